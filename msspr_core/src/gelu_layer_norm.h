// GELU and LayerNorm of a CPU activation, each in one op each way, with the
// GELU and the LayerNorm after it fused into one pass over the rows.
//
// bfloat16: under bf16 autocast a Linear returns bfloat16, LayerNorm (fp32
// weights) runs in fp32 and the next Linear casts its input back to bfloat16:
// four casts and a LayerNorm forward and backward per hidden layer, and
// LibTorch 1.13's own bfloat16 LayerNorm is far slower than its fp32 one. These
// ops read the bfloat16 input, compute the statistics and the affine map in
// fp32 and write bfloat16 once, which is what the cast + fp32 LayerNorm + cast
// chain computes (the output rounded to bfloat16 once); their backward likewise.
//
// float32: GELU and LayerNorm are LibTorch's two ops each way otherwise, four
// passes over the activation per hidden layer (its AVX2 loops in Debian's
// build); the fused op reads x once and writes y once each way, with the same
// GELU (erf) and LayerNorm to within fp32 rounding.
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

// LayerNorm(GELU(x), weight, bias, eps) of a float32 CPU tensor in one op each
// way: LibTorch's torch::gelu (exact, erf) then torch::layer_norm, to within
// fp32 rounding. Same arguments as LayerNormBf16, all fp32; returns fp32.
torch::Tensor GeluLayerNormFp32(const torch::Tensor& x, const torch::Tensor& weight,
                                const torch::Tensor& bias, double eps);

// The exact GELU (erf) of a float32 CPU tensor: torch::gelu to within fp32
// rounding. Differentiable.
torch::Tensor GeluFp32(const torch::Tensor& x);

// Whether the fp32 ops apply to x: a float32 tensor on the CPU.
inline bool UseFusedFp32(const torch::Tensor& x) {
  return x.scalar_type() == torch::kFloat32 && x.device().is_cpu();
}

// Whether LayerNormBf16 applies to x: a bfloat16 tensor on the CPU.
inline bool UseLayerNormBf16(const torch::Tensor& x) {
  return x.scalar_type() == torch::kBFloat16 && x.device().is_cpu();
}

}  // namespace internal
}  // namespace core
}  // namespace msspr
