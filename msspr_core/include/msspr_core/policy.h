// Inference: the trained goal-conditioned actor (and critic) behind one
// call, under torch::InferenceMode.
//
// Latency on CPU: a single-sample Act takes ~0.3 ms (state, CPU scale) to
// ~3 ms (image, paper scale); it runs in one thread whatever the thread
// setting (see Act). Batches share their rows among torch's threads: on
// cores shared with other processes set OMP_WAIT_POLICY=PASSIVE in the
// environment (see process_env.h), as spinning OpenMP threads slow them.
#pragma once

#include <torch/torch.h>

#include <string>
#include <vector>

#include "msspr_core/gc_agent.h"
#include "msspr_core/networks.h"
#include "msspr_core/options.h"

namespace msspr {
namespace core {

// Writes to `out` a Ms.PR policy export whose weights (encoders and goal
// head, actor, critic) are the element-wise mean of the given exports' or
// checkpoints' (Policy::Load), e.g. one run's last few policy_step<N>.pt:
// averaging the weights of late exports of a run smooths the swings between
// them. Its header holds the first input's options and the largest step.
// Throws CheckpointError naming the input that cannot be read, is a baseline
// agent's, or has other network options than the first.
void AveragePolicies(const std::vector<std::string>& inputs, const std::string& out);

class Policy {
 public:
  // The policy of an agent (options.baseline.agent names it: Ms.PR or a
  // baseline); shares it (no copy). It must be on `device`.
  Policy(const MsprOptions& options, std::shared_ptr<GcAgent> agent, torch::Device device);
  // A Ms.PR policy sharing the given networks (no copy); they must be on `device`.
  Policy(const MsprOptions& options, Representation repr, Actor actor, Critic critic,
         torch::Device device);

  // Loads an inference export (Trainer::ExportPolicy) or a full trainer
  // checkpoint onto `device` (of a run with trainer.policy_ema: its moving
  // average, as the run's exports). Throws CheckpointError naming the file.
  static Policy Load(const std::string& path, torch::Device device = torch::kCPU);

  // Action for observations and goals. State mode: obs, goal [B, obs_dim] or
  // [obs_dim] float; pixels mode: [B, H, W, C * frame_stack] or
  // [H, W, C * frame_stack] uint8 (frames stacked oldest first along
  // channels). Returns [B, action_dim] or [action_dim] float32 in [-1, 1] on
  // the policy's device. Inputs on another device are moved.
  //
  // Batch- and thread-invariant: each row's action is computed on its own,
  // as a batch of one, in float32 and with one intra-op thread, so it is
  // bitwise the same whatever the batch it comes in and whatever the thread
  // setting (torch::set_num_threads, OMP_NUM_THREADS). A batched matrix
  // product may round a row's last bits differently from a single row's, or
  // at another thread count; in a simulator with contacts (the ant) such
  // differences change episodes' outcomes. A batch of B costs about B
  // single calls; on the CPU its rows are shared among torch's threads.
  torch::Tensor Act(const torch::Tensor& obs, const torch::Tensor& goal);
  // Single state sample: obs, goal [obs_dim] -> action [action_dim].
  std::vector<float> Act(const std::vector<float>& obs, const std::vector<float>& goal);
  // Twin Q values: obs, goal as in Act; action [B, action_dim] or
  // [action_dim] -> [B, 2] or [2] float32 (returns in [-1/(1-gamma), 0]).
  // One batched forward pass: unlike Act, its last bits may vary with the
  // batch and the thread count.
  // Baseline agents: GcAgent::Value (see OgbenchAgent for the units);
  // throws std::logic_error when has_value() is false (gcbc).
  torch::Tensor Q(const torch::Tensor& obs, const torch::Tensor& action, const torch::Tensor& goal);

  const MsprOptions& options() const { return options_; }
  // "mspr" or the baseline agent's name (gcbc, gcivl, gciql, qrl, crl, hiql).
  const std::string& agent_name() const { return options_.baseline.agent; }
  // Whether Q gives a value estimate (false for gcbc).
  bool has_value() const { return agent_->has_value(); }
  bool pixels() const { return options_.network.obs_mode == "pixels"; }
  int obs_dim() const { return options_.network.obs_dim; }
  int action_dim() const { return options_.network.action_dim; }
  torch::Device device() const { return device_; }
  // The training step of the file Load read (its header); 0 for a Policy
  // built on live networks.
  int64_t step() const { return step_; }

  // Ms.PR's networks (MsprAgent::policy_networks); std::logic_error for a
  // baseline agent.
  Representation& repr();
  Actor& actor();
  Critic& critic();
  // The agent.
  std::shared_ptr<GcAgent> agent() { return agent_; }

 private:
  // Adds the batch dim when missing; returns whether it was added.
  bool Batch(torch::Tensor* obs) const;

  MsprOptions options_;
  std::shared_ptr<GcAgent> agent_;
  torch::Device device_;
  int64_t step_ = 0;
};

}  // namespace core
}  // namespace msspr
