#include "msspr_core/foreach_adamw.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <set>
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

// The flat update: fp32 contiguous parameters and gradients on the CPU.
bool FlatUpdateApplies(const std::vector<torch::Tensor>& ps, const std::vector<torch::Tensor>& gs) {
  for (size_t i = 0; i < ps.size(); ++i) {
    for (const torch::Tensor* t : {&ps[i], &gs[i]}) {
      if (!t->device().is_cpu() || t->scalar_type() != torch::kFloat32 || !t->is_contiguous())
        return false;
    }
  }
  return !ps.empty();
}

torch::Tensor Concat(const std::vector<torch::Tensor>& ts) {
  std::vector<torch::Tensor> flat;
  flat.reserve(ts.size());
  for (const auto& t : ts) flat.push_back(t.reshape(-1));
  return torch::cat(flat);
}

}  // namespace

ForeachAdamW::FlatMoments& ForeachAdamW::Flat(
    const std::vector<torch::Tensor>& ps,
    const std::vector<torch::optim::AdamWParamState*>& states) {
  std::vector<const c10::TensorImpl*> impls;
  for (const auto& p : ps) impls.push_back(p.unsafeGetTensorImpl());
  FlatMoments* flat = nullptr;
  for (auto& f : flat_) {
    if (f.params == impls) flat = &f;
  }
  bool views = flat != nullptr;
  if (flat) {
    // Still views into the buffers? (A load or a reset replaces the state's tensors.)
    int64_t offset = 0;
    for (size_t i = 0; i < ps.size() && views; ++i) {
      const torch::Tensor &m = states[i]->exp_avg(), &v = states[i]->exp_avg_sq();
      views = m.scalar_type() == torch::kFloat32 && v.scalar_type() == torch::kFloat32 &&
              m.data_ptr<float>() == flat->exp_avg.data_ptr<float>() + offset &&
              v.data_ptr<float>() == flat->exp_avg_sq.data_ptr<float>() + offset &&
              m.sizes() == ps[i].sizes() && v.sizes() == ps[i].sizes();
      offset += ps[i].numel();
    }
  } else {
    // A parameter's moments live in one buffer: drop older lists that share one.
    const std::set<const c10::TensorImpl*> mine(impls.begin(), impls.end());
    flat_.erase(std::remove_if(flat_.begin(), flat_.end(),
                               [&](const FlatMoments& f) {
                                 return std::any_of(f.params.begin(), f.params.end(),
                                                    [&](auto* p) { return mine.count(p) > 0; });
                               }),
                flat_.end());
    flat_.push_back(FlatMoments{impls, {}, {}});
    flat = &flat_.back();
  }
  if (!views) {
    std::vector<torch::Tensor> m, v;
    for (auto* s : states) {
      m.push_back(s->exp_avg().to(torch::kFloat32));
      v.push_back(s->exp_avg_sq().to(torch::kFloat32));
    }
    flat->exp_avg = Concat(m);
    flat->exp_avg_sq = Concat(v);
    int64_t offset = 0;
    for (size_t i = 0; i < ps.size(); ++i) {
      const int64_t n = ps[i].numel();
      states[i]->exp_avg(flat->exp_avg.narrow(0, offset, n).view(ps[i].sizes()));
      states[i]->exp_avg_sq(flat->exp_avg_sq.narrow(0, offset, n).view(ps[i].sizes()));
      offset += n;
    }
  }
  return *flat;
}

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
    std::map<int64_t, std::vector<torch::optim::AdamWParamState*>> states;
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
      states[s.step()].push_back(&s);
      params[s.step()].push_back(p);
      grads[s.step()].push_back(p.grad());
      exp_avgs[s.step()].push_back(s.exp_avg());
      exp_avg_sqs[s.step()].push_back(s.exp_avg_sq());
    }
    for (auto& [step, ps] : params) {
      const auto& gs = grads[step];
      auto& m = exp_avgs[step];
      auto& v = exp_avg_sqs[step];
      const double bias_correction1 = 1 - std::pow(beta1, step);
      const double bias_correction2 = 1 - std::pow(beta2, step);
      if (FlatUpdateApplies(ps, gs)) {
        // The same ops in the same order, each once over all the parameters.
        FlatMoments& flat = Flat(ps, states[step]);
        torch::Tensor p_flat = Concat(ps), g_flat = Concat(gs);
        if (options.weight_decay() != 0) p_flat.mul_(1 - options.lr() * options.weight_decay());
        flat.exp_avg.mul_(beta1);
        flat.exp_avg.add_(g_flat, 1 - beta1);
        flat.exp_avg_sq.mul_(beta2);
        flat.exp_avg_sq.addcmul_(g_flat, g_flat, 1 - beta2);
        torch::Tensor denom = flat.exp_avg_sq.sqrt();
        denom.div_(std::sqrt(bias_correction2));
        denom.add_(options.eps());
        p_flat.addcdiv_(flat.exp_avg, denom, -options.lr() / bias_correction1);
        int64_t offset = 0;
        for (auto& p : ps) {
          p.view(-1).copy_(p_flat.narrow(0, offset, p.numel()));
          offset += p.numel();
        }
        continue;
      }
      if (options.weight_decay() != 0)
        torch::_foreach_mul_(ps, 1 - options.lr() * options.weight_decay());
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
