// LayerNorm of a bfloat16 activation on the CPU, in one op each way.
//
// Under bf16 autocast a Linear returns bfloat16, LayerNorm (fp32 weights) runs
// in fp32 and the next Linear casts its input back to bfloat16: four casts and
// a LayerNorm forward and backward per hidden layer, and LibTorch 1.13's own
// bfloat16 LayerNorm is far slower than its fp32 one. This op reads the
// bfloat16 input, computes the statistics and the affine map in fp32 and
// writes bfloat16 once, which is what the cast + fp32 LayerNorm + cast chain
// computes (the output rounded to bfloat16 once); its backward likewise.
#pragma once

#include <torch/torch.h>

namespace msspr {
namespace core {
namespace internal {

// y = (x - mean) / sqrt(var + eps) * weight + bias over the last dimension.
// x: bfloat16 on the CPU, [..., D]; weight and bias: fp32 [D]. Returns
// bfloat16 of x's shape. Differentiable in x, weight and bias.
torch::Tensor LayerNormBf16(const torch::Tensor& x, const torch::Tensor& weight,
                            const torch::Tensor& bias, double eps);

// LayerNormBf16(bf16(GELU(x)), weight, bias, eps) in one op each way: the
// exact GELU (erf), its output rounded to bfloat16 as a bfloat16 GELU op
// would hand it on, and the backward of both. Same arguments as LayerNormBf16.
torch::Tensor GeluLayerNormBf16(const torch::Tensor& x, const torch::Tensor& weight,
                                const torch::Tensor& bias, double eps);

// The exact GELU of a bfloat16 CPU tensor, computed in fp32 and rounded once
// (LibTorch 1.13's bfloat16 GELU rounds after each of its five steps, and is
// several times slower). Differentiable; returns bfloat16.
torch::Tensor GeluBf16(const torch::Tensor& x);

// Whether LayerNormBf16 applies to x: a bfloat16 tensor on the CPU.
inline bool UseLayerNormBf16(const torch::Tensor& x) {
  return x.scalar_type() == torch::kBFloat16 && x.device().is_cpu();
}

}  // namespace internal
}  // namespace core
}  // namespace msspr
