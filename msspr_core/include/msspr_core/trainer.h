// The trainer of every agent (gc_agent.h): Ms.PR (Algorithm 1 of the paper,
// the paper; mspr_agent.h) or one of OGBench's baselines (baselines.h).
// It owns the data, the batch builder and its random streams, the step
// count, the data-parallel group, the training loop and checkpoints that
// resume exactly; the agent owns its networks, optimisers and step schedule.
#pragma once

#include <torch/torch.h>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "msspr_core/baselines.h"
#include "msspr_core/batch_sampler.h"
#include "msspr_core/batches.h"
#include "msspr_core/dataset.h"
#include "msspr_core/distributed.h"
#include "msspr_core/gc_agent.h"
#include "msspr_core/mspr_agent.h"
#include "msspr_core/mspr_losses.h"
#include "msspr_core/networks.h"
#include "msspr_core/options.h"
#include "msspr_core/policy.h"

namespace msspr {
namespace core {

class AsyncWorker;

// Evaluator hook: receives a Policy sharing the trainer's online networks
// and the step; returns (name, value) pairs, e.g. per-task success rates,
// that are logged to eval.csv and printed.
using EvalResult = std::vector<std::pair<std::string, double>>;
using Evaluator = std::function<EvalResult(Policy& policy, int64_t step)>;

// Where Train writes: out_dir/metrics.csv, out_dir/eval.csv,
// out_dir/checkpoint.ckpt (every checkpoint_every steps and at the end) and
// out_dir/policy.pt (inference export at the end). Empty out_dir: no files.
struct TrainLoopOptions {
  std::string out_dir;
  bool quiet = false;  // no progress output
  // Called after each evaluation's rows are in eval.csv, and once more after
  // the final checkpoint (e.g. to draw the learning curve); its exceptions
  // are reported as warnings, and training goes on.
  std::function<void()> on_eval_written;
  // Polled before every step (every 16th step when data-parallel, so that all
  // ranks agree): once it reads true, Train stops as at a time limit, but
  // skips the final evaluation, and still writes the checkpoint and the
  // policy. msspr_train points it at a flag its SIGINT / SIGTERM handler sets.
  const std::atomic<bool>* stop_requested = nullptr;
};

// Why Train returned.
enum class TrainEnd { kSteps, kTimeLimit, kStopRequested };

// Trains the agent named by options.baseline.agent: Ms.PR ("mspr") or a
// baseline (baselines.h). The loop, checkpoints, export and Policy are the
// same for all; the Ms.PR parts below (losses, single updates, networks)
// forward to its MsprAgent and throw std::logic_error for a baseline.
class Trainer {
 public:
  // Fills network.obs_dim / action_dim / image sizes from `data` where 0,
  // validates the options, seeds torch and the sampler with trainer.seed and
  // builds the agent on trainer.device. Throws OptionsError.
  Trainer(const MsprOptions& options, std::shared_ptr<const Dataset> data);
  ~Trainer();  // waits for a pipelined update still running
  Trainer(const Trainer&) = delete;
  Trainer& operator=(const Trainer&) = delete;

  const MsprOptions& options() const { return options_; }
  int64_t step() const { return step_; }
  torch::Device device() const { return device_; }

  // One training step of the agent (GcAgent::Step): for Ms.PR, target copy
  // when step % K == 0, representation updates (updates_per_step, fractions
  // accumulate), one critic and one actor update; for a baseline, one Adam
  // step on its summed losses over a batch of
  // BatchSampler::SampleOgbenchTransitions and its target update. Returns
  // the losses of this step (all NaN when collect_info is false: no
  // device-to-host reads, which sync a GPU). With Ms.PR's trainer.pipeline
  // active and collect_info false, the step's actor-critic update may still
  // run on the worker thread when Step returns: it overlaps the next step's
  // representation update, and every other member function (and the
  // destructor) waits for it first. With agent.critic_grad_to_encoder the
  // critic update is done when Step returns and the actor update is
  // deferred to the next step's worker (Sync() runs it when anything else
  // comes first). The results are those of the sequential schedule.
  LossInfo Step(bool collect_info = true);
  // Whether Step runs pipelined (trainer.pipeline, the device, the thread
  // count: see TrainerOptions::pipeline).
  bool pipelined() const { return agent_->Pipelined(); }
  // Waits for a pipelined actor-critic update still running, and runs a
  // deferred actor update (rethrows their exception). Called by every member
  // function that reads the networks.
  void Sync() { agent_->Sync(); }

