// The row kernels of gelu_layer_norm.cc: GELU and LayerNorm over rows of a CPU activation
// stored as bfloat16 (uint16_t) or float, statistics and arithmetic in fp32. This file needs no
// LibTorch, so it builds quickly with its own flags (OpenMP SIMD, no trapping math, 512-bit
// vectors), while the ops around it share the precompiled LibTorch header.
#include "gelu_layer_norm_kernels.h"

#include <cmath>
#include <cstdint>
#include <cstring>

// The row kernels are plain loops that the compiler vectorises; on x86-64 with
// GCC they are compiled for AVX-512, AVX2 and the baseline, and the loader
// picks the best the CPU has (the binary stays portable).
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define MSSPR_ROW_KERNEL __attribute__((target_clones("arch=x86-64-v4", "avx2", "default")))
#else
#define MSSPR_ROW_KERNEL
#endif

namespace msspr {
namespace core {
namespace internal {
namespace {

inline float ToFloat(uint16_t v) {
  const uint32_t u = static_cast<uint32_t>(v) << 16;
  float f;
  std::memcpy(&f, &u, sizeof f);
  return f;
}

// Round to nearest even, NaN kept quiet: c10::BFloat16's conversion, branch-free.
inline uint16_t ToBf16(float f) {
  uint32_t u;
  std::memcpy(&u, &f, sizeof u);
  const uint32_t rounded = (u + 0x7FFFu + ((u >> 16) & 1u)) >> 16;
  return static_cast<uint16_t>((u & 0x7FFFFFFFu) > 0x7F800000u ? 0x7FC0u : rounded);
}

// exp(x) for x <= 0 (here -x^2 / 2): 2^n * p(r) with x = n ln2 + r, |r| <= ln2 / 2,
// p a degree-6 Taylor polynomial (relative error under 2e-7); 0 below -87.
inline float ExpNonPositive(float x) {
  x = x < -87.0f ? -87.0f : x;
  const float n = __builtin_floorf(x * 1.44269504f + 0.5f);
  const float r = (x - n * 0.693145752f) - n * 1.42860677e-6f;
  float p = 1.0f / 720.0f;
  p = p * r + 1.0f / 120.0f;
  p = p * r + 1.0f / 24.0f;
  p = p * r + 1.0f / 6.0f;
  p = p * r + 0.5f;
  p = p * r + 1.0f;
  p = p * r + 1.0f;
  const uint32_t bits = static_cast<uint32_t>(static_cast<int32_t>(n) + 127) << 23;
  float scale;
  std::memcpy(&scale, &bits, sizeof scale);
  return p * scale;
}

// The exact GELU, x * Phi(x), and (with `dgelu`) its derivative Phi(x) + x phi(x),
// in fp32. erfc by Abramowitz and Stegun 7.1.26 (absolute error under 1.5e-7), the
// approximation ATen's vectorised erf uses; Phi(x) = erfc(-x / sqrt 2) / 2 keeps
// the negative tail free of cancellation.
inline float Gelu(float x, float* dgelu) {
  const float z = std::fabs(x) * 0.707106781f;
  const float t = 1.0f / (1.0f + 0.3275911f * z);
  float poly = 1.061405429f;
  poly = poly * t - 1.453152027f;
  poly = poly * t + 1.421413741f;
  poly = poly * t - 0.284496736f;
  poly = poly * t + 0.254829592f;
  const float e = ExpNonPositive(-0.5f * x * x);
  const float tail = 0.5f * poly * t * e;  // 1 - Phi(|x|), without cancellation
  const float phi_cdf = x < 0.0f ? tail : 1.0f - tail;
  if (dgelu) *dgelu = phi_cdf + x * e * 0.398942280f;
  return x * phi_cdf;
}

// An activation's storage: bfloat16 bits (uint16_t) or fp32. Load reads one
// element as fp32, Stored<T> rounds an fp32 value to T's storage, and Kept<T>
// is the value T keeps (bfloat16's rounding, or fp32 as it is).
inline float Load(uint16_t v) { return ToFloat(v); }
inline float Load(float v) { return v; }
template <typename T>
inline T Stored(float f);
template <>
inline uint16_t Stored<uint16_t>(float f) {
  return ToBf16(f);
}
template <>
inline float Stored<float>(float f) {
  return f;
}
template <typename T>
inline float Kept(float f) {
  return Load(Stored<T>(f));
}

template <typename T>
__attribute__((always_inline)) inline void GeluRows(const T* x, T* y, int64_t begin, int64_t end) {
#pragma omp simd
  for (int64_t i = begin; i < end; ++i) y[i] = Stored<T>(Gelu(Load(x[i]), nullptr));
}

// dx = dy * GELU'(x); dy of the activation's type (dyt) or fp32 (dy32).
template <typename T>
__attribute__((always_inline)) inline void GeluBackwardRows(const T* x, const T* dyt,
                                                            const float* dy32, T* dx, int64_t begin,
                                                            int64_t end) {
  if (dyt) {
#pragma omp simd
    for (int64_t i = begin; i < end; ++i) {
      float d;
      Gelu(Load(x[i]), &d);
      dx[i] = Stored<T>(Load(dyt[i]) * d);
    }
  } else {
#pragma omp simd
    for (int64_t i = begin; i < end; ++i) {
      float d;
      Gelu(Load(x[i]), &d);
      dx[i] = Stored<T>(dy32[i] * d);
    }
  }
}

// LayerNorm over rows of x (kGelu false), or of u = GELU(x) as T keeps it (for
// bfloat16: rounded, as a bfloat16 GELU op would hand it on). Inlined into each
// compiled copy of the kernels below.
template <typename T, bool kGelu>
__attribute__((always_inline)) inline void NormRows(const T* x, const float* w, const float* b,
                                                    T* y, float* mean, float* rstd, int64_t begin,
                                                    int64_t end, int64_t d, float eps, float* buf) {
  const float inv_d = 1.0f / static_cast<float>(d);
  for (int64_t r = begin; r < end; ++r) {
    const T* xr = x + r * d;
    T* yr = y + r * d;
    float s = 0.0f;
#pragma omp simd reduction(+ : s)
    for (int64_t i = 0; i < d; ++i) {
      const float v = kGelu ? Kept<T>(Gelu(Load(xr[i]), nullptr)) : Load(xr[i]);
      buf[i] = v;
      s += v;
    }
    const float m = s * inv_d;
    float q = 0.0f;
#pragma omp simd reduction(+ : q)
    for (int64_t i = 0; i < d; ++i) {
      const float c = buf[i] - m;
      q += c * c;
    }
    const float rs = 1.0f / std::sqrt(q * inv_d + eps);
#pragma omp simd
    for (int64_t i = 0; i < d; ++i) yr[i] = Stored<T>((buf[i] - m) * rs * w[i] + b[i]);
    mean[r] = m;
    rstd[r] = rs;
  }
}

// The LayerNorm's backward: dx = rstd * (g - mean(g) - xhat * mean(g * xhat)) with
// g = dy * weight; dweight += dy * xhat and dbias += dy over the rows. dy is of
// the activation's type (dyt) or fp32 (dy32). With kGelu, the GELU's backward
// follows: dx = du * GELU'(x), du the LayerNorm's dx as T keeps it.
template <typename T, bool kGelu>
__attribute__((always_inline)) inline void NormBackwardRows(const T* x, const T* dyt,
                                                            const float* dy32, const float* w,
                                                            const float* mean, const float* rstd,
                                                            T* dx, float* dw, float* db,
                                                            int64_t begin, int64_t end, int64_t d,
                                                            float* xh, float* gw, float* dg) {
  const float inv_d = 1.0f / static_cast<float>(d);
  for (int64_t r = begin; r < end; ++r) {
    const T* xr = x + r * d;
    const float m = mean[r], rs = rstd[r];
    if (dyt) {
      const T* gr = dyt + r * d;
#pragma omp simd
      for (int64_t i = 0; i < d; ++i) gw[i] = Load(gr[i]);
    } else {
      std::memcpy(gw, dy32 + r * d, sizeof(float) * static_cast<size_t>(d));
    }
    float s1 = 0.0f, s2 = 0.0f;
#pragma omp simd reduction(+ : s1, s2)
    for (int64_t i = 0; i < d; ++i) {
      float dgelu = 1.0f;
      const float u = kGelu ? Kept<T>(Gelu(Load(xr[i]), &dgelu)) : Load(xr[i]);
      const float xhat = (u - m) * rs;
      const float g = gw[i];
      db[i] += g;
      dw[i] += g * xhat;
      const float gwi = g * w[i];
      xh[i] = xhat;
      gw[i] = gwi;
      if (kGelu) dg[i] = dgelu;
      s1 += gwi;
      s2 += gwi * xhat;
    }
    const float c1 = s1 * inv_d, c2 = s2 * inv_d;
    T* dxr = dx + r * d;
#pragma omp simd
    for (int64_t i = 0; i < d; ++i) {
      const float du = rs * (gw[i] - c1 - xh[i] * c2);
      dxr[i] = kGelu ? Stored<T>(Kept<T>(du) * dg[i]) : Stored<T>(du);
    }
  }
}

}  // namespace

// The compiled kernels, one overload per storage type (target_clones takes
// plain functions, not templates).
#define MSSPR_DEFINE_ROW_KERNELS(T)                                                               \
  MSSPR_ROW_KERNEL void GeluForward(const T* x, T* y, int64_t begin, int64_t end) {               \
    GeluRows<T>(x, y, begin, end);                                                                \
  }                                                                                               \
  MSSPR_ROW_KERNEL void GeluBackward(const T* x, const T* dyt, const float* dy32, T* dx,          \
                                     int64_t begin, int64_t end) {                                \
    GeluBackwardRows<T>(x, dyt, dy32, dx, begin, end);                                            \
  }                                                                                               \
  MSSPR_ROW_KERNEL void ForwardRows(bool gelu, const T* x, const float* w, const float* b, T* y,  \
                                    float* mean, float* rstd, int64_t begin, int64_t end,         \
                                    int64_t d, float eps, float* buf) {                           \
    if (gelu)                                                                                     \
      NormRows<T, true>(x, w, b, y, mean, rstd, begin, end, d, eps, buf);                         \
    else                                                                                          \
      NormRows<T, false>(x, w, b, y, mean, rstd, begin, end, d, eps, buf);                        \
  }                                                                                               \
  MSSPR_ROW_KERNEL void BackwardRows(bool gelu, const T* x, const T* dyt, const float* dy32,      \
                                     const float* w, const float* mean, const float* rstd, T* dx, \
                                     float* dw, float* db, int64_t begin, int64_t end, int64_t d, \
                                     float* xh, float* gw, float* dg) {                           \
    if (gelu)                                                                                     \
      NormBackwardRows<T, true>(x, dyt, dy32, w, mean, rstd, dx, dw, db, begin, end, d, xh, gw,   \
                                dg);                                                              \
    else                                                                                          \
      NormBackwardRows<T, false>(x, dyt, dy32, w, mean, rstd, dx, dw, db, begin, end, d, xh, gw,  \
                                 dg);                                                             \
  }
MSSPR_DEFINE_ROW_KERNELS(uint16_t)
MSSPR_DEFINE_ROW_KERNELS(float)
#undef MSSPR_DEFINE_ROW_KERNELS

}  // namespace internal
}  // namespace core
}  // namespace msspr
