// The interface of every goal-conditioned agent the Trainer trains and a
// Policy runs: Ms.PR (MsprAgent, mspr_agent.h) and OGBench's six baselines
// (OgbenchAgent, baselines.h). The trainer owns the data, the sampler's
// random stream, the step count and the data-parallel group; an agent owns
// its networks, optimisers and step schedule, and names what a checkpoint
// and a policy export hold. So the training loop, checkpoint I/O and Policy
// do not depend on which agent it is.
#pragma once

#include <torch/torch.h>

#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "msspr_core/batches.h"
#include "msspr_core/options.h"

namespace msspr {
namespace core {

class Distributed;

// Where an agent's batches come from: while training, the trainer's sampler
// and random stream (each call draws the next batch of Trainer::local_batch()
// samples, shifted for pixels); for validation losses, a fixed stream
// without augmentation.
class BatchSource {
 public:
  virtual ~BatchSource() = default;
  // Ms.PR's representation chunks (BatchSampler::SampleChunks).
  virtual ChunkBatch SampleChunks() = 0;
  // Ms.PR's n-step transitions (BatchSampler::SampleTransitions).
  virtual TransitionBatch SampleTransitions() = 0;
  // OGBench's 1-step transitions, with subgoals `subgoal_steps` ahead when
  // > 0 (BatchSampler::SampleOgbenchTransitions).
  virtual TransitionBatch SampleOgbenchTransitions(int subgoal_steps) = 0;
};

// A training step's view of the trainer: its batches, the step being taken
// and the target-policy noise stream (the trainer's torch generator).
class TrainingContext : public BatchSource {
 public:
  // The step being taken: 1 in the first.
  virtual int64_t step() const = 0;
  // [rows, cols] float32 N(0, 1) draws on the CPU.
  virtual torch::Tensor Noise(int64_t rows, int64_t cols) = 0;
};

using NamedModules = std::vector<std::pair<std::string, torch::nn::Module*>>;
using NamedOptimizers = std::vector<std::pair<std::string, torch::optim::Optimizer*>>;

class GcAgent : public torch::nn::Module {
 public:
  explicit GcAgent(const MsprOptions& options);
  ~GcAgent() override = default;

  // "mspr" or the baseline's name (options.baseline.agent).
  const std::string& agent_name() const { return options_.baseline.agent; }

  // --- Training ---------------------------------------------------------------
  // Names of the losses a step reports (LossInfo::Named order: the columns
  // of metrics.csv).
  virtual std::vector<std::string> LossNames() const = 0;
  // A LossInfo with these names, all NaN.
  virtual LossInfo NoLosses() const;
  // One training step (the trainer has counted it: context.step()). Returns
  // its losses, all NaN when collect_info is false (no device-to-host reads,
  // which sync a GPU). The agent may leave work running when it returns
  // (Ms.PR's pipelined schedule); Sync() finishes it.
  virtual LossInfo Step(TrainingContext& context, bool collect_info) = 0;
  // Finishes work a step left running (rethrows its exception); the trainer
  // calls it before anything that reads the networks.
  virtual void Sync() {}
  // Whether steps overlap work on a worker thread (Ms.PR's trainer.pipeline).
  virtual bool Pipelined() const { return false; }
  // Target network update outside the step's own (hard copy for Ms.PR,
  // Polyak for the baselines; none for gcbc, qrl, crl).
  virtual void UpdateTargets() {}
  // Losses (no update, no augmentation, zero target noise) on batches of
  // `batches`; gradient mode is the caller's.
  virtual LossInfo ValidationLosses(BatchSource& batches) = 0;
  // This agent becomes one rank of a data-parallel group: gradients are
  // averaged over it before every optimiser step (null: none).
  void SetDistributed(std::shared_ptr<Distributed> dist) { dist_ = std::move(dist); }

  // --- The training loop's logs -------------------------------------------------
  // Whether the loop must collect the next step's losses although it does
  // not log it; `last`: the losses it keeps (Ms.PR: until it has
  // representation losses to carry over).
  virtual bool NeedsLosses(const LossInfo& /*last*/) const { return false; }
  // The LossNames() that the next Step leaves NaN although it collects
  // (Ms.PR: its representation terms when no representation update is due);
  // the loop's check for non-finite losses skips them.
  virtual std::vector<std::string> LossesSkippedByNextStep() const { return {}; }
  // A step's losses `info` with those it skipped taken from `last`.
  virtual LossInfo CarryOverLosses(const LossInfo& info, const LossInfo& /*last*/) const {
    return info;
  }
  // What the progress bar shows (default: the first four losses).
  virtual NamedValues ProgressValues(const LossInfo& info) const;

  // --- Checkpoints and exports (the keys stay fixed across versions) -----------
  // Every module of the training state (targets and averages included).
  virtual NamedModules CheckpointModules() = 0;
  virtual NamedOptimizers Optimizers() = 0;
  // Schedule state carried by the checkpoint header (Ms.PR: the fractional
  // representation updates carried over; CheckpointHeader::repr_credit).
  virtual double schedule_credit() const { return 0.0; }
  virtual void set_schedule_credit(double) {}
  // The modules of a policy export: the acting networks, or with raw the
  // online ones where the policy is a moving average (HasRawPolicy).
  virtual NamedModules PolicyModules(bool raw) = 0;
  // Whether exports have a raw variant (with trainer.policy_ema).
  virtual bool HasRawPolicy() const { return false; }
  // Reads the acting networks from a policy export (or, trainer_checkpoint,
  // a trainer checkpoint) into an agent built for acting (MakeGcAgent).
  virtual void ReadPolicy(torch::serialize::InputArchive& archive, bool trainer_checkpoint) = 0;

  // --- Acting ---------------------------------------------------------------------
  // Deterministic action: obs, goal [B, ...] -> [B, action_dim] in [-1, 1].
  virtual torch::Tensor Act(const torch::Tensor& obs, const torch::Tensor& goal) = 0;
  // Whether Value is defined (all but gcbc).
  virtual bool has_value() const { return true; }
  // The agent's value estimate of (s, a, g) as [B, 2]: Ms.PR's twin Q; see
  // the baselines for theirs. Throws std::logic_error when !has_value().
  virtual torch::Tensor Value(const torch::Tensor& obs, const torch::Tensor& action,
                              const torch::Tensor& goal);

 protected:
  // Averages the gradients of `params` over the ranks (no-op without a group).
  void AverageGradients(const std::vector<torch::Tensor>& params);
  bool distributed() const { return dist_ != nullptr; }

  MsprOptions options_;

 private:
  std::shared_ptr<Distributed> dist_;
};

// The agent named by options.baseline.agent. training: on `device`, with its
// optimisers, ready for Step; else its acting networks alone, on the CPU,
// for ReadPolicy (Policy::Load). Throws OptionsError for an unknown name or
// options the agent does not support.
std::shared_ptr<GcAgent> MakeGcAgent(const MsprOptions& options, torch::Device device,
                                     bool training);

}  // namespace core
}  // namespace msspr
