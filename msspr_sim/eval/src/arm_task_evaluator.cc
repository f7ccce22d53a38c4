#include "msspr_eval/arm_task_evaluator.h"

#include <torch/torch.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <stdexcept>
#include <utility>
#include <vector>

#include "msspr_core/policy.h"
#include "msspr_eval/batched_episodes.h"
#include "msspr_sim/cube_double_env.h"
#include "msspr_sim/env_id.h"
#include "msspr_sim/package_files.h"
#include "msspr_sim/puzzle_env.h"
#include "msspr_sim/scene_env.h"

namespace msspr::agent {
namespace {

sim::EnvId PuzzleId(int side) {
  if (side == 3) return sim::EnvId::kPuzzle3x3;
  if (side == 4) return sim::EnvId::kPuzzle4x4;
  throw std::invalid_argument("EvaluateOnPuzzle: side must be 3 or 4, got " + std::to_string(side));
}

// Checks the policy and options against an env of `env_name` (obs_dim states, 5-D actions);
// throws std::invalid_argument naming what does not fit.
template <class Options>
void CheckStatePolicy(const core::Policy& policy, const Options& options,
                      const std::string& env_name, int obs_dim, const char* who) {
  const std::string w = std::string(who) + ": ";
  if (policy.pixels())
    throw std::invalid_argument(w + env_name +
                                " is evaluated from states; this policy takes images");
  if (policy.obs_dim() != obs_dim)
    throw std::invalid_argument(w + "the policy expects " + std::to_string(policy.obs_dim()) +
                                "-dimensional observations, " + env_name + " gives " +
                                std::to_string(obs_dim));
  if (policy.action_dim() != sim::ArmEnv::kActionSize)
    throw std::invalid_argument(w + "the policy has " + std::to_string(policy.action_dim()) +
                                " action dimensions, " + env_name + " takes 5");
  for (int t : options.tasks)
    if (t < 1 || t > 5)
      throw std::invalid_argument(w + "task " + std::to_string(t) + " is not a task of " +
                                  env_name + " (1 to 5)");
  if (options.episodes < 1 || options.max_steps < 0 || options.episodes_at_once < 1)
    throw std::invalid_argument(
        w + "episodes and episodes_at_once must be at least 1 and max_steps at least 0");
}

// Every (task, episode) of `options` in an env of its own (make_env()), options.episodes_at_once
// side by side.
template <class Env, class Options, class MakeEnv>
TaskSuccessResult EvaluateStates(core::Policy& policy, const Options& options, int obs_dim,
                                 int max_steps, MakeEnv make_env) {
  const auto t0 = std::chrono::steady_clock::now();
  struct Slot {
    std::unique_ptr<Env> env;
    typename Env::Observation obs;
    bool done = false, success = false;
    int steps = 0;
  };
  const auto inputs = [&](const std::vector<Slot*>& active, torch::Tensor* obs,
                          torch::Tensor* goal) { StateInputs(active, obs_dim, obs, goal); };
  std::vector<EpisodeResult> episodes;
  RunEpisodesInGroups<Slot>(
      policy, options.tasks, options.episodes, options.episodes_at_once, max_steps,
      [&](int t, int e) {
        Slot s;
        s.env = make_env();
        s.obs = s.env->ResetToTask(t, sim::EvalEpisodeSeed(options.seed, t, e));
        s.success = s.done = s.env->Success();
        return s;
      },
      inputs,
      [&](Slot& s, const auto& a) {
        typename Env::Action u;
        for (int k = 0; k < sim::ArmEnv::kActionSize; ++k)
          u[k] = std::clamp<double>(a[k], -1.0, 1.0);
        s.success = s.env->Step(u);
        s.obs = s.env->GetObservation();
        ++s.steps;
        s.done = s.success || s.steps >= max_steps;
      },
      [&](const Slot& s) {
        episodes.push_back({s.success, s.steps, std::vector<double>(s.obs.begin(), s.obs.end())});
      });
  TaskSuccessResult r = SummarizeTaskEpisodes(options.tasks, options.episodes, std::move(episodes));
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

// An arm env's evaluation (Env::Options: its arm and cap).
template <class Env>
ArmTaskEvalResult EvaluateArmTask(core::Policy& policy, const ArmTaskEvalOptions& options,
                                  sim::EnvId id, const char* who) {
  CheckStatePolicy(policy, options, sim::EnvLabel(id), Env::kObservationSize, who);
  typename Env::Options eo;
  eo.urdf_path = options.urdf_path.empty() ? sim::DefaultArmUrdf() : options.urdf_path;
  if (options.max_steps > 0) eo.max_episode_steps = options.max_steps;
  return EvaluateStates<Env>(policy, options, Env::kObservationSize, eo.max_episode_steps,
                             [&] { return std::make_unique<Env>(eo); });
}

// The report of an arm env's evaluation (its cap when max_steps is 0).
template <class Env>
sim::EvalReport MakeArmTaskReport(const ArmTaskEvalResult& result,
                                  const ArmTaskEvalOptions& options, sim::EnvId id,
                                  const std::string& agent) {
  return MakeTaskReport(
      result, sim::EnvLabel(id), agent, options.episodes,
      options.max_steps > 0 ? options.max_steps : typename Env::Options().max_episode_steps,
      options.seed);
}

}  // namespace

PuzzleEvalResult EvaluateOnPuzzle(core::Policy& policy, const PuzzleEvalOptions& options) {
  const std::string env_name = sim::EnvLabel(PuzzleId(options.side));
  const int obs_dim = sim::ArmEnv::kProprioSize + 4 * options.side * options.side;
  CheckStatePolicy(policy, options, env_name, obs_dim, "EvaluateOnPuzzle");
  sim::PuzzleEnvOptions eo;
  eo.urdf_path = options.urdf_path.empty() ? sim::DefaultArmUrdf() : options.urdf_path;
  eo.side = options.side;
  if (options.max_steps > 0) eo.max_episode_steps = options.max_steps;
  return EvaluateStates<sim::PuzzleEnv>(policy, options, obs_dim, eo.max_episode_steps,
                                        [&] { return std::make_unique<sim::PuzzleEnv>(eo); });
}

ArmTaskEvalResult EvaluateOnCubeDouble(core::Policy& policy, const ArmTaskEvalOptions& options) {
  return EvaluateArmTask<sim::CubeDoubleEnv>(policy, options, sim::EnvId::kCubeDouble,
                                             "EvaluateOnCubeDouble");
}

ArmTaskEvalResult EvaluateOnScene(core::Policy& policy, const ArmTaskEvalOptions& options) {
  return EvaluateArmTask<sim::SceneEnv>(policy, options, sim::EnvId::kScene, "EvaluateOnScene");
}

sim::EvalReport MakePuzzleEvalReport(const PuzzleEvalResult& result,
                                     const PuzzleEvalOptions& options, const std::string& agent) {
  sim::EvalReport report =
      MakeArmTaskReport<sim::PuzzleEnv>(result, options, PuzzleId(options.side), agent);
  const auto& tasks = sim::PuzzleTasks(options.side);
  for (auto& t : report.tasks) {
    const auto& pt = tasks[static_cast<size_t>(t.task_id - 1)];
    t.start.assign(pt.start.begin(), pt.start.end());
    t.goal.assign(pt.goal.begin(), pt.goal.end());
  }
  return report;
}

void WritePuzzleResultsJson(const PuzzleEvalResult& result, const PuzzleEvalOptions& options,
                            const std::string& agent, const std::string& path) {
  sim::WriteTextFile(path, sim::EvalReportJson(MakePuzzleEvalReport(result, options, agent)));
}

sim::EvalReport MakeCubeDoubleEvalReport(const ArmTaskEvalResult& result,
                                         const ArmTaskEvalOptions& options,
                                         const std::string& agent) {
  return MakeArmTaskReport<sim::CubeDoubleEnv>(result, options, sim::EnvId::kCubeDouble, agent);
}

void WriteCubeDoubleResultsJson(const ArmTaskEvalResult& result, const ArmTaskEvalOptions& options,
                                const std::string& agent, const std::string& path) {
  sim::WriteTextFile(path, sim::EvalReportJson(MakeCubeDoubleEvalReport(result, options, agent)));
}

sim::EvalReport MakeSceneEvalReport(const ArmTaskEvalResult& result,
                                    const ArmTaskEvalOptions& options, const std::string& agent) {
  return MakeArmTaskReport<sim::SceneEnv>(result, options, sim::EnvId::kScene, agent);
}

void WriteSceneResultsJson(const ArmTaskEvalResult& result, const ArmTaskEvalOptions& options,
                           const std::string& agent, const std::string& path) {
  sim::WriteTextFile(path, sim::EvalReportJson(MakeSceneEvalReport(result, options, agent)));
}

}  // namespace msspr::agent
