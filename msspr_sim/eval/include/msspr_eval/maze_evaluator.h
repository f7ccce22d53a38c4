// In-process evaluation of a Policy on a point maze by OGBench's protocol
// (no ROS): the tasks' resets with the same seeds as msspr_eval over ROS, up to
// max_steps steps, success within the success radius. All episodes run side
// by side, one policy call per control step, each episode's action computed on
// its own (Policy::Act), so outcomes do not depend on the thread count or the
// number of episodes.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "msspr_eval/eval_result.h"
#include "msspr_sim/custom_tasks.h"
#include "msspr_sim/eval_protocol.h"

namespace msspr::core {
class Policy;
}

namespace msspr::agent {

struct MazeEvalOptions {
  std::string maze = "medium";
  std::vector<int> tasks = {1, 2, 3, 4, 5};
  int episodes = 50;  // per task
  int max_steps = 1000;
  uint64_t seed = 0;        // episode e of task t: sim::EvalEpisodeSeed(seed, t, e), as msspr_eval
  bool keep_paths = false;  // record the trajectories (for plots)
  // When not empty: these tasks instead of `tasks`; each of their episodes starts
  // exactly at the task's start (as msspr_eval --tasks-file over ROS), and the
  // result's tasks are their ids.
  std::vector<sim::CustomTask> custom_tasks;
};

struct MazeEvalResult : TaskSuccessResult {
  // With keep_paths: per task, per episode.
  std::vector<std::vector<std::vector<Eigen::Vector2d>>> paths;
  std::vector<std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>>> start_goal;
  std::vector<std::vector<bool>> episode_success;
};

// Runs the evaluation; pixels policies get 64x64 renders (a rendering context is
// created on the calling thread). Throws std::invalid_argument on a bad maze or
// task, or when the policy's dimensions do not fit the maze.
MazeEvalResult EvaluateOnMaze(core::Policy& policy, const MazeEvalOptions& options);

// The value-error map of the paper's App. E: for one goal, starts on a grid over
// the free cells; from each, `rollouts` episodes of the frozen policy (each from
// the grid point plus U[-start_noise, start_noise] per axis, as OGBench's reset
// noise: the point maze and the policy are deterministic, so this is where
// rollouts differ). The true value of an episode is its discounted return under
// the training reward (-1 per step before the goal, 0 from it on, as the
// relabelled reward and the critic's mask): -(1 - gamma^T) / (1 - gamma) for T
// steps to success, or for T = max_steps on failure (a truncated return).
// The predicted value is the critic's min over its twin heads of
// Q(s, pi(s, g), g) at the episode's actual start.
struct ValueMapOptions {
  std::string maze = "medium";
  Eigen::Vector2d goal = Eigen::Vector2d::Zero();
  int per_cell = 3;          // starts per cell per axis (per_cell^2 per free cell)
  int rollouts = 10;         // episodes per start
  double start_noise = 0.1;  // metres
  int max_steps = 1000;
  uint64_t seed = 0;
};

struct ValueMapPoint {
  Eigen::Vector2d xy;
  double predicted = 0, true_value = 0, success = 0;  // means over the rollouts
};

struct ValueMapResult {
  std::vector<ValueMapPoint> points;
  double gamma = 0.99;
  double mean_abs_error = 0, bias = 0;  // mean |pred - true|, mean (pred - true)
  double correlation = 0;               // Pearson, over the points
  double mean_success = 0;
  int episodes = 0;
  double seconds = 0;
};

// Throws std::invalid_argument on a bad maze, a goal inside a wall, or options
// out of range.
ValueMapResult ComputeValueMap(core::Policy& policy, const ValueMapOptions& options);

// The map's three heatmaps (dir/value_predicted.png, value_true.png,
// value_error.png: predicted - true) and dir/value_map.json (options, summary
// numbers and every point). Throws std::runtime_error naming the path.
void WriteValueMap(const ValueMapResult& result, const ValueMapOptions& options,
                   const std::string& agent, const std::string& dir);

// The results of an evaluation in msspr_eval's report form (custom tasks with
// their exact start and goal), mean_success filled.
sim::EvalReport MakeEvalReport(const MazeEvalResult& result, const MazeEvalOptions& options,
                               const std::string& agent);

// Writes the results JSON shared with msspr_eval ({env, agent, mean_success,
// tasks: [{task_id, success, ...}]}); throws std::runtime_error naming the path.
void WriteResultsJson(const MazeEvalResult& result, const MazeEvalOptions& options,
                      const std::string& agent, const std::string& path);

}  // namespace msspr::agent
