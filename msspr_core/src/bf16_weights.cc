#include "bf16_weights.h"

#include "autocast_compat.h"

namespace msspr {
namespace core {
namespace internal {
namespace {

thread_local Bf16WeightCache* current_cache = nullptr;

}  // namespace

torch::Tensor Bf16WeightCache::Get(const torch::Tensor& w) {
  const bool graph = torch::GradMode::is_enabled() && w.requires_grad();
  const int64_t version = static_cast<int64_t>(w._version());
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = entries_.find(w.unsafeGetTensorImpl());
  // A copy with a graph also serves where none is needed (gradient mode off
  // records nothing), unless the weight stopped requiring grad.
  if (it != entries_.end() && it->second.version == version &&
      (it->second.graph == graph || (it->second.graph && w.requires_grad()))) {
    return it->second.copy;
  }
  torch::Tensor copy;
  if (graph) {
    copy = w.to(torch::kBFloat16);
  } else {
    torch::NoGradGuard no_grad;
    copy = w.to(torch::kBFloat16);
  }
  entries_[w.unsafeGetTensorImpl()] = Entry{version, graph, copy};
  return copy;
}

void Bf16WeightCache::Clear() {
  std::lock_guard<std::mutex> lock(mutex_);
  entries_.clear();
}

size_t Bf16WeightCache::size() {
  std::lock_guard<std::mutex> lock(mutex_);
  return entries_.size();
}

Bf16WeightCacheScope::Bf16WeightCacheScope(Bf16WeightCache* cache) : previous_(current_cache) {
  current_cache = cache;
}

Bf16WeightCacheScope::~Bf16WeightCacheScope() { current_cache = previous_; }

torch::Tensor Linear(torch::nn::LinearImpl& linear, const torch::Tensor& x) {
  Bf16WeightCache* cache = current_cache;
  const torch::Tensor& w = linear.weight;
  if (cache == nullptr || !x.device().is_cpu() || w.scalar_type() != torch::kFloat32 ||
      !w.device().is_cpu() || !CpuBf16Autocast()) {
    return linear.forward(x);
  }
  const torch::Tensor& b = linear.bias;
  return torch::linear(x, cache->Get(w), b.defined() ? cache->Get(b) : torch::Tensor());
}

torch::Tensor LinearFp32(torch::nn::LinearImpl& linear, const torch::Tensor& x) {
  AutocastOffScope off;
  return torch::linear(x.to(torch::kFloat32), linear.weight, linear.bias);
}

}  // namespace internal
}  // namespace core
}  // namespace msspr
