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

MSSPR_ROW_KERNEL
void GeluForward(const uint16_t* x, uint16_t* y, int64_t begin, int64_t end) {
#pragma omp simd
  for (int64_t i = begin; i < end; ++i) y[i] = ToBf16(Gelu(ToFloat(x[i]), nullptr));
}

// dx = dy * GELU'(x); dy bfloat16 (dy16) or fp32 (dy32).
MSSPR_ROW_KERNEL
void GeluBackward(const uint16_t* x, const uint16_t* dy16, const float* dy32, uint16_t* dx,
                  int64_t begin, int64_t end) {
  if (dy16) {
#pragma omp simd
    for (int64_t i = begin; i < end; ++i) {
      float d;
      Gelu(ToFloat(x[i]), &d);
      dx[i] = ToBf16(ToFloat(dy16[i]) * d);
    }
  } else {
#pragma omp simd
    for (int64_t i = begin; i < end; ++i) {
      float d;
      Gelu(ToFloat(x[i]), &d);
      dx[i] = ToBf16(dy32[i] * d);
    }
  }
}

// LayerNorm over rows of x (kGelu false), or of u = bf16(GELU(x)): the GELU's
// output rounded to bfloat16, as a bfloat16 GELU op would hand it on. Inlined
// into each compiled copy of the kernels below.
template <bool kGelu>
__attribute__((always_inline)) inline void NormRows(const uint16_t* x, const float* w,
                                                    const float* b, uint16_t* y, float* mean,
                                                    float* rstd, int64_t begin, int64_t end,
                                                    int64_t d, float eps, float* buf) {
  const float inv_d = 1.0f / static_cast<float>(d);
  for (int64_t r = begin; r < end; ++r) {
    const uint16_t* xr = x + r * d;
    uint16_t* yr = y + r * d;
    float s = 0.0f;
#pragma omp simd reduction(+ : s)
    for (int64_t i = 0; i < d; ++i) {
      const float v = kGelu ? ToFloat(ToBf16(Gelu(ToFloat(xr[i]), nullptr))) : ToFloat(xr[i]);
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

// The LayerNorm's backward: dx = rstd * (g - mean(g) - xhat * mean(g * xhat)) with
// g = dy * weight; dweight += dy * xhat and dbias += dy over the rows. dy is
// bfloat16 (dy16) or fp32 (dy32). With kGelu, the GELU's backward follows:
// dx = bf16(du) * GELU'(x), du the LayerNorm's dx rounded to bfloat16.
template <bool kGelu>
__attribute__((always_inline)) inline void NormBackwardRows(const uint16_t* x, const uint16_t* dy16,
                                                            const float* dy32, const float* w,
                                                            const float* mean, const float* rstd,
                                                            uint16_t* dx, float* dw, float* db,
                                                            int64_t begin, int64_t end, int64_t d,
                                                            float* xh, float* gw, float* dg) {
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
      float dgelu = 1.0f;
      const float u = kGelu ? ToFloat(ToBf16(Gelu(ToFloat(xr[i]), &dgelu))) : ToFloat(xr[i]);
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
    uint16_t* dxr = dx + r * d;
#pragma omp simd
    for (int64_t i = 0; i < d; ++i) {
      const float du = rs * (gw[i] - c1 - xh[i] * c2);
      dxr[i] = kGelu ? ToBf16(ToFloat(ToBf16(du)) * dg[i]) : ToBf16(du);
    }
  }
}

MSSPR_ROW_KERNEL
void ForwardRows(const uint16_t* x, const float* w, const float* b, uint16_t* y, float* mean,
                 float* rstd, int64_t begin, int64_t end, int64_t d, float eps, float* buf) {
  NormRows<false>(x, w, b, y, mean, rstd, begin, end, d, eps, buf);
}

MSSPR_ROW_KERNEL
void GeluForwardRows(const uint16_t* x, const float* w, const float* b, uint16_t* y, float* mean,
                     float* rstd, int64_t begin, int64_t end, int64_t d, float eps, float* buf) {
  NormRows<true>(x, w, b, y, mean, rstd, begin, end, d, eps, buf);
}

MSSPR_ROW_KERNEL
void BackwardRows(const uint16_t* x, const uint16_t* dy16, const float* dy32, const float* w,
                  const float* mean, const float* rstd, uint16_t* dx, float* dw, float* db,
                  int64_t begin, int64_t end, int64_t d, float* xh, float* gw) {
  NormBackwardRows<false>(x, dy16, dy32, w, mean, rstd, dx, dw, db, begin, end, d, xh, gw, nullptr);
}

MSSPR_ROW_KERNEL
void GeluBackwardRows(const uint16_t* x, const uint16_t* dy16, const float* dy32, const float* w,
                      const float* mean, const float* rstd, uint16_t* dx, float* dw, float* db,
                      int64_t begin, int64_t end, int64_t d, float* xh, float* gw, float* dg) {
  NormBackwardRows<true>(x, dy16, dy32, w, mean, rstd, dx, dw, db, begin, end, d, xh, gw, dg);
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

// An incoming gradient as the backward kernels read it: bfloat16 as it comes,
// anything else as fp32; contiguous. Exactly one of bf16 and fp32 is set.
struct GradIn {
  explicit GradIn(const torch::Tensor& dy)
      : t((dy.scalar_type() == torch::kBFloat16 ? dy : dy.to(torch::kFloat32)).contiguous()),
        bf16(t.scalar_type() == torch::kBFloat16 ? Bits(t) : nullptr),
        fp32(bf16 ? nullptr : t.data_ptr<float>()) {}
  torch::Tensor t;
  const uint16_t* bf16;
  const float* fp32;
};

class LayerNormBf16Fn : public torch::autograd::Function<LayerNormBf16Fn> {
 public:
  // gelu: the LayerNorm of bf16(GELU(x)) (GeluLayerNormBf16).
  static torch::Tensor forward(torch::autograd::AutogradContext* ctx, const torch::Tensor& x_in,
                               const torch::Tensor& weight, const torch::Tensor& bias, double eps,
                               bool gelu) {
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
      if (gelu)
        GeluForwardRows(xp, wp, bp, yp, mp, rp, begin, end, d, e, buf.get());
      else
        ForwardRows(xp, wp, bp, yp, mp, rp, begin, end, d, e, buf.get());
    });
    ctx->save_for_backward({x, w, mean, rstd});
    ctx->saved_data["gelu"] = gelu;
    return y;
  }

  static torch::autograd::tensor_list backward(torch::autograd::AutogradContext* ctx,
                                               torch::autograd::tensor_list grads) {
    const auto saved = ctx->get_saved_variables();
    const torch::Tensor &x = saved[0], &w = saved[1], &mean = saved[2], &rstd = saved[3];
    const bool gelu = ctx->saved_data["gelu"].toBool();
    const int64_t d = x.size(-1), rows = d > 0 ? x.numel() / d : 0;
    const GradIn dy(grads[0]);
    torch::Tensor dx = torch::empty_like(x);
    // Per-thread partial sums of dweight and dbias, added up after.
    const int64_t threads = std::max<int64_t>(1, at::get_num_threads());
    torch::Tensor partial = torch::zeros({threads, 2, d}, x.options().dtype(torch::kFloat32));
    const uint16_t* xp = Bits(x);
    const uint16_t* dy16 = dy.bf16;
    const float* dy32 = dy.fp32;
    const float *wp = w.data_ptr<float>(), *mp = mean.data_ptr<float>(),
                *rp = rstd.data_ptr<float>();
    uint16_t* dxp = MutableBits(dx);
    float* pp = partial.data_ptr<float>();
    at::parallel_for(0, rows, kGrain, [&](int64_t begin, int64_t end) {
      const int64_t t = std::min<int64_t>(at::get_thread_num(), threads - 1);
      std::unique_ptr<float[]> buf(new float[3 * static_cast<size_t>(d)]);
      float *dw = pp + (t * 2) * d, *db = pp + (t * 2 + 1) * d;
      if (gelu)
        GeluBackwardRows(xp, dy16, dy32, wp, mp, rp, dxp, dw, db, begin, end, d, buf.get(),
                         buf.get() + d, buf.get() + 2 * d);
      else
        BackwardRows(xp, dy16, dy32, wp, mp, rp, dxp, dw, db, begin, end, d, buf.get(),
                     buf.get() + d);
    });
    const torch::Tensor sums = threads == 1 ? partial[0] : partial.sum(0);
    return {dx, sums[0], sums[1], torch::Tensor(), torch::Tensor()};
  }
};

// Elements per parallel chunk of the elementwise GELU.
constexpr int64_t kGeluGrain = 16384;

class GeluBf16Fn : public torch::autograd::Function<GeluBf16Fn> {
 public:
  static torch::Tensor forward(torch::autograd::AutogradContext* ctx, const torch::Tensor& x_in) {
    const torch::Tensor x = x_in.contiguous();
    torch::Tensor y = torch::empty_like(x);
    const uint16_t* xp = Bits(x);
    uint16_t* yp = MutableBits(y);
    at::parallel_for(0, x.numel(), kGeluGrain,
                     [&](int64_t begin, int64_t end) { GeluForward(xp, yp, begin, end); });
    ctx->save_for_backward({x});
    return y;
  }

  static torch::autograd::tensor_list backward(torch::autograd::AutogradContext* ctx,
                                               torch::autograd::tensor_list grads) {
    const torch::Tensor x = ctx->get_saved_variables()[0];
    const GradIn dy(grads[0]);
    torch::Tensor dx = torch::empty_like(x);
    const uint16_t* xp = Bits(x);
    uint16_t* dxp = MutableBits(dx);
    at::parallel_for(0, x.numel(), kGeluGrain, [&](int64_t begin, int64_t end) {
      GeluBackward(xp, dy.bf16, dy.fp32, dxp, begin, end);
    });
    return {dx};
  }
};

void CheckNormArgs(const char* op, const torch::Tensor& x, const torch::Tensor& weight,
                   const torch::Tensor& bias) {
  TORCH_CHECK(UseLayerNormBf16(x), op, " takes a bfloat16 CPU tensor, got ", x.scalar_type(),
              " on ", x.device());
  TORCH_CHECK(weight.scalar_type() == torch::kFloat32 && bias.scalar_type() == torch::kFloat32, op,
              " takes fp32 weight and bias");
  TORCH_CHECK(x.dim() >= 1 && weight.numel() == x.size(-1) && bias.numel() == x.size(-1), op,
              ": weight and bias must have the last dimension's size ",
              x.dim() >= 1 ? x.size(-1) : 0);
}

}  // namespace

torch::Tensor LayerNormBf16(const torch::Tensor& x, const torch::Tensor& weight,
                            const torch::Tensor& bias, double eps) {
  CheckNormArgs("LayerNormBf16", x, weight, bias);
  return LayerNormBf16Fn::apply(x, weight, bias, eps, false);
}

torch::Tensor GeluLayerNormBf16(const torch::Tensor& x, const torch::Tensor& weight,
                                const torch::Tensor& bias, double eps) {
  CheckNormArgs("GeluLayerNormBf16", x, weight, bias);
  return LayerNormBf16Fn::apply(x, weight, bias, eps, true);
}

torch::Tensor GeluBf16(const torch::Tensor& x) {
  TORCH_CHECK(UseLayerNormBf16(x), "GeluBf16 takes a bfloat16 CPU tensor, got ", x.scalar_type(),
              " on ", x.device());
  return GeluBf16Fn::apply(x);
}

}  // namespace internal
}  // namespace core
}  // namespace msspr
