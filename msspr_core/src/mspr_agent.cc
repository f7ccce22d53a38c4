// Ms.PR as a GcAgent: its networks and optimisers, the single updates,
// target copies, the policy's moving average, what checkpoints and exports
// hold, and acting. The step schedules are in mspr_schedule.cc, the losses
// in mspr_losses.cc.
#include "msspr_core/mspr_agent.h"

#include <algorithm>
#include <cmath>

#include "async_worker.h"
#include "module_io.h"
#include "msspr_core/foreach_adamw.h"
#include "trainer_internal.h"

namespace msspr {
namespace core {
using namespace trainer_internal;

MsprAgent::MsprAgent(const MsprOptions& options, torch::Device device, bool training)
    : GcAgent(options), device_(device) {
  const NetworkOptions& n = options_.network;
  online_.repr = register_module("repr", Representation(n));
  if (!training) {
    // As Policy::Load built them: on the CPU, for ReadPolicy.
    online_.actor = register_module("actor", Actor(n));
    online_.critic = register_module("critic", Critic(n));
    if (options_.agent.subgoal_steps > 0)
      online_.subgoal = register_module("subgoal_actor", SubgoalActor(n));
    device_ = torch::kCPU;
    return;
  }
  online_.critic = register_module("critic", Critic(n));
  online_.actor = register_module("actor", Actor(n));
  target_.repr = register_module("target_repr", Representation(n));
  target_.critic = register_module("target_critic", Critic(n));
  target_.actor = register_module("target_actor", Actor(n));
  for (torch::nn::Module* m : std::vector<torch::nn::Module*>{
           online_.repr.get(), online_.critic.get(), online_.actor.get(), target_.repr.get(),
           target_.critic.get(), target_.actor.get()}) {
    m->to(device_);
  }
  UpdateTargets();
  SetRequiresGrad(*target_.repr, false);
  SetRequiresGrad(*target_.critic, false);
  SetRequiresGrad(*target_.actor, false);
  if (options_.trainer.policy_ema > 0) {
    average_.repr = register_module("ema_repr", Representation(n));
    average_.critic = register_module("ema_critic", Critic(n));
    average_.actor = register_module("ema_actor", Actor(n));
    for (torch::nn::Module* m : std::vector<torch::nn::Module*>{
             average_.repr.get(), average_.critic.get(), average_.actor.get()}) {
      m->to(device_);
      SetRequiresGrad(*m, false);
    }
    HardUpdate(*average_.repr, *online_.repr);
    HardUpdate(*average_.critic, *online_.critic);
    HardUpdate(*average_.actor, *online_.actor);
  }
  const RepresentationOptions& r = options_.representation;
  const AgentOptions& a = options_.agent;
  // Multi-tensor AdamW: the same maths and state as torch::optim::AdamW.
  repr_opt_ = std::make_unique<ForeachAdamW>(
      online_.repr->parameters(), torch::optim::AdamWOptions(r.lr).weight_decay(r.weight_decay));
  critic_opt_ = std::make_unique<ForeachAdamW>(
      online_.critic->parameters(), torch::optim::AdamWOptions(a.lr).weight_decay(a.weight_decay));
  actor_opt_ = std::make_unique<ForeachAdamW>(
      online_.actor->parameters(), torch::optim::AdamWOptions(a.lr).weight_decay(a.weight_decay));
  // V: the critic's in-sample target, or the subgoal actor's advantage.
  if (a.critic_target == "expectile" || a.subgoal_steps > 0) {
    value_ = register_module("value", core::Value(n));
    value_->to(device_);
    value_opt_ = std::make_unique<ForeachAdamW>(
        value_->parameters(), torch::optim::AdamWOptions(a.lr).weight_decay(a.weight_decay));
  }
  // Built last, so that the other networks draw the initial weights they
  // draw without it.
  if (a.subgoal_steps > 0) {
    online_.subgoal = register_module("subgoal_actor", SubgoalActor(n));
    online_.subgoal->to(device_);
    subgoal_opt_ = std::make_unique<ForeachAdamW>(
        online_.subgoal->parameters(),
        torch::optim::AdamWOptions(a.lr).weight_decay(a.weight_decay));
    if (average_.repr) {
      average_.subgoal = register_module("ema_subgoal_actor", SubgoalActor(n));
      average_.subgoal->to(device_);
      SetRequiresGrad(*average_.subgoal, false);
      HardUpdate(*average_.subgoal, *online_.subgoal);
    }
  }
  bins_ = ReturnBins(n.num_bins, a.gamma).to(device_);
  if (bf16() && device_.is_cpu()) weight_cache_ = std::make_unique<internal::Bf16WeightCache>();
}

MsprAgent::MsprAgent(const MsprOptions& options, const MsprNetworks& networks, torch::Device device)
    : GcAgent(options), device_(device) {
  online_.repr = register_module("repr", networks.repr);
  online_.actor = register_module("actor", networks.actor);
  online_.critic = register_module("critic", networks.critic);
  if (networks.subgoal) online_.subgoal = register_module("subgoal_actor", networks.subgoal);
}

LossInfo MsprAgent::NoLosses() const {
  LossInfo info;
  if (options_.agent.subgoal_steps > 0) info.extra = {{"subgoal", NAN}};
  return info;
}

std::vector<std::string> MsprAgent::LossNames() const {
  std::vector<std::string> names;
  for (const auto& kv : NoLosses().Named()) names.push_back(kv.first);
  return names;
}

// --- Losses on the online networks ------------------------------------------------

mspr::TransitionLatents MsprAgent::EncodeTransitions(const TransitionBatch& batch) {
  Sync();
  return mspr::EncodeTransitions(*online_.repr, batch);
}

mspr::TransitionLatents MsprAgent::EncodeForUpdate(const TransitionBatch& batch) {
  PrecisionScope precision(bf16(), device_, weight_cache_.get());
  return mspr::EncodeTransitions(*online_.repr, batch);
}

torch::Tensor MsprAgent::RepresentationLoss(const ChunkBatch& batch, LossInfo* info) {
  return mspr::RepresentationLoss(options_, *online_.repr, *target_.repr, bins_, batch, info);
}

torch::Tensor MsprAgent::CriticLoss(const TransitionBatch& batch, const torch::Tensor& noise,
                                    LossInfo* info) {
  const bool through = options_.agent.critic_grad_to_encoder && torch::GradMode::is_enabled();
  std::optional<mspr::TransitionLatents> lat;
  if (!through) lat = EncodeTransitions(batch);
  const torch::Tensor y = TdTarget(batch, noise, /*update=*/false);
  return mspr::CriticLoss(options_.agent, online_, batch, lat ? &*lat : nullptr, y, info);
}

torch::Tensor MsprAgent::ActorLoss(const TransitionBatch& batch, LossInfo* info) {
  const mspr::TransitionLatents lat = EncodeTransitions(batch);
  return mspr::ActorLoss(options_.agent, online_, batch, lat, info);
}

LossInfo MsprAgent::ValidationLosses(BatchSource& batches) {
  Sync();
  LossInfo info = NoLosses();
  RepresentationLoss(batches.SampleChunks(), &info);
  const TransitionBatch tb = batches.SampleTransitions();
  CriticLoss(tb, torch::zeros({tb.action.size(0), tb.action.size(1)}), &info);
  ActorLoss(tb, &info);
  if (online_.subgoal) {
    mspr::SubgoalLoss(options_.agent, online_, target_, *value_, tb, EncodeTransitions(tb),
                      &info.extra[0].second);
  }
  return info;
}

// --- Updates ------------------------------------------------------------------------

void MsprAgent::RepresentationBackward(const ChunkBatch& batch, LossInfo* info) {
  ClearGrads(*online_.repr);
  torch::Tensor loss;
  {
    PrecisionScope precision(bf16(), device_, weight_cache_.get());
    loss = RepresentationLoss(batch, info);
  }
  loss.backward();
}

void MsprAgent::StepRepresentation() {
  AverageGradients(online_.repr->parameters());
  repr_opt_->step();
}

void MsprAgent::UpdateRepresentation(const ChunkBatch& batch, LossInfo* info) {
  Sync();
  RepresentationBackward(batch, info);
  StepRepresentation();
}

void MsprAgent::UpdateCritic(const TransitionBatch& batch, const torch::Tensor& noise,
                             LossInfo* info) {
  Sync();
  if (options_.agent.critic_grad_to_encoder) {
    UpdateCritic(batch, nullptr, noise, info);
    return;
  }
  const mspr::TransitionLatents lat = EncodeForUpdate(batch);
  UpdateCritic(batch, &lat, noise, info);
}

void MsprAgent::UpdateCritic(const TransitionBatch& batch, const mspr::TransitionLatents* lat,
                             const torch::Tensor& noise, LossInfo* info) {
  UpdateCriticFromTarget(batch, lat, TdTarget(batch, noise, /*update=*/true), info);
}

torch::Tensor MsprAgent::TdTarget(const TransitionBatch& batch, const torch::Tensor& noise,
                                  bool update) {
  if (!value_ || options_.agent.critic_target == "td3") {
    // With the subgoal policy V learns beside the TD3 target (as the
    // expectile target's V below), for the subgoal actor's advantage.
    if (value_ && update) {
      ClearGrads(*value_);
      torch::Tensor value_loss;
      {
        PrecisionScope precision(bf16(), device_, weight_cache_.get());
        value_loss = mspr::ExpectileValueLoss(options_.agent, target_, *value_, batch);
      }
      value_loss.backward();
      AverageGradients(value_->parameters());
      value_opt_->step();
    }
    PrecisionScope precision(bf16(), device_, weight_cache_.get());
    return mspr::CriticTarget(options_.agent, target_, batch, noise);
  }
  if (!update) {
    torch::NoGradGuard no_grad;
    PrecisionScope precision(bf16(), device_, weight_cache_.get());
    return mspr::ExpectileCriticTarget(options_.agent, target_, *value_, batch).y;
  }
  ClearGrads(*value_);
  mspr::ExpectileTarget t;
  {
    PrecisionScope precision(bf16(), device_, weight_cache_.get());
    t = mspr::ExpectileCriticTarget(options_.agent, target_, *value_, batch);
  }
  t.value_loss.backward();
  AverageGradients(value_->parameters());
  value_opt_->step();
  return t.y;
}

void MsprAgent::UpdateCriticFromTarget(const TransitionBatch& batch,
                                       const mspr::TransitionLatents* lat, const torch::Tensor& y,
                                       LossInfo* info) {
  ClearGrads(*online_.critic);
  const bool through = lat == nullptr;
  if (through) ClearGrads(*online_.repr);
  torch::Tensor loss;
  {
    PrecisionScope precision(bf16(), device_, weight_cache_.get());
    loss = mspr::CriticLoss(options_.agent, online_, batch, lat, y, info);
  }
  loss.backward();
  AverageGradients(online_.critic->parameters());
  critic_opt_->step();
  if (through) StepRepresentation();
}

void MsprAgent::UpdateActor(const TransitionBatch& batch, LossInfo* info) {
  Sync();
  UpdateActor(batch, EncodeForUpdate(batch), info);
}

void MsprAgent::UpdateActor(const TransitionBatch& batch, const mspr::TransitionLatents& lat,
                            LossInfo* info) {
  // Gradients only for the actor's parameters: the critic and E_sa are
  // differentiated through but not updated by the actor loss.
  torch::Tensor loss;
  {
    PrecisionScope precision(bf16(), device_, weight_cache_.get());
    loss = mspr::ActorLoss(options_.agent, online_, batch, lat, info);
  }
  std::vector<torch::Tensor> params = online_.actor->parameters();
  std::vector<torch::Tensor> grads = torch::autograd::grad({loss}, params);
  for (size_t i = 0; i < params.size(); ++i) params[i].mutable_grad() = grads[i];
  AverageGradients(online_.actor->parameters());
  actor_opt_->step();
  if (online_.subgoal) UpdateSubgoalActor(batch, lat, info);
}

void MsprAgent::UpdateSubgoalActor(const TransitionBatch& batch, const mspr::TransitionLatents& lat,
                                   LossInfo* info) {
  ClearGrads(*online_.subgoal);
  torch::Tensor loss;
  {
    PrecisionScope precision(bf16(), device_, weight_cache_.get());
    loss = mspr::SubgoalLoss(options_.agent, online_, target_, *value_, batch, lat,
                             info && !info->extra.empty() ? &info->extra[0].second : nullptr);
  }
  loss.backward();
  AverageGradients(online_.subgoal->parameters());
  subgoal_opt_->step();
}

void MsprAgent::UpdateTargets() {
  HardUpdate(*target_.repr, *online_.repr);
  HardUpdate(*target_.critic, *online_.critic);
  HardUpdate(*target_.actor, *online_.actor);
}

void MsprAgent::UpdatePolicyAverage(int64_t step) {
  if (!average_.repr) return;
  // Warm-up: the plain mean of the weights of steps 0..t until that window is
  // longer than the average's (t > decay / (1 - decay)), so the start's
  // random weights do not linger in it.
  const double t = static_cast<double>(step);
  const double decay = std::min(options_.trainer.policy_ema, t / (t + 1.0));
  torch::NoGradGuard no_grad;
  std::vector<torch::Tensor> avg, raw;
  std::vector<std::pair<torch::nn::Module*, torch::nn::Module*>> pairs{
      {average_.repr.get(), online_.repr.get()},
      {average_.critic.get(), online_.critic.get()},
      {average_.actor.get(), online_.actor.get()}};
  if (average_.subgoal) pairs.emplace_back(average_.subgoal.get(), online_.subgoal.get());
  for (const auto& [e, o] : pairs) {
    for (const auto& p : e->parameters()) avg.push_back(p);
    for (const auto& p : o->parameters()) raw.push_back(p.detach());
    const auto eb = e->buffers();
    const auto ob = o->buffers();
    for (size_t i = 0; i < eb.size(); ++i) eb[i].copy_(ob[i]);
  }
  TORCH_CHECK(avg.size() == raw.size(), "UpdatePolicyAverage: parameter count mismatch");
  torch::_foreach_mul_(avg, decay);
  torch::_foreach_add_(avg, raw, 1.0 - decay);
}

// --- The training loop's logs ----------------------------------------------------------

bool MsprAgent::NeedsLosses(const LossInfo& last) const { return std::isnan(last.repr); }

std::vector<std::string> MsprAgent::LossesSkippedByNextStep() const {
  if (ReprUpdateDue(options_.representation.updates_per_step)) return {};
  return {"repr", "dyn", "rew", "inv", "gdyn", "gact"};
}

LossInfo MsprAgent::CarryOverLosses(const LossInfo& info, const LossInfo& last) const {
  // The last representation losses on steps without a representation update.
  LossInfo merged = info;
  if (std::isnan(info.repr)) {
    merged.repr = last.repr;
    merged.dyn = last.dyn;
    merged.rew = last.rew;
    merged.inv = last.inv;
    merged.goal_dyn = last.goal_dyn;
    merged.goal_act = last.goal_act;
  }
  return merged;
}

NamedValues MsprAgent::ProgressValues(const LossInfo& info) const {
  return {{"critic", info.critic}, {"actor", info.actor}, {"repr", info.repr}, {"q", info.q_mean}};
}

// --- Checkpoints and exports ------------------------------------------------------------

NamedModules MsprAgent::CheckpointModules() {
  NamedModules modules{{"repr", online_.repr.get()},
                       {"critic", online_.critic.get()},
                       {"actor", online_.actor.get()},
                       {"target_repr", target_.repr.get()},
                       {"target_critic", target_.critic.get()},
                       {"target_actor", target_.actor.get()}};
  if (value_) modules.emplace_back("value", value_.get());
  if (average_.repr) {
    modules.emplace_back("ema_repr", average_.repr.get());
    modules.emplace_back("ema_critic", average_.critic.get());
    modules.emplace_back("ema_actor", average_.actor.get());
  }
  if (online_.subgoal) modules.emplace_back("subgoal_actor", online_.subgoal.get());
  if (average_.subgoal) modules.emplace_back("ema_subgoal_actor", average_.subgoal.get());
  return modules;
}

NamedOptimizers MsprAgent::Optimizers() {
  NamedOptimizers opts{{"repr_opt", repr_opt_.get()},
                       {"critic_opt", critic_opt_.get()},
                       {"actor_opt", actor_opt_.get()}};
  if (value_opt_) opts.emplace_back("value_opt", value_opt_.get());
  if (subgoal_opt_) opts.emplace_back("subgoal_opt", subgoal_opt_.get());
  return opts;
}

NamedModules MsprAgent::PolicyModules(bool raw) {
  // The moving average when there is one: what the policy runs.
  MsprNetworks& n = raw ? online_ : policy_networks();
  NamedModules modules{
      {"repr", n.repr.get()}, {"actor", n.actor.get()}, {"critic", n.critic.get()}};
  if (n.subgoal) modules.emplace_back("subgoal_actor", n.subgoal.get());
  return modules;
}

void MsprAgent::ReadPolicy(torch::serialize::InputArchive& archive, bool trainer_checkpoint) {
  // A trainer checkpoint of a run with trainer.policy_ema holds the moving
  // average beside the raw weights: the policy is the average, as in the
  // run's exports.
  const std::string prefix = trainer_checkpoint && options_.trainer.policy_ema > 0 ? "ema_" : "";
  ReadModule(archive, prefix + "repr", *online_.repr);
  ReadModule(archive, prefix + "actor", *online_.actor);
  ReadModule(archive, prefix + "critic", *online_.critic);
  if (online_.subgoal) ReadModule(archive, prefix + "subgoal_actor", *online_.subgoal);
}

// --- Acting ---------------------------------------------------------------------------------

torch::Tensor MsprAgent::Act(const torch::Tensor& obs, const torch::Tensor& goal) {
  MsprNetworks& n = policy_networks();
  const torch::Tensor zs = n.repr->state_encoder->forward(obs);
  const torch::Tensor zg = n.repr->state_encoder->forward(goal);
  if (!n.subgoal) return n.actor->forward(zs, n.repr->goal_head->forward(zs, zg), obs, goal);
  // The subgoal policy: the state to reach next on the way to the goal, then
  // the action toward it.
  const torch::Tensor sub = n.subgoal->forward(zs, n.repr->goal_head->forward(zs, zg), obs, goal);
  const torch::Tensor zsub = n.repr->state_encoder->forward(sub);
  return n.actor->forward(zs, n.repr->goal_head->forward(zs, zsub), obs, sub);
}

torch::Tensor MsprAgent::Value(const torch::Tensor& obs, const torch::Tensor& action,
                               const torch::Tensor& goal) {
  MsprNetworks& n = policy_networks();
  const torch::Tensor zs = n.repr->state_encoder->forward(obs);
  const torch::Tensor zg = n.repr->state_encoder->forward(goal);
  return n.critic->forward(n.repr->Zsa(zs, action), n.repr->goal_head->forward(zs, zg), obs, action,
                           goal);
}

}  // namespace core
}  // namespace msspr
