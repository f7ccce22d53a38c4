// Soft actor-critic (Haarnoja et al. 2018), the online learner OGBench trains
// its low-level locomotion experts with (data_gen_scripts/main_sac.py): a
// tanh-squashed Gaussian actor with a state-dependent log-std, two Q networks
// with Polyak-averaged targets and the minimum of the two in the targets, the
// entropy bonus in the backup, and a learned temperature. Environments plug in
// through OnlineEnv, so the learner knows nothing of MuJoCo or ROS.
//
// SacTrainer runs the loop of main_sac.py: uniform random actions for the
// first `random_steps`, then one update per environment step from a replay
// buffer; it logs metrics.csv, writes its checkpoint atomically
// (out_dir/sac_checkpoint.pt: the networks, optimisers, temperature, replay
// buffer, step and random states) and resumes from it, and exports the actor
// alone (out_dir/sac_policy.pt) for SacPolicy.
#pragma once

#include <torch/torch.h>

#include <atomic>
#include <cmath>
#include <cstdint>
#include <functional>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "msspr_core/baselines.h"
#include "msspr_core/options.h"

namespace msspr {
namespace core {

// The learner's options; OGBench's main_sac.py defaults for the ant's
// direction-following expert (docs/ant_mazes.md), except `steps`.
struct SacOptions {
  int hidden = 256;                  // width of every hidden layer (actor and critics)
  int layers = 2;                    // hidden layers
  bool layer_norm = false;           // LayerNorm after each hidden layer's GELU
  double lr = 1e-4;                  // Adam, actor, critics and temperature
  int batch_size = 256;              //
  double gamma = 0.99;               //
  double tau = 0.005;                // Polyak rate of the target critics
  double target_entropy = NAN;       // NaN: -action_dim / 2 (OGBench)
  double init_temperature = 1.0;     // alpha at the start
  double log_std_min = -5.0;         // the actor's log-std is clipped to [min, max]
  double log_std_max = 2.0;          //
  bool backup_entropy = true;        // the target includes -alpha * log pi(a' | s')
  int64_t steps = 400000;            // environment steps
  int64_t random_steps = 10000;      // uniform random actions first (no updates)
  int64_t buffer_size = 1000000;     // replay capacity (transitions)
  uint64_t seed = 0;                 // torch, the sampler and the environment's episodes
  int log_every = 1000;              // metrics.csv row period (environment steps)
  int64_t checkpoint_every = 50000;  // 0: only at the end
  int64_t eval_every = 0;            // deterministic evaluation period; 0: never
  int eval_episodes = 5;             //
  double time_limit_s = 0;           // stop after this wall time of the run (s); 0: none

  template <class V>
  void Visit(V& v) {
    v("hidden", hidden);
    v("layers", layers);
    v("layer_norm", layer_norm);
    v("lr", lr);
    v("batch_size", batch_size);
    v("gamma", gamma);
    v("tau", tau);
    v("target_entropy", target_entropy);
    v("init_temperature", init_temperature);
    v("log_std_min", log_std_min);
    v("log_std_max", log_std_max);
    v("backup_entropy", backup_entropy);
    v("steps", steps);
    v("random_steps", random_steps);
    v("buffer_size", buffer_size);
    v("seed", seed);
    v("log_every", log_every);
    v("checkpoint_every", checkpoint_every);
    v("eval_every", eval_every);
    v("eval_episodes", eval_episodes);
    v("time_limit_s", time_limit_s);
  }
};

// Throws OptionsError naming the first bad value.
void ValidateSacOptions(const SacOptions& o);
// YAML: a `sac:` section of SacOptions' fields on top of `base`; unknown keys
// throw OptionsError naming `source` and the key.
SacOptions ApplySacYaml(const std::string& yaml_text, const SacOptions& base,
                        const std::string& source = "<string>");
std::string SacOptionsToYaml(const SacOptions& o);

// An environment for online learning: float observations, actions in [-1, 1].
class OnlineEnv {
 public:
  virtual ~OnlineEnv() = default;
  virtual int obs_dim() const = 0;
  virtual int action_dim() const = 0;
  // Starts an episode from `seed`; returns its first observation.
  virtual std::vector<float> Reset(uint64_t seed) = 0;
  struct StepResult {
    std::vector<float> obs;
    double reward = 0;
    bool terminated = false;  // a terminal state: no bootstrap
    bool truncated = false;   // the time limit: bootstrap, then reset
  };
  virtual StepResult Step(const std::vector<float>& action) = 0;
};

// The tanh-squashed Gaussian actor: mean and log-std heads on one MLP.
class SacActorImpl : public torch::nn::Module {
 public:
  SacActorImpl(int64_t obs_dim, int64_t action_dim, const SacOptions& o);
  // obs [B, obs_dim] -> (mean, log_std) [B, action_dim] each, log_std clipped.
  std::pair<torch::Tensor, torch::Tensor> forward(const torch::Tensor& obs);
  // Reparameterised sample: (tanh(u), log pi(tanh(u) | obs)) [B, act], [B].
  std::pair<torch::Tensor, torch::Tensor> Sample(const torch::Tensor& obs);
  torch::Tensor Deterministic(const torch::Tensor& obs);  // tanh(mean)