  // Runs Step() until options().trainer.steps with progress, CSV and the
  // evaluator every trainer.eval_every steps (and at the end), or until the
  // time limit or loop.stop_requested.
  TrainEnd Train(const TrainLoopOptions& loop, const Evaluator& evaluator = nullptr);

  // Batches drawn with the trainer's sampler RNG.
  TransitionBatch SampleTransitions();
  ChunkBatch SampleChunks();
  // A batch of OGBench 1-step transitions for the baseline agent.
  TransitionBatch SampleBaselineBatch();
  // Gathers indexed steps of `data` (the training set when null) into tensors
  // on the trainer's device. augment (pixels): with probability augment_prob
  // (one draw per batch, as OGBench) every sample gets one random shift of up
  // to augment_pad pixels (edge padding), shared by all of its images:
  // observation, next observation and goals; chunk states and chunk goal.
  TransitionBatch MakeTransitionBatch(const TransitionIndices& idx, bool augment,
                                      const Dataset* data = nullptr);
  ChunkBatch MakeChunkBatch(const ChunkIndices& idx, bool augment, const Dataset* data = nullptr);
  // Losses (no update, no augmentation, zero target noise) on `batch`
  // transitions and chunks of another dataset, e.g. a validation split, drawn
  // with a generator seeded by `seed`. Needs the same observation layout.
  LossInfo ValidationLosses(const Dataset& data, int batch, uint64_t seed);

  // The agent.
  GcAgent& gc_agent() {
    Sync();
    return *agent_;
  }
  // The baseline agent (null when training Ms.PR).
  std::shared_ptr<OgbenchAgent> agent();
  bool baseline() const { return options_.baseline.agent != "mspr"; }
  // Target network update (GcAgent::UpdateTargets; for Ms.PR a hard copy
  // online -> target of encoders, critic and actor).
  void UpdateTargets();

  // --- Ms.PR's parts (MsprAgent; std::logic_error for a baseline) ------------
  // Losses (scalar tensors with graph); fill `info` when not null.
  torch::Tensor RepresentationLoss(const ChunkBatch& batch, LossInfo* info = nullptr);
  // noise: [B, action_dim] N(0, 1) draws, scaled by target_noise and clipped here.
  torch::Tensor CriticLoss(const TransitionBatch& batch, const torch::Tensor& noise,
                           LossInfo* info = nullptr);
  torch::Tensor ActorLoss(const TransitionBatch& batch, LossInfo* info = nullptr);
  // Online-encoder latents of a transition batch (no gradient), shared by
  // the critic and the actor update of a step.
  using TransitionLatents = mspr::TransitionLatents;
  TransitionLatents EncodeTransitions(const TransitionBatch& batch);
  // Single updates (Step's parts; public for tests).
  void UpdateRepresentation(const ChunkBatch& batch, LossInfo* info = nullptr);
  void UpdateCritic(const TransitionBatch& batch, const torch::Tensor& noise,
                    LossInfo* info = nullptr);
  void UpdateActor(const TransitionBatch& batch, LossInfo* info = nullptr);
  // One step of the policy's moving average (trainer.policy_ema > 0).
  void UpdatePolicyAverage();
  // Ms.PR's agent.
  MsprAgent& mspr();
  // Networks: online, target, and the moving average of the policy's
  // networks (trainer.policy_ema > 0, else null holders).
  Representation& repr() { return mspr().online().repr; }
  Critic& critic() { return mspr().online().critic; }
  Actor& actor() { return mspr().online().actor; }
  Representation& target_repr() { return mspr().target().repr; }
  Critic& target_critic() { return mspr().target().critic; }
  Actor& target_actor() { return mspr().target().actor; }
  Representation& ema_repr() { return mspr().average().repr; }
  Critic& ema_critic() { return mspr().average().critic; }
  // V of agent.critic_target "expectile" or agent.subgoal_steps (else null).
  Value& value() { return mspr().value(); }
  Actor& ema_actor() { return mspr().average().actor; }
  // The subgoal actor of agent.subgoal_steps and its moving average (null holders without).
  SubgoalActor& subgoal_actor() { return mspr().online().subgoal; }
  SubgoalActor& ema_subgoal_actor() { return mspr().average().subgoal; }

