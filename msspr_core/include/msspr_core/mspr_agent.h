// Ms.PR as a GcAgent (Algorithm 1 of the paper): online,
// target and (trainer.policy_ema) moving-average networks, one AdamW each
// for the representation, the critic and the actor, and the step schedules:
// the sequential step, and the pipelined one whose actor-critic update runs
// on a worker thread beside the next representation update
// (trainer.pipeline). The losses are mspr_losses.h's.
#pragma once

#include <torch/torch.h>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "msspr_core/gc_agent.h"
#include "msspr_core/mspr_losses.h"

namespace msspr {
namespace core {

class AsyncWorker;
namespace internal {
class Bf16WeightCache;
}

class MsprAgent : public GcAgent {
 public:
  // training: all networks on `device`, targets equal to the online ones,
  // the optimisers; else the acting networks alone, on the CPU (the ones
  // ReadPolicy fills). Draws the initial weights from torch's generator:
  // repr, critic, actor, their targets, their moving averages, then V and the
  // subgoal actor where the options ask for them.
  MsprAgent(const MsprOptions& options, torch::Device device, bool training);
  // An acting agent on the given networks (shared, no copy; on `device`).
  MsprAgent(const MsprOptions& options, const MsprNetworks& networks, torch::Device device);
  ~MsprAgent() override;  // waits for a pipelined update still running

  // GcAgent.
  std::vector<std::string> LossNames() const override;
  // All NaN; with agent.subgoal_steps also the subgoal actor's loss ("subgoal").
  LossInfo NoLosses() const override;
  // One step of Algorithm 1: target copy when step % K == 0, representation
  // updates (updates_per_step, fractions accumulate), one critic and one
  // actor update. Pipelined with collect_info false, the actor-critic update
  // may still run on the worker thread when Step returns (with
  // agent.critic_grad_to_encoder: the actor update, deferred to the next
  // step's worker); the results are the sequential schedule's bit for bit.
  LossInfo Step(TrainingContext& context, bool collect_info) override;
  void Sync() override;
  // trainer.pipeline on the CPU without a data-parallel group ("auto": with
  // at least two torch threads).
  bool Pipelined() const override;
  void UpdateTargets() override;  // hard copy online -> target
  LossInfo ValidationLosses(BatchSource& batches) override;
  bool NeedsLosses(const LossInfo& last) const override;
  std::vector<std::string> LossesSkippedByNextStep() const override;
  LossInfo CarryOverLosses(const LossInfo& info, const LossInfo& last) const override;
  NamedValues ProgressValues(const LossInfo& info) const override;
  NamedModules CheckpointModules() override;
  NamedOptimizers Optimizers() override;
  double schedule_credit() const override { return repr_credit_; }
  void set_schedule_credit(double credit) override { repr_credit_ = credit; }
  NamedModules PolicyModules(bool raw) override;
  bool HasRawPolicy() const override { return static_cast<bool>(average_.repr); }
  void ReadPolicy(torch::serialize::InputArchive& archive, bool trainer_checkpoint) override;
  torch::Tensor Act(const torch::Tensor& obs, const torch::Tensor& goal) override;
  torch::Tensor Value(const torch::Tensor& obs, const torch::Tensor& action,
                      const torch::Tensor& goal) override;

  // Networks: online, target, moving average (null holders without
  // trainer.policy_ema, and for an acting agent), and the ones the policy
  // runs (the average when there is one, else the online ones).
  MsprNetworks& online() { return online_; }
  MsprNetworks& target() { return target_; }
  MsprNetworks& average() { return average_; }
  MsprNetworks& policy_networks() { return average_.repr ? average_ : online_; }
  // V of agent.critic_target "expectile" or agent.subgoal_steps (null otherwise).
  core::Value& value() { return value_; }

  // Losses on the online networks (scalar tensors with graph), as
  // mspr_losses.h; CriticLoss with agent.critic_grad_to_encoder and
  // gradient mode on lets the gradient reach the encoders.
  torch::Tensor RepresentationLoss(const ChunkBatch& batch, LossInfo* info = nullptr);
  torch::Tensor CriticLoss(const TransitionBatch& batch, const torch::Tensor& noise,
                           LossInfo* info = nullptr);
  torch::Tensor ActorLoss(const TransitionBatch& batch, LossInfo* info = nullptr);
  mspr::TransitionLatents EncodeTransitions(const TransitionBatch& batch);

