// In-process evaluation of a Policy on a point maze by OGBench's protocol
// (no ROS): the tasks' resets with the same seeds as msspr_eval over ROS, up to
// max_steps steps, success within the success radius. All episodes run side
// by side so that each control step is one batched forward pass.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace msspr::core {
class Policy;
}

namespace msspr::agent {

struct MazeEvalOptions {
  std::string maze = "medium";
  std::vector<int> tasks = {1, 2, 3, 4, 5};
  int episodes = 50;        // per task
  int max_steps = 1000;
  uint64_t seed = 0;        // episode e of task t: sim::EvalEpisodeSeed(seed, t, e), as msspr_eval
  bool keep_paths = false;  // record the trajectories (for plots)
};

struct MazeEvalResult {
  std::vector<int> tasks;
  std::vector<double> success;              // per task, in [0, 1]
  std::vector<double> mean_steps_success;   // per task, steps of the successful episodes
  double mean_success = 0.0;
  double seconds = 0.0;
  // With keep_paths: per task, per episode.
  std::vector<std::vector<std::vector<Eigen::Vector2d>>> paths;
  std::vector<std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>>> start_goal;
  std::vector<std::vector<bool>> episode_success;
};

// Runs the evaluation; pixels policies get 64x64 renders (a rendering context is
// created on the calling thread). Throws std::invalid_argument on a bad maze or
// task, or when the policy's dimensions do not fit the maze.
MazeEvalResult EvaluateOnMaze(core::Policy& policy, const MazeEvalOptions& options);

// Writes the results JSON shared with msspr_eval ({env, agent, mean_success,
// tasks: [{task_id, success, ...}]}); throws std::runtime_error naming the path.
void WriteResultsJson(const MazeEvalResult& result, const MazeEvalOptions& options,
                      const std::string& agent, const std::string& path);

}  // namespace msspr::agent
