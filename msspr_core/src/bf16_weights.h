// bfloat16 copies of fp32 weights, cast once per version of each weight.
//
// Under bf16 autocast a Linear casts its fp32 weight and bias to bfloat16 at
// every call, and autocast's own cache lasts one autocast region and skips
// weights that do not require grad (the target networks). A training step
// runs several regions over the same weights, so most of its casts repeat
// one another. This cache keeps one bfloat16 copy per weight until the weight
// changes (its version counter moves: an optimiser step, a target copy, a
// load). A copy made with gradient mode on carries its ToCopyBackward node,
// as autocast's cached casts do, so gradients still reach the fp32 weight:
// the maths is autocast's, bit for bit; only the repeated casts are gone.
#pragma once

#include <torch/torch.h>

#include <mutex>
#include <unordered_map>

namespace msspr {
namespace core {
namespace internal {

class Bf16WeightCache {
 public:
  // The bfloat16 copy of `w` (an fp32 CPU tensor), cast now if the cached
  // one is stale or lacks the graph that gradient mode calls for.
  torch::Tensor Get(const torch::Tensor& w);
  void Clear();
  size_t size();

 private:
  struct Entry {
    int64_t version;
    bool graph;  // carries ToCopyBackward into w
    torch::Tensor copy;
  };
  std::mutex mutex_;
  std::unordered_map<const c10::TensorImpl*, Entry> entries_;
};

// Installs `cache` as the calling thread's weight cache while alive (null:
// none); restores the previous one after.
class Bf16WeightCacheScope {
 public:
  explicit Bf16WeightCacheScope(Bf16WeightCache* cache);
  ~Bf16WeightCacheScope();
  Bf16WeightCacheScope(const Bf16WeightCacheScope&) = delete;
  Bf16WeightCacheScope& operator=(const Bf16WeightCacheScope&) = delete;

 private:
  Bf16WeightCache* previous_;
};

// linear->forward(x), with the weight and bias from the calling thread's
// cache when one is installed, bf16 autocast is on for the CPU, and the
// weight is fp32 on the CPU. The same result and gradients either way.
torch::Tensor Linear(torch::nn::LinearImpl& linear, const torch::Tensor& x);

// linear(x) in float32 with autocast off, for the last Linear of a value head
// (the critics' Q, the value network's V) or an actor's output under bf16
// autocast. Returns reach 1 / (1 - gamma) = 100 in magnitude, where bfloat16
// keeps 8 significant bits: Q = -70 would round to a multiple of 0.5, coarser
// than the differences of a step or an action (about gamma^d for a goal d
// steps away) that the critic has to resolve.
torch::Tensor LinearFp32(torch::nn::LinearImpl& linear, const torch::Tensor& x);

}  // namespace internal
}  // namespace core
}  // namespace msspr
