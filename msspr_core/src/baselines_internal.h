// Internal to msspr_core: what the OGBench agents share (baselines.cc: the building
// blocks and OgbenchAgent; baselines_agents.cc: the six agents).
#pragma once

#include <torch/torch.h>

#include <vector>

#include "msspr_core/baselines.h"

namespace msspr::core::baselines_internal {

// A scalar tensor as a double (for the logged losses).
double Item(const torch::Tensor& t);

// Evaluates networks with their current weights but without gradients to
// them ("frozen", as OGBench's calls without grad params): gradients still
// flow through their inputs.
class Frozen {
 public:
  explicit Frozen(const std::vector<torch::Tensor>& params) : params_(params) {
    for (auto& p : params_) p.set_requires_grad(false);
  }
  ~Frozen() {
    for (auto& p : params_) p.set_requires_grad(true);
  }
  Frozen(const Frozen&) = delete;
  Frozen& operator=(const Frozen&) = delete;

 private:
  std::vector<torch::Tensor> params_;
};

std::vector<torch::Tensor> ParamsOf(const std::vector<torch::nn::Module*>& modules);

// x scaled to norm sqrt(dim) along the last axis (OGBench's LengthNormalize).
torch::Tensor LengthNormalize(const torch::Tensor& x);

// AWR weights min(exp(alpha * adv), 100).
torch::Tensor AwrWeight(const torch::Tensor& adv, double alpha);

// The two heads of an ensemble on one input: [B, 2].
torch::Tensor Twin(OgMlp& a, OgMlp& b, const torch::Tensor& x);

// OGBench's value loss of a twin V ensemble with target heads (GCIVL, HIQL):
// q = r + gamma m min(Vbar(s')), adv = q - mean(Vbar(s)), and each online
// head regresses on its own target q_i = r + gamma m Vbar_i(s') with the
// expectile weight of adv. next_target, target: [B, 2] without gradient;
// online: [B, 2].
torch::Tensor TwinExpectileValueLoss(const TransitionBatch& batch, const torch::Tensor& next_target,
                                     const torch::Tensor& target, const torch::Tensor& online,
                                     double expectile);

}  // namespace msspr::core::baselines_internal