  // A Policy sharing the agent's networks the exports write (no copy): for
  // Ms.PR the online ones, or their moving average when trainer.policy_ema > 0.
  Policy MakePolicy();

  // Data-parallel training (distributed.h): this trainer becomes one rank of
  // the group. Each rank samples batch_size / world_size of the global batch
  // with its own seed stream (seed, rank); gradients are averaged over the
  // ranks before every optimiser step; rank 0's parameters are broadcast
  // now. In Train(), only rank 0 writes files, logs and evaluates; every rank
  // stops at the same step; SaveCheckpoint on every rank puts every rank's
  // random state into rank 0's file, and LoadCheckpoint restores each
  // rank's own. Throws OptionsError when batch_size is not a multiple of the
  // world size. Call before the first Step or LoadCheckpoint.
  void SetDistributed(std::shared_ptr<Distributed> dist);
  // 0 without a group.
  int rank() const { return dist_ ? dist_->rank() : 0; }
  // The batch this rank samples per step.
  int local_batch() const;

  // Full training state, written atomically (temp file + rename): header
  // (magic, version, options as YAML, step), the agent's networks, targets
  // and optimisers (GcAgent::CheckpointModules, Optimizers), torch generator
  // and sampler RNG. Throws CheckpointError naming the file.
  void SaveCheckpoint(const std::string& path);
  // Restores a checkpoint written by SaveCheckpoint of a trainer built with
  // the same network options; the next Step() equals the uninterrupted one.
  // Throws CheckpointError naming the file on a truncated or foreign file.
  void LoadCheckpoint(const std::string& path);
  // Inference export (GcAgent::PolicyModules) for Policy::Load. Throws
  // std::runtime_error, writing nothing, when a weight is NaN or Inf. With
  // trainer.policy_ema > 0 it writes the moving average, or the raw online
  // weights when raw is true.
  void ExportPolicy(const std::string& path, bool raw = false);

 private:
  class Batches;  // the training batches and noise (TrainingContext)
  class ValidationBatches;

  torch::Tensor GatherObs(const Dataset& data, const std::vector<int64_t>& idx) const;
  // Augmentation draws for a batch: empty (no augmentation this batch) or
  // one (dy, dx) per sample.
  std::vector<std::pair<int, int>> DrawShifts(int64_t batch);
  torch::Tensor ToDevice(const torch::Tensor& cpu) const;
  // This rank's random state as text (sampler RNG, torch generator) and back.
  std::string RandomStateText();
  void RestoreRandomState(const std::string& text, const std::string& path);

  MsprOptions options_;
  std::shared_ptr<const Dataset> data_;
  torch::Device device_;
  std::unique_ptr<BatchSampler> sampler_;
  std::mt19937_64 rng_;   // batch sampling and augmentation
  torch::Generator gen_;  // target policy noise (CPU)
  int64_t step_ = 0;
  std::shared_ptr<Distributed> dist_;  // data-parallel group, or null
  std::shared_ptr<GcAgent> agent_;     // last member: destroyed (and its worker joined) first
};

// Reads the options stored in a checkpoint's (or policy export's) header.
// Throws CheckpointError naming the file.
MsprOptions ReadCheckpointOptions(const std::string& path);

}  // namespace core
}  // namespace msspr
