// SAC's trainer (SacTrainer): episodes in the env, updates from the replay buffer,
// evaluations, and checkpoints that resume exactly.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <numeric>
#include <sstream>

#include "module_io.h"
#include "msspr_core/checkpoint.h"
#include "msspr_core/progress.h"
#include "msspr_core/sac.h"
#include "sac_internal.h"

namespace msspr {
namespace core {
namespace {

// A distinct, reproducible seed per SAC episode of a run. Not sim::EpisodeSeed
// (the dataset collectors' mixing): the shipped locomotion expert was trained
// with this formula, so it stays to keep that training reproducible.
uint64_t SacEpisodeSeed(uint64_t seed, int64_t episode) {
  uint64_t z = seed * 0x9E3779B97F4A7C15ull + static_cast<uint64_t>(episode) + 1;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

}  // namespace

using namespace sac_internal;

// --- Trainer --------------------------------------------------------------------

SacTrainer::SacTrainer(const SacOptions& options,
                       std::function<std::unique_ptr<OnlineEnv>()> make_env, std::string out_dir)
    : options_(options), make_env_(std::move(make_env)), out_dir_(std::move(out_dir)) {
  ValidateSacOptions(options_);
  std::filesystem::create_directories(out_dir_);
  env_ = make_env_();
  TORCH_CHECK(env_ && env_->obs_dim() > 0 && env_->action_dim() > 0, "SacTrainer: no environment");
  if (std::isnan(options_.target_entropy))  // resolved here, so that checkpoints state it
    options_.target_entropy = -static_cast<double>(env_->action_dim()) / 2.0;
  if (std::filesystem::exists(checkpoint_path()) ||
      std::filesystem::exists(checkpoint_path() + ".prev")) {
    LoadCheckpoint(checkpoint_path());
    return;
  }
  torch::manual_seed(options_.seed);
  rng_.seed(options_.seed);
  agent_ = std::make_unique<SacAgent>(env_->obs_dim(), env_->action_dim(), options_);
  buffer_ = std::make_unique<ReplayBuffer>(std::min(options_.buffer_size, options_.steps),
                                           env_->obs_dim(), env_->action_dim());
}

std::string SacTrainer::checkpoint_path() const { return out_dir_ + "/sac_checkpoint.pt"; }
std::string SacTrainer::policy_path() const { return out_dir_ + "/sac_policy.pt"; }

void SacTrainer::LoadCheckpoint(const std::string& path) {
  std::string used;
  const CheckpointFile file = ReadCheckpointFileOrPrevious(path, kSacCheckpointKind, &used);
  const SacHeader h = ParseHeader(file.header, used);
  if (h.obs_dim != env_->obs_dim() || h.action_dim != env_->action_dim()) {
    throw CheckpointError(used + ": the checkpoint's environment has " + std::to_string(h.obs_dim) +
                          " observation and " + std::to_string(h.action_dim) +
                          " action values; this one " + std::to_string(env_->obs_dim()) + " and " +
                          std::to_string(env_->action_dim()));
  }
  // The run's learning options are the checkpoint's; how long and how often
  // to log, save and evaluate come from this invocation.
  SacOptions o = h.options;
  o.steps = options_.steps;
  o.time_limit_s = options_.time_limit_s;
  o.log_every = options_.log_every;
  o.checkpoint_every = options_.checkpoint_every;
  o.eval_every = options_.eval_every;
  o.eval_episodes = options_.eval_episodes;
  options_ = o;
  agent_ = std::make_unique<SacAgent>(h.obs_dim, h.action_dim, options_);
  buffer_ = std::make_unique<ReplayBuffer>(std::min(options_.buffer_size, options_.steps),
                                           h.obs_dim, h.action_dim);
  try {
    torch::serialize::InputArchive archive;
    std::istringstream payload(file.payload);
    archive.load_from(payload);
    agent_->Load(archive);
    buffer_->Load(archive);
    torch::Tensor torch_rng;
    archive.read("torch_rng", torch_rng);
    torch::manual_seed(options_.seed);
    at::Generator gen = at::detail::getDefaultCPUGenerator();
    std::lock_guard<std::mutex> lock(gen.mutex());
    gen.set_state(torch_rng);
  } catch (const c10::Error& e) {
    throw CheckpointError(used +
                          ": unreadable SAC checkpoint payload: " + e.what_without_backtrace());
  }
  std::istringstream rng_text(h.rng);
  rng_text >> rng_;
  step_ = h.step;
  episode_ = h.episode;
  updates_ = h.updates;
  resumed_ = true;
}

void SacTrainer::SaveCheckpoint() {
  SacHeader h;
  h.options = options_;
  h.obs_dim = env_->obs_dim();
  h.action_dim = env_->action_dim();
  h.step = step_;
  h.episode = episode_;
  h.updates = updates_;
  std::ostringstream rng_text;
  rng_text << rng_;
  h.rng = rng_text.str();
  const std::string header = HeaderToYaml(h);
  torch::serialize::OutputArchive archive;
  agent_->Save(archive);
  buffer_->Save(archive);
  archive.write("torch_rng", at::detail::getDefaultCPUGenerator().get_state());
  WriteArchiveFile(checkpoint_path(), kSacCheckpointKind, header, archive, /*keep_previous=*/true);

  torch::serialize::OutputArchive policy;
  WriteModule(policy, "actor", *agent_->actor);
  WriteArchiveFile(policy_path(), kSacPolicyKind, header, policy);
}

double SacTrainer::Evaluate(int episodes, uint64_t seed) {
  std::unique_ptr<OnlineEnv> env = make_env_();
  double total = 0;
  for (int e = 0; e < episodes; ++e) {
    std::vector<float> obs = env->Reset(SacEpisodeSeed(seed ^ 0x5EEDull, e));
    for (;;) {
      const OnlineEnv::StepResult r = env->Step(agent_->Act(obs, /*deterministic=*/true));
      total += r.reward;
      obs = r.obs;
      if (r.terminated || r.truncated) break;
    }
  }
  return total / episodes;
}

int64_t SacTrainer::Train(const std::atomic<bool>* stop_requested) {
  stopped_ = false;
  RunDirLock lock(out_dir_);
  const std::string csv_path = out_dir_ + "/metrics.csv";
  TruncateCsvRows(csv_path, step_);
  CsvWriter csv(csv_path, {"step", "episodes", "return_mean10", "critic_loss", "actor_loss",
                           "alpha", "entropy", "q_mean", "eval_return", "wall_s"});
  ProgressBar bar(step_, options_.steps);
  if (resumed_)
    bar.Message("[sac] resumed at step " + std::to_string(step_) + " from " + checkpoint_path());
  const auto start = std::chrono::steady_clock::now();
  auto wall = [&] {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  };
  std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
  std::deque<double> returns;
  double ep_return = 0;
  NamedValues last = {{"critic_loss", NAN},
                      {"actor_loss", NAN},
                      {"alpha", agent_->alpha()},
                      {"entropy", NAN},
                      {"q_mean", NAN}};
  std::vector<float> obs = env_->Reset(SacEpisodeSeed(options_.seed, episode_));
  int64_t last_saved = step_;
  while (step_ < options_.steps) {
    std::vector<float> action(env_->action_dim());
    if (step_ < options_.random_steps) {
      for (float& a : action) a = uniform(rng_);
    } else {
      action = agent_->Act(obs, /*deterministic=*/false);
    }
    OnlineEnv::StepResult r = env_->Step(action);
    buffer_->Add(obs, action, r.reward, r.obs, r.terminated);
    ep_return += r.reward;
    obs = std::move(r.obs);
    ++step_;
    if (r.terminated || r.truncated) {
      returns.push_back(ep_return);
      if (returns.size() > 10) returns.pop_front();
      ep_return = 0;
      ++episode_;
      obs = env_->Reset(SacEpisodeSeed(options_.seed, episode_));
    }
    if (step_ > options_.random_steps && buffer_->size() >= options_.batch_size) {
      last = agent_->Update(buffer_->Sample(options_.batch_size, rng_));
      ++updates_;
    }
    double eval_return = NAN;
    if (options_.eval_every > 0 && step_ % options_.eval_every == 0) {
      eval_return = Evaluate(options_.eval_episodes, options_.seed + static_cast<uint64_t>(step_));
      bar.Message("[sac] step " + std::to_string(step_) + ": deterministic return " +
                  std::to_string(eval_return) + " over " + std::to_string(options_.eval_episodes) +
                  " episodes");
    }
    stopped_ = stop_requested != nullptr && stop_requested->load();
    const bool out_of_time =
        stopped_ || (options_.time_limit_s > 0 && wall() >= options_.time_limit_s);
    if (step_ % options_.log_every == 0 || !std::isnan(eval_return) || step_ == options_.steps ||
        out_of_time) {
      const double mean10 =
          returns.empty() ? NAN
                          : std::accumulate(returns.begin(), returns.end(), 0.0) / returns.size();
      std::vector<double> row{static_cast<double>(step_), static_cast<double>(episode_), mean10};
      for (const auto& kv : last) row.push_back(kv.second);
      row.push_back(eval_return);
      row.push_back(wall());
      csv.Write(row);
      bar.Update(step_, {{"return", mean10}, {"alpha", last[2].second}, {"q", last[4].second}});
    }
    if (options_.checkpoint_every > 0 && step_ % options_.checkpoint_every == 0) {
      SaveCheckpoint();
      last_saved = step_;
    }
    if (out_of_time) {
      bar.Message(stopped_ ? "[sac] stop requested at step " + std::to_string(step_)
                           : "[sac] time limit of " + std::to_string(options_.time_limit_s) +
                                 " s reached at step " + std::to_string(step_));
      break;
    }
  }
  if (last_saved != step_ || !std::filesystem::exists(policy_path())) SaveCheckpoint();
  bar.Finish();
  return step_;
}

}  // namespace core
}  // namespace msspr