  OgMlp trunk{nullptr};                // "trunk" (GELU output)
  torch::nn::Linear mean{nullptr};     // "mean"
  torch::nn::Linear log_std{nullptr};  // "log_std"
  double log_std_min, log_std_max;
};
TORCH_MODULE(SacActor);

// One replay batch.
struct SacBatch {
  torch::Tensor obs, action, reward, next_obs, done;  // [B, o], [B, a], [B], [B, o], [B]
};

// A ring buffer of transitions (float32, on the CPU).
class ReplayBuffer {
 public:
  ReplayBuffer(int64_t capacity, int64_t obs_dim, int64_t action_dim);
  void Add(const std::vector<float>& obs, const std::vector<float>& action, double reward,
           const std::vector<float>& next_obs, bool done);
  SacBatch Sample(int64_t n, std::mt19937_64& rng) const;
  int64_t size() const { return size_; }
  int64_t capacity() const { return capacity_; }
  // The filled part and the write position, for checkpoints.
  void Save(torch::serialize::OutputArchive& archive) const;
  void Load(torch::serialize::InputArchive& archive);

 private:
  int64_t capacity_, obs_dim_, action_dim_, size_ = 0, next_ = 0;
  torch::Tensor obs_, action_, reward_, next_obs_, done_;
};

// Actor, critics, targets, temperature and their optimisers.
class SacAgent {
 public:
  SacAgent(int64_t obs_dim, int64_t action_dim, const SacOptions& o);
  // One gradient step on each of critic, actor and temperature, then the
  // Polyak update. Returns {critic_loss, actor_loss, alpha, entropy, q_mean}.
  NamedValues Update(const SacBatch& batch);
  // One action: sampled (training) or tanh(mean) (deterministic).
  std::vector<float> Act(const std::vector<float>& obs, bool deterministic);
  double alpha() const;
  double target_entropy() const { return target_entropy_; }

  SacActor actor{nullptr};
  OgMlp q1{nullptr}, q2{nullptr}, target_q1{nullptr}, target_q2{nullptr};
  torch::Tensor log_alpha;
  std::unique_ptr<torch::optim::Adam> actor_opt, critic_opt, alpha_opt;

  void Save(torch::serialize::OutputArchive& archive) const;
  void Load(torch::serialize::InputArchive& archive);

 private:
  torch::Tensor Q(OgMlp& q, const torch::Tensor& obs, const torch::Tensor& action);
  // The optimisers with their checkpoint keys, for Save and Load.
  std::vector<std::pair<const char*, torch::optim::Adam*>> NamedOptimizers() const;
  SacOptions options_;
  int64_t obs_dim_, action_dim_;
  double target_entropy_;
};

// The loop. Resumes from out_dir/sac_checkpoint.pt when it exists (the
// interrupted episode starts afresh; everything else continues).
class SacTrainer {
 public:
  // `make_env` builds the environment (called once; again for evaluations).
  SacTrainer(const SacOptions& options, std::function<std::unique_ptr<OnlineEnv>()> make_env,
             std::string out_dir);
  // Runs to options.steps, the time limit or until *stop_requested reads true
  // (polled after each step: msspr_core/stop_signals.h), writing the checkpoint
  // at the end in every case; returns the steps done in all.
  int64_t Train(const std::atomic<bool>* stop_requested = nullptr);
  // Whether the last Train() ended on *stop_requested.
  bool stopped() const { return stopped_; }
  // Mean undiscounted return of the deterministic actor over `episodes`
  // episodes seeded from `seed`.
  double Evaluate(int episodes, uint64_t seed);
  // Writes out_dir/sac_checkpoint.pt and out_dir/sac_policy.pt now.
  void SaveCheckpoint();
  int64_t step() const { return step_; }
  SacAgent& agent() { return *agent_; }
  const ReplayBuffer& buffer() const { return *buffer_; }
  bool resumed() const { return resumed_; }
  std::string checkpoint_path() const;
  std::string policy_path() const;

 private:
  void LoadCheckpoint(const std::string& path);
  SacOptions options_;
  std::function<std::unique_ptr<OnlineEnv>()> make_env_;
  std::unique_ptr<OnlineEnv> env_;
  std::string out_dir_;
  std::unique_ptr<SacAgent> agent_;
  std::unique_ptr<ReplayBuffer> buffer_;
  std::mt19937_64 rng_;
  int64_t step_ = 0, episode_ = 0, updates_ = 0;
  bool resumed_ = false, stopped_ = false;
};

// A trained actor (sac_policy.pt) for inference: deterministic tanh(mean).
class SacPolicy {
 public:
  explicit SacPolicy(const std::string& path);  // throws CheckpointError naming the path
  std::vector<float> Act(const std::vector<float>& obs);
  int obs_dim() const { return static_cast<int>(obs_dim_); }
  int action_dim() const { return static_cast<int>(action_dim_); }
  const SacOptions& options() const { return options_; }

 private:
  SacOptions options_;
  int64_t obs_dim_ = 0, action_dim_ = 0;
  SacActor actor_{nullptr};
};

}  // namespace core
}  // namespace msspr
