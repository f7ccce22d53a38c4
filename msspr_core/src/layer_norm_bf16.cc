#include "layer_norm_bf16.h"

#include <ATen/Parallel.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <memory>
#include <vector>

// The row kernels are plain loops that the compiler vectorises; on x86-64 with
// GCC they are compiled for AVX-512, AVX2 and the baseline, and the loader
// picks the best the CPU has (the binary stays portable).
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__)
#define MSSPR_ROW_KERNEL __attribute__((target_clones("avx512f", "avx2", "default")))
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

MSSPR_ROW_KERNEL
void ForwardRows(const uint16_t* x, const float* w, const float* b, uint16_t* y, float* mean,
                 float* rstd, int64_t begin, int64_t end, int64_t d, float eps, float* buf) {
  const float inv_d = 1.0f / static_cast<float>(d);
  for (int64_t r = begin; r < end; ++r) {
    const uint16_t* xr = x + r * d;
    uint16_t* yr = y + r * d;
    float s = 0.0f;
#pragma omp simd reduction(+ : s)
    for (int64_t i = 0; i < d; ++i) {
      const float v = ToFloat(xr[i]);
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
    for (int64_t i = 0; i < d; ++i) yr[i] = ToBf16((buf[i] - m) * rs * w[i] + b[i]);
    mean[r] = m;
    rstd[r] = rs;
  }
}

// dx = rstd * (g - mean(g) - xhat * mean(g * xhat)) with g = dy * weight;
// dweight += dy * xhat and dbias += dy over the rows. dy is bfloat16 (dy16)
// or fp32 (dy32).
MSSPR_ROW_KERNEL
void BackwardRows(const uint16_t* x, const uint16_t* dy16, const float* dy32, const float* w,
                  const float* mean, const float* rstd, uint16_t* dx, float* dw, float* db,
                  int64_t begin, int64_t end, int64_t d, float* xh, float* gw) {
  const float inv_d = 1.0f / static_cast<float>(d);
  for (int64_t r = begin; r < end; ++r) {
    const uint16_t* xr = x + r * d;
    const float m = mean[r], rs = rstd[r];
    if (dy16) {
      const uint16_t* gr = dy16 + r * d;
#pragma omp simd
      for (int64_t i = 0; i < d; ++i) gw[i] = ToFloat(gr[i]);
    } else {
      std::memcpy(gw, dy32 + r * d, sizeof(float) * static_cast<size_t>(d));
    }
    float s1 = 0.0f, s2 = 0.0f;
#pragma omp simd reduction(+ : s1, s2)
    for (int64_t i = 0; i < d; ++i) {
      const float xhat = (ToFloat(xr[i]) - m) * rs;
      const float g = gw[i];
      db[i] += g;
      dw[i] += g * xhat;
      const float gwi = g * w[i];
      xh[i] = xhat;
      gw[i] = gwi;
      s1 += gwi;
      s2 += gwi * xhat;
    }
    const float c1 = s1 * inv_d, c2 = s2 * inv_d;
    uint16_t* dxr = dx + r * d;
#pragma omp simd
    for (int64_t i = 0; i < d; ++i) dxr[i] = ToBf16(rs * (gw[i] - c1 - xh[i] * c2));
  }
}

// Rows per parallel chunk: small enough to spread a batch over threads, large
// enough that a thread's hand-off costs less than its rows.
constexpr int64_t kGrain = 64;

const uint16_t* Bits(const torch::Tensor& t) {
  return reinterpret_cast<const uint16_t*>(t.data_ptr<at::BFloat16>());
}
uint16_t* MutableBits(torch::Tensor& t) {
  return reinterpret_cast<uint16_t*>(t.data_ptr<at::BFloat16>());
}

class LayerNormBf16Fn : public torch::autograd::Function<LayerNormBf16Fn> {
 public:
  static torch::Tensor forward(torch::autograd::AutogradContext* ctx, const torch::Tensor& x_in,
                               const torch::Tensor& weight, const torch::Tensor& bias, double eps) {
    const torch::Tensor x = x_in.contiguous();
    const int64_t d = x.size(-1), rows = d > 0 ? x.numel() / d : 0;
    const torch::Tensor w = weight.contiguous(), b = bias.contiguous();
    torch::Tensor y = torch::empty_like(x);
    torch::Tensor mean = torch::empty({rows}, x.options().dtype(torch::kFloat32));
    torch::Tensor rstd = torch::empty({rows}, x.options().dtype(torch::kFloat32));
    const uint16_t* xp = Bits(x);
    uint16_t* yp = MutableBits(y);
    const float *wp = w.data_ptr<float>(), *bp = b.data_ptr<float>();
    float *mp = mean.data_ptr<float>(), *rp = rstd.data_ptr<float>();
    const float e = static_cast<float>(eps);
    at::parallel_for(0, rows, kGrain, [&](int64_t begin, int64_t end) {
      std::unique_ptr<float[]> buf(new float[static_cast<size_t>(d)]);
      ForwardRows(xp, wp, bp, yp, mp, rp, begin, end, d, e, buf.get());
    });
    ctx->save_for_backward({x, w, mean, rstd});
    return y;
  }

  static torch::autograd::tensor_list backward(torch::autograd::AutogradContext* ctx,
                                               torch::autograd::tensor_list grads) {
    const auto saved = ctx->get_saved_variables();
    const torch::Tensor &x = saved[0], &w = saved[1], &mean = saved[2], &rstd = saved[3];
    const int64_t d = x.size(-1), rows = d > 0 ? x.numel() / d : 0;
    torch::Tensor dy = grads[0];
    if (dy.scalar_type() != torch::kBFloat16) dy = dy.to(torch::kFloat32);
    dy = dy.contiguous();
    const bool bf = dy.scalar_type() == torch::kBFloat16;
    torch::Tensor dx = torch::empty_like(x);
    // Per-thread partial sums of dweight and dbias, added up after.
    const int64_t threads = std::max<int64_t>(1, at::get_num_threads());
    torch::Tensor partial = torch::zeros({threads, 2, d}, x.options().dtype(torch::kFloat32));
    const uint16_t* xp = Bits(x);
    const uint16_t* dy16 = bf ? Bits(dy) : nullptr;
    const float* dy32 = bf ? nullptr : dy.data_ptr<float>();
    const float *wp = w.data_ptr<float>(), *mp = mean.data_ptr<float>(),
                *rp = rstd.data_ptr<float>();
    uint16_t* dxp = MutableBits(dx);
    float* pp = partial.data_ptr<float>();
    at::parallel_for(0, rows, kGrain, [&](int64_t begin, int64_t end) {
      const int64_t t = std::min<int64_t>(at::get_thread_num(), threads - 1);
      std::unique_ptr<float[]> buf(new float[2 * static_cast<size_t>(d)]);
      BackwardRows(xp, dy16, dy32, wp, mp, rp, dxp, pp + (t * 2) * d, pp + (t * 2 + 1) * d, begin,
                   end, d, buf.get(), buf.get() + d);
    });
    const torch::Tensor sums = threads == 1 ? partial[0] : partial.sum(0);
    return {dx, sums[0], sums[1], torch::Tensor()};
  }
};

}  // namespace

torch::Tensor LayerNormBf16(const torch::Tensor& x, const torch::Tensor& weight,
                            const torch::Tensor& bias, double eps) {
  TORCH_CHECK(UseLayerNormBf16(x), "LayerNormBf16 takes a bfloat16 CPU tensor, got ",
              x.scalar_type(), " on ", x.device());
  TORCH_CHECK(weight.scalar_type() == torch::kFloat32 && bias.scalar_type() == torch::kFloat32,
              "LayerNormBf16 takes fp32 weight and bias");
  TORCH_CHECK(x.dim() >= 1 && weight.numel() == x.size(-1) && bias.numel() == x.size(-1),
              "LayerNormBf16: weight and bias must have the last dimension's size ",
              x.dim() >= 1 ? x.size(-1) : 0);
  return LayerNormBf16Fn::apply(x, weight, bias, eps);
}

}  // namespace internal
}  // namespace core
}  // namespace msspr