  // Single updates (Step's parts; public for tests).
  void UpdateRepresentation(const ChunkBatch& batch, LossInfo* info = nullptr);
  void UpdateCritic(const TransitionBatch& batch, const torch::Tensor& noise,
                    LossInfo* info = nullptr);
  void UpdateActor(const TransitionBatch& batch, LossInfo* info = nullptr);
  // One step of the policy's moving average after training step `step`
  // (no-op without trainer.policy_ema).
  void UpdatePolicyAverage(int64_t step);

 private:
  bool bf16() const { return EffectivePrecision(options_.trainer) == "bf16"; }
  // Whether the accumulated representation credit (plus `extra_credit`, the
  // credit the next step adds) calls for a representation update.
  bool ReprUpdateDue(double extra_credit = 0.0) const;
  // Encode under trainer.precision, as the updates use it.
  mspr::TransitionLatents EncodeForUpdate(const TransitionBatch& batch);
  // The representation loss and its backward (no optimiser step).
  void RepresentationBackward(const ChunkBatch& batch, LossInfo* info);
  // The representation optimiser step on the gradients of a backward.
  void StepRepresentation();
  // lat null: the critic's gradient reaches the encoders.
  void UpdateCritic(const TransitionBatch& batch, const mspr::TransitionLatents* lat,
                    const torch::Tensor& noise, LossInfo* info);
  // The critic's TD target from the target networks (no gradient). With
  // agent.critic_target "expectile" it also takes one optimiser step of the
  // value network V (update = true; false: the target alone, for validation).
  torch::Tensor TdTarget(const TransitionBatch& batch, const torch::Tensor& noise, bool update);
  // The critic update against a TD target y computed beforehand.
  void UpdateCriticFromTarget(const TransitionBatch& batch, const mspr::TransitionLatents* lat,
                              const torch::Tensor& y, LossInfo* info);
  void UpdateActor(const TransitionBatch& batch, const mspr::TransitionLatents& lat,
                   LossInfo* info);
  // One step of the subgoal actor (agent.subgoal_steps; after the actor's).
  void UpdateSubgoalActor(const TransitionBatch& batch, const mspr::TransitionLatents& lat,
                          LossInfo* info);
  // Starts `task` on the worker thread (created on first use) with `threads`
  // torch threads; waits for the previous task first.
  void RunOnWorker(int threads, std::function<void()> task);
  // The pipelined step when the critic's gradient reaches the encoders.
  LossInfo CriticGradPipelinedStep(TrainingContext& context, bool collect_info, int worker_threads);

  torch::Device device_;
  MsprNetworks online_, target_, average_;
  std::unique_ptr<torch::optim::AdamW> repr_opt_, critic_opt_, actor_opt_;
  std::unique_ptr<torch::optim::AdamW> subgoal_opt_;  // agent.subgoal_steps > 0, else null
  // agent.critic_target "expectile" or agent.subgoal_steps: V(s, g) and its
  // optimiser (else null).
  core::Value value_{nullptr};
  std::unique_ptr<torch::optim::AdamW> value_opt_;
  torch::Tensor bins_;  // [num_bins] float32 on device
  // bf16 on the CPU: the weights' bfloat16 copies, cast once per update.
  std::unique_ptr<internal::Bf16WeightCache> weight_cache_;
  double repr_credit_ = 0.0;  // accumulated fractional representation updates
  // Pipelined with agent.critic_grad_to_encoder: the actor update of the
  // last step, deferred so that the worker runs it beside the next step's
  // representation update; Sync() runs it when anything else comes first.
  std::optional<TransitionBatch> pending_actor_;
  int pending_threads_ = 1;      // the worker's torch threads for it
  torch::Tensor worker_target_;  // the TD target the worker computed
  // The pipelined actor-critic update's thread (trainer.pipeline); created
  // on first use. Last member: destroyed (and joined) first.
  std::unique_ptr<AsyncWorker> worker_;
};

}  // namespace core
}  // namespace msspr
