#include "msspr_core/foreach_adamw.h"

#include <cmath>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <type_traits>

namespace msspr {
namespace core {
namespace {

// The optimiser state's key: a string of the TensorImpl address up to
// LibTorch 2.x, the address itself in later versions.
template <class Map>
typename Map::key_type StateKey(const Map&, const torch::Tensor& p) {
  if constexpr (std::is_same_v<typename Map::key_type, std::string>) {
    std::ostringstream key;  // as c10::guts::to_string
    key << p.unsafeGetTensorImpl();
    return key.str();
  } else {
    return static_cast<typename Map::key_type>(p.unsafeGetTensorImpl());
  }
}

}  // namespace

torch::Tensor ForeachAdamW::step(LossClosure closure) {
  for (auto& group : param_groups_) {
    if (static_cast<torch::optim::AdamWOptions&>(group.options()).amsgrad()) {
      // Rare; the reference implementation does it.
      return torch::optim::AdamW::step(closure);
    }
  }
  torch::NoGradGuard no_grad;
  torch::Tensor loss;
  if (closure) {
    at::AutoGradMode enable_grad(true);
    loss = closure();
  }
  for (auto& group : param_groups_) {
    auto& options = static_cast<torch::optim::AdamWOptions&>(group.options());
    const double beta1 = std::get<0>(options.betas()), beta2 = std::get<1>(options.betas());
    // Parameters that share a step count (all of them, except after a
    // partial update) share the bias corrections: one list each.
    std::map<int64_t, std::vector<torch::Tensor>> params, grads, exp_avgs, exp_avg_sqs;
    for (auto& p : group.params()) {
      if (!p.grad().defined()) continue;
      TORCH_CHECK(!p.grad().is_sparse(), "ForeachAdamW does not support sparse gradients");
      const auto key = StateKey(state_, p);
      auto it = state_.find(key);
      if (it == state_.end()) {
        auto s = std::make_unique<torch::optim::AdamWParamState>();
        s->step(0);
        s->exp_avg(torch::zeros_like(p, torch::MemoryFormat::Preserve));
        s->exp_avg_sq(torch::zeros_like(p, torch::MemoryFormat::Preserve));
        it = state_.emplace(key, std::move(s)).first;
      }
      auto& s = static_cast<torch::optim::AdamWParamState&>(*it->second);
      s.step(s.step() + 1);
      params[s.step()].push_back(p);
      grads[s.step()].push_back(p.grad());
      exp_avgs[s.step()].push_back(s.exp_avg());
      exp_avg_sqs[s.step()].push_back(s.exp_avg_sq());
    }
    for (auto& [step, ps] : params) {
      const auto& gs = grads[step];
      auto& m = exp_avgs[step];
      auto& v = exp_avg_sqs[step];
      if (options.weight_decay() != 0)
        torch::_foreach_mul_(ps, 1 - options.lr() * options.weight_decay());
      const double bias_correction1 = 1 - std::pow(beta1, step);
      const double bias_correction2 = 1 - std::pow(beta2, step);
      torch::_foreach_mul_(m, beta1);
      torch::_foreach_add_(m, gs, 1 - beta1);
      torch::_foreach_mul_(v, beta2);
      torch::_foreach_addcmul_(v, gs, gs, 1 - beta2);
      std::vector<torch::Tensor> denom = torch::_foreach_sqrt(v);
      torch::_foreach_div_(denom, std::sqrt(bias_correction2));
      torch::_foreach_add_(denom, options.eps());
      torch::_foreach_addcdiv_(ps, m, denom, -options.lr() / bias_correction1);
    }
  }
  return loss;
}

}  // namespace core
}  // namespace msspr
