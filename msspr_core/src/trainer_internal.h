// Helpers shared by the trainer's and Ms.PR's source files (trainer*.cc,
// mspr_*.cc):
// float32 casts, gradient clearing, the bf16 autocast scope, per-thread
// OpenMP thread counts and the representation-update credit test.
#pragma once

#include <ATen/autocast_mode.h>
#include <torch/torch.h>
#include <torch/version.h>

#include "autocast_compat.h"
#include "bf16_weights.h"

// The OpenMP runtime that LibTorch loaded (weak: null without one). Its
// thread count is per calling thread, unlike at::set_num_threads, which is
// process-wide and also drops oneDNN's cached convolution primitives.
extern "C" {
__attribute__((weak)) void omp_set_num_threads(int);
__attribute__((weak)) int omp_get_max_threads(void);
}

namespace msspr {
namespace core {
namespace trainer_internal {

inline torch::Tensor F32(const torch::Tensor& t) { return t.to(torch::kFloat32); }

// Sets gradients to undefined so that optimisers skip parameters that the
// next backward does not reach.
inline void ClearGrads(torch::nn::Module& m) {
  for (auto& p : m.parameters()) p.mutable_grad() = torch::Tensor();
}

// Whether an accumulated representation credit calls for an update.
inline bool CreditDue(double credit) { return credit >= 1.0 - 1e-9; }

// trainer.precision = bf16: matrix products and convolutions run in
// bfloat16 inside this scope (autocast); backward runs outside it, as
// PyTorch recommends. A no-op for fp32.
class PrecisionScope {
 public:
  // cache: where the Linears of this scope take their bfloat16 weights on
  // the CPU (null: autocast casts them at every call).
  PrecisionScope(bool bf16, const torch::Device& device, internal::Bf16WeightCache* cache = nullptr)
      : bf16_(bf16),
        type_(device.is_cuda() ? at::kCUDA : at::kCPU),
        cache_scope_(bf16 && !device.is_cuda() ? cache : nullptr) {
    if (!bf16_) return;
    prev_ = internal::AutocastEnabled(type_);
    internal::SetAutocastDtype(type_, at::kBFloat16);
    internal::SetAutocastEnabled(type_, true);
  }
  ~PrecisionScope() {
    if (!bf16_) return;
    internal::SetAutocastEnabled(type_, prev_);
    at::autocast::clear_cache();
  }
  PrecisionScope(const PrecisionScope&) = delete;
  PrecisionScope& operator=(const PrecisionScope&) = delete;

 private:
  bool bf16_;
  at::DeviceType type_;
  bool prev_ = false;
  internal::Bf16WeightCacheScope cache_scope_;
};

// Sets the calling thread's intra-op thread count for a scope (no-op for
// n <= 0 or without OpenMP).
class ThreadCountScope {
 public:
  explicit ThreadCountScope(int n) {
    if (n <= 0 || omp_set_num_threads == nullptr || omp_get_max_threads == nullptr) return;
    prev_ = omp_get_max_threads();
    if (prev_ != n)
      omp_set_num_threads(n);
    else
      prev_ = 0;
  }
  ~ThreadCountScope() {
    if (prev_ > 0) omp_set_num_threads(prev_);
  }
  ThreadCountScope(const ThreadCountScope&) = delete;
  ThreadCountScope& operator=(const ThreadCountScope&) = delete;

 private:
  int prev_ = 0;
};

}  // namespace trainer_internal
}  // namespace core
}  // namespace msspr
