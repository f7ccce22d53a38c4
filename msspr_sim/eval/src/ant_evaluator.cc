#include "msspr_eval/ant_evaluator.h"

#include <torch/torch.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <stdexcept>
#include <utility>
#include <vector>

#include "msspr_core/policy.h"
#include "msspr_eval/batched_episodes.h"
#include "msspr_sim/ant_maze.h"
#include "msspr_sim/env_id.h"
#include "msspr_sim/eval_protocol.h"
#include "msspr_sim/maze_map.h"

namespace msspr::agent {

AntEvalResult EvaluateOnAntMaze(core::Policy& policy, const AntEvalOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  constexpr int kObs = sim::AntMaze::kObsDim, kAct = sim::AntMaze::kActionDim;
  const std::string env_name =
      sim::EnvLabel(sim::AntMazeEnvId(options.maze));  // throws on a bad maze
  if (policy.pixels())
    throw std::invalid_argument("EvaluateOnAntMaze: a pixels policy; " + env_name +
                                " is evaluated from states only");
  if (policy.obs_dim() != kObs)
    throw std::invalid_argument("EvaluateOnAntMaze: the policy expects " +
                                std::to_string(policy.obs_dim()) + "-dimensional observations, " +
                                env_name + " gives " + std::to_string(kObs));
  if (policy.action_dim() != kAct)
    throw std::invalid_argument("EvaluateOnAntMaze: the policy has " +
                                std::to_string(policy.action_dim()) + " action dimensions, " +
                                env_name + " takes " + std::to_string(kAct));
  if (options.episodes < 1 || options.max_steps < 1 || options.episodes_at_once < 1)
    throw std::invalid_argument(
        "EvaluateOnAntMaze: episodes, max_steps and episodes_at_once must be at least 1");

  sim::AntMazeOptions eo;
  eo.maze = options.maze;
  eo.max_episode_steps = options.max_steps;
  struct Slot {
    std::unique_ptr<sim::AntMaze> env;
    Eigen::VectorXd obs;
    bool done = false, success = false;
  };
  const int n_tasks = static_cast<int>(sim::MazeMap::FromName(options.maze).Tasks().size());
  for (int t : options.tasks)
    if (t < 1 || t > n_tasks)
      throw std::invalid_argument("EvaluateOnAntMaze: task " + std::to_string(t) +
                                  " is not a task of " + env_name + " (1 to " +
                                  std::to_string(n_tasks) + ")");
  const auto inputs = [&](const std::vector<Slot*>& active, torch::Tensor* obs,
                          torch::Tensor* goal) {
    const int64_t B = static_cast<int64_t>(active.size());
    *obs = torch::empty({B, kObs}, torch::kFloat32);
    *goal = torch::empty({B, kObs}, torch::kFloat32);
    auto o = obs->accessor<float, 2>(), g = goal->accessor<float, 2>();
    for (int64_t b = 0; b < B; ++b) {
      const Eigen::VectorXd& gs = active[b]->env->goal();
      for (int k = 0; k < kObs; ++k) {
        o[b][k] = static_cast<float>(active[b]->obs[k]);
        g[b][k] = static_cast<float>(gs[k]);
      }
    }
  };
  Eigen::VectorXd u(kAct);
  std::vector<EpisodeResult> episodes;
  RunEpisodesInGroups<Slot>(
      policy, options.tasks, options.episodes, options.episodes_at_once, options.max_steps,
      [&](int t, int e) {
        Slot s;
        s.env = std::make_unique<sim::AntMaze>(eo);
        s.obs = s.env->ResetToTask(t, sim::EvalEpisodeSeed(options.seed, t, e));
        s.success = s.done = s.env->success();
        return s;
      },
      inputs,
      [&](Slot& s, const auto& a) {
        for (int k = 0; k < kAct; ++k) u[k] = std::clamp<double>(a[k], -1.0, 1.0);
        s.obs = s.env->Step(u);
        s.success = s.env->success();
        s.done = s.success || s.env->truncated();
      },
      [&](const Slot& s) {
        episodes.push_back({s.success, s.env->steps(),
                            std::vector<double>(s.obs.data(), s.obs.data() + s.obs.size())});
      });
  AntEvalResult r = SummarizeTaskEpisodes(options.tasks, options.episodes, std::move(episodes));
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

sim::EvalReport MakeAntEvalReport(const AntEvalResult& result, const AntEvalOptions& options,
                                  const std::string& agent) {
  return MakeTaskReport(result, sim::EnvLabel(sim::AntMazeEnvId(options.maze)), agent,
                        options.episodes, options.max_steps, options.seed);
}

void WriteAntResultsJson(const AntEvalResult& result, const AntEvalOptions& options,
                         const std::string& agent, const std::string& path) {
  sim::WriteTextFile(path, sim::EvalReportJson(sim::MazeMap::FromName(options.maze),
                                               MakeAntEvalReport(result, options, agent)));
}

}  // namespace msspr::agent
