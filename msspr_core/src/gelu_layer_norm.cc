#include "gelu_layer_norm.h"

#include <ATen/Parallel.h>

#include <memory>
#include <type_traits>
#include <vector>

#include "gelu_layer_norm_kernels.h"

namespace msspr {
namespace core {
namespace internal {
namespace {

// Rows per parallel chunk: small enough to spread a batch over threads, large
// enough that a thread's hand-off costs less than its rows.
constexpr int64_t kGrain = 64;

// The elements of a CPU tensor as the kernels read them.
template <typename T>
const T* Data(const torch::Tensor& t);
template <>
const uint16_t* Data<uint16_t>(const torch::Tensor& t) {
  return reinterpret_cast<const uint16_t*>(t.data_ptr<at::BFloat16>());
}
template <>
const float* Data<float>(const torch::Tensor& t) {
  return t.data_ptr<float>();
}
template <typename T>
T* MutableData(torch::Tensor& t) {
  return const_cast<T*>(Data<T>(t));
}

// An incoming gradient as the backward kernels read it: of the activation's type
// (T) as it comes, anything else as fp32; contiguous. Exactly one of same and
// fp32 is set.
template <typename T>
struct GradIn {
  explicit GradIn(const torch::Tensor& dy)
      : t((dy.scalar_type() == kType ? dy : dy.to(torch::kFloat32)).contiguous()),
        same(t.scalar_type() == kType ? Data<T>(t) : nullptr),
        fp32(same ? nullptr : t.data_ptr<float>()) {}
  static constexpr torch::ScalarType kType =
      std::is_same<T, float>::value ? torch::kFloat32 : torch::kBFloat16;
  torch::Tensor t;
  const T* same;
  const float* fp32;
};

// LayerNorm (optionally of GELU(x)) over the last dimension of a CPU activation
// stored as T; statistics and arithmetic in fp32.
template <typename T>
class RowNormFn : public torch::autograd::Function<RowNormFn<T>> {
 public:
  static torch::Tensor forward(torch::autograd::AutogradContext* ctx, const torch::Tensor& x_in,
                               const torch::Tensor& weight, const torch::Tensor& bias, double eps,
                               bool gelu) {
    const torch::Tensor x = x_in.contiguous();
    const int64_t d = x.size(-1), rows = d > 0 ? x.numel() / d : 0;
    const torch::Tensor w = weight.contiguous(), b = bias.contiguous();
    torch::Tensor y = torch::empty_like(x);
    torch::Tensor mean = torch::empty({rows}, x.options().dtype(torch::kFloat32));
    torch::Tensor rstd = torch::empty({rows}, x.options().dtype(torch::kFloat32));
    const T* xp = Data<T>(x);
    T* yp = MutableData<T>(y);
    const float *wp = w.data_ptr<float>(), *bp = b.data_ptr<float>();
    float *mp = mean.data_ptr<float>(), *rp = rstd.data_ptr<float>();
    const float e = static_cast<float>(eps);
    at::parallel_for(0, rows, kGrain, [&](int64_t begin, int64_t end) {
      std::unique_ptr<float[]> buf(new float[static_cast<size_t>(d)]);
      ForwardRows(gelu, xp, wp, bp, yp, mp, rp, begin, end, d, e, buf.get());
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
    const GradIn<T> dy(grads[0]);
    torch::Tensor dx = torch::empty_like(x);
    // Per-thread partial sums of dweight and dbias, added up after.
    const int64_t threads = std::max<int64_t>(1, at::get_num_threads());
    torch::Tensor partial = torch::zeros({threads, 2, d}, x.options().dtype(torch::kFloat32));
    const T* xp = Data<T>(x);
    const float *wp = w.data_ptr<float>(), *mp = mean.data_ptr<float>(),
                *rp = rstd.data_ptr<float>();
    T* dxp = MutableData<T>(dx);
    float* pp = partial.data_ptr<float>();
    at::parallel_for(0, rows, kGrain, [&](int64_t begin, int64_t end) {
      const int64_t t = std::min<int64_t>(at::get_thread_num(), threads - 1);
      std::unique_ptr<float[]> buf(new float[3 * static_cast<size_t>(d)]);
      float *dw = pp + (t * 2) * d, *db = pp + (t * 2 + 1) * d;
      BackwardRows(gelu, xp, dy.same, dy.fp32, wp, mp, rp, dxp, dw, db, begin, end, d, buf.get(),
                   buf.get() + d, buf.get() + 2 * d);
    });
    const torch::Tensor sums = threads == 1 ? partial[0] : partial.sum(0);
    return {dx, sums[0], sums[1], torch::Tensor(), torch::Tensor()};
  }
};

// Elements per parallel chunk of the elementwise GELU.
constexpr int64_t kGeluGrain = 16384;

template <typename T>
class GeluFn : public torch::autograd::Function<GeluFn<T>> {
 public:
  static torch::Tensor forward(torch::autograd::AutogradContext* ctx, const torch::Tensor& x_in) {
    const torch::Tensor x = x_in.contiguous();
    torch::Tensor y = torch::empty_like(x);
    const T* xp = Data<T>(x);
    T* yp = MutableData<T>(y);
    at::parallel_for(0, x.numel(), kGeluGrain,
                     [&](int64_t begin, int64_t end) { GeluForward(xp, yp, begin, end); });
    ctx->save_for_backward({x});
    return y;
  }

  static torch::autograd::tensor_list backward(torch::autograd::AutogradContext* ctx,
                                               torch::autograd::tensor_list grads) {
    const torch::Tensor x = ctx->get_saved_variables()[0];
    const GradIn<T> dy(grads[0]);
    torch::Tensor dx = torch::empty_like(x);
    const T* xp = Data<T>(x);
    T* dxp = MutableData<T>(dx);
    at::parallel_for(0, x.numel(), kGeluGrain, [&](int64_t begin, int64_t end) {
      GeluBackward(xp, dy.same, dy.fp32, dxp, begin, end);
    });
    return {dx};
  }
};

// x is the CPU tensor op takes (takes_x: of x_kind, "bfloat16" or "float32").
void CheckInput(const char* op, bool takes_x, const char* x_kind, const torch::Tensor& x) {
  TORCH_CHECK(takes_x, op, " takes a ", x_kind, " CPU tensor, got ", x.scalar_type(), " on ",
              x.device());
}

void CheckNormArgs(const char* op, bool takes_x, const char* x_kind, const torch::Tensor& x,
                   const torch::Tensor& weight, const torch::Tensor& bias) {
  CheckInput(op, takes_x, x_kind, x);
  TORCH_CHECK(weight.scalar_type() == torch::kFloat32 && bias.scalar_type() == torch::kFloat32, op,
              " takes fp32 weight and bias");
  TORCH_CHECK(x.dim() >= 1 && weight.numel() == x.size(-1) && bias.numel() == x.size(-1), op,
              ": weight and bias must have the last dimension's size ",
              x.dim() >= 1 ? x.size(-1) : 0);
}

}  // namespace

torch::Tensor LayerNormBf16(const torch::Tensor& x, const torch::Tensor& weight,
                            const torch::Tensor& bias, double eps) {
  CheckNormArgs("LayerNormBf16", UseLayerNormBf16(x), "bfloat16", x, weight, bias);
  return RowNormFn<uint16_t>::apply(x, weight, bias, eps, false);
}

torch::Tensor GeluLayerNormBf16(const torch::Tensor& x, const torch::Tensor& weight,
                                const torch::Tensor& bias, double eps) {
  CheckNormArgs("GeluLayerNormBf16", UseLayerNormBf16(x), "bfloat16", x, weight, bias);
  return RowNormFn<uint16_t>::apply(x, weight, bias, eps, true);
}

torch::Tensor GeluBf16(const torch::Tensor& x) {
  CheckInput("GeluBf16", UseLayerNormBf16(x), "bfloat16", x);
  return GeluFn<uint16_t>::apply(x);
}

torch::Tensor GeluLayerNormFp32(const torch::Tensor& x, const torch::Tensor& weight,
                                const torch::Tensor& bias, double eps) {
  CheckNormArgs("GeluLayerNormFp32", UseFusedFp32(x), "float32", x, weight, bias);
  return RowNormFn<float>::apply(x, weight, bias, eps, true);
}

torch::Tensor GeluFp32(const torch::Tensor& x) {
  CheckInput("GeluFp32", UseFusedFp32(x), "float32", x);
  return GeluFn<float>::apply(x);
}

}  // namespace internal
}  // namespace core
}  // namespace msspr
