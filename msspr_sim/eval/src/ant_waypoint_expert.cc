#include "msspr_eval/ant_waypoint_expert.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>

#include "msspr_sim/eval_protocol.h"

namespace msspr::agent {
namespace {

// Portable N(0, 1) (Box-Muller over 53-bit uniforms): the std::
// distributions are implementation-defined.
double Uniform01(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }
double StandardNormal(std::mt19937_64& rng) {
  const double u1 = 1.0 - Uniform01(rng);  // (0, 1]
  const double u2 = Uniform01(rng);
  return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * M_PI * u2);
}

}  // namespace

std::vector<float> AntExpertInput(const Eigen::VectorXd& ob, const Eigen::Vector2d& dir) {
  if (ob.size() != sim::AntMaze::kObsDim)
    throw std::invalid_argument("AntExpertInput: expected a 29-D ant observation, got " +
                                std::to_string(ob.size()) + " values");
  std::vector<float> in;
  in.reserve(AntWaypointExpert::kInputDim);
  for (Eigen::Index i = 2; i < ob.size(); ++i) in.push_back(static_cast<float>(ob[i]));
  in.push_back(static_cast<float>(dir.x()));
  in.push_back(static_cast<float>(dir.y()));
  return in;
}

AntWaypointExpert::AntWaypointExpert(core::SacPolicy& policy, const sim::MazeMap& map,
                                     double noise_std, uint64_t seed)
    : policy_(&policy), planner_(map), noise_std_(noise_std), rng_(seed) {
  if (policy.obs_dim() != kInputDim || policy.action_dim() != sim::AntMaze::kActionDim)
    throw std::invalid_argument(
        "AntWaypointExpert: the expert must map " + std::to_string(kInputDim) + " inputs to " +
        std::to_string(sim::AntMaze::kActionDim) + " actions, not " +
        std::to_string(policy.obs_dim()) + " -> " + std::to_string(policy.action_dim()));
  if (!(noise_std >= 0.0)) throw std::invalid_argument("AntWaypointExpert: noise_std must be >= 0");
}

Eigen::VectorXd AntWaypointExpert::Deterministic(const Eigen::VectorXd& ob,
                                                 const Eigen::Vector2d& dir) {
  last_input_ = AntExpertInput(ob, dir);
  const std::vector<float> a = policy_->Act(last_input_);
  Eigen::VectorXd out(static_cast<Eigen::Index>(a.size()));
  for (size_t i = 0; i < a.size(); ++i) out[static_cast<Eigen::Index>(i)] = a[i];
  return out;
}

Eigen::VectorXd AntWaypointExpert::Act(const Eigen::VectorXd& ob, const Eigen::Vector2d& goal_xy) {
  if (ob.size() != sim::AntMaze::kObsDim)
    throw std::invalid_argument("AntWaypointExpert::Act: expected a 29-D ant observation, got " +
                                std::to_string(ob.size()) + " values");
  last_dir_ = planner_.Direction(ob.head<2>(), goal_xy);
  last_det_ = Deterministic(ob, last_dir_);
  last_unclipped_ = last_det_;
  if (noise_std_ > 0.0)
    for (Eigen::Index i = 0; i < last_unclipped_.size(); ++i)
      last_unclipped_[i] += noise_std_ * StandardNormal(rng_);
  return last_unclipped_.cwiseMax(-1.0).cwiseMin(1.0);
}

AntExpertEvalResult EvaluateAntExpert(core::SacPolicy& policy, const AntExpertEvalOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  sim::AntMazeOptions eo;
  eo.maze = o.maze;
  eo.max_episode_steps = o.max_steps;
  sim::AntMaze env(eo);
  for (int task : o.tasks)
    if (task < 1 || task > static_cast<int>(env.map().Tasks().size()))
      throw std::invalid_argument("EvaluateAntExpert: no task " + std::to_string(task));
  AntWaypointExpert expert(policy, env.map(), 0.0);
  const double dt = sim::kAntTimestep * sim::kAntFrameSkip;
  AntExpertEvalResult r;
  double all_path = 0.0;
  int64_t all_steps = 0;
  for (int task : o.tasks) {
    int successes = 0;
    double steps_success = 0.0, path = 0.0;
    int64_t steps = 0;
    for (int e = 0; e < o.episodes; ++e) {
      Eigen::VectorXd ob = env.ResetToTask(task, sim::EvalEpisodeSeed(o.seed, task, e));
      const Eigen::Vector2d goal = env.goal_xy();
      bool success = false;
      while (!env.truncated()) {
        const Eigen::Vector2d before = env.xy();
        ob = env.Step(expert.Act(ob, goal));
        path += (env.xy() - before).norm();
        ++steps;
        if (env.success()) {
          success = true;
          break;
        }
      }
      if (success) {
        ++successes;
        steps_success += env.steps();
      }
      if (o.on_episode) o.on_episode(task, e, success, env.steps());
    }
    r.tasks.push_back(task);
    r.success.push_back(o.episodes > 0 ? static_cast<double>(successes) / o.episodes : 0.0);
    r.mean_steps_success.push_back(successes > 0 ? steps_success / successes : 0.0);
    r.speed.push_back(steps > 0 ? path / (static_cast<double>(steps) * dt) : 0.0);
    all_path += path;
    all_steps += steps;
  }
  double sum = 0.0;
  for (double s : r.success) sum += s;
  r.mean_success = r.success.empty() ? 0.0 : sum / static_cast<double>(r.success.size());
  r.mean_speed = all_steps > 0 ? all_path / (static_cast<double>(all_steps) * dt) : 0.0;
  r.steps = all_steps;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace msspr::agent
