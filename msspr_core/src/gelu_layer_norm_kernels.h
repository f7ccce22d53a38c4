// The row kernels of the fused GELU + LayerNorm ops (gelu_layer_norm.h), one overload per
// storage type: bfloat16 as uint16_t, and float. Statistics and arithmetic in fp32; [begin,
// end) are rows of length d (elements for the GELU kernels). Compiled on x86-64 for AVX-512,
// AVX2 and the baseline; the loader picks the best the CPU has.
#pragma once

#include <cstdint>

namespace msspr {
namespace core {
namespace internal {

#define MSSPR_DECLARE_ROW_KERNELS(T)                                                           \
  /* y = GELU(x), elementwise */                                                               \
  void GeluForward(const T* x, T* y, int64_t begin, int64_t end);                              \
  /* dx = dy * GELU'(x); dy of the activation's type (dyt) or fp32 (dy32), the other null */   \
  void GeluBackward(const T* x, const T* dyt, const float* dy32, T* dx, int64_t begin,         \
                    int64_t end);                                                              \
  /* LayerNorm of x's rows (of GELU(x) with gelu); mean and 1/std per row; buf: d floats */    \
  void ForwardRows(bool gelu, const T* x, const float* w, const float* b, T* y, float* mean,   \
                   float* rstd, int64_t begin, int64_t end, int64_t d, float eps, float* buf); \
  /* Its backward: dx, and this chunk's sums into dw and db; xh, gw, dg: d floats each */      \
  void BackwardRows(bool gelu, const T* x, const T* dyt, const float* dy32, const float* w,    \
                    const float* mean, const float* rstd, T* dx, float* dw, float* db,         \
                    int64_t begin, int64_t end, int64_t d, float* xh, float* gw, float* dg);
MSSPR_DECLARE_ROW_KERNELS(uint16_t)
MSSPR_DECLARE_ROW_KERNELS(float)
#undef MSSPR_DECLARE_ROW_KERNELS

}  // namespace internal
}  // namespace core
}  // namespace msspr
