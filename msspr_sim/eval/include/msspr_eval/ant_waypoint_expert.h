// The ant mazes' waypoint expert (OGBench's data_gen_scripts/generate_locomaze.py):
// every step, the BFS waypoint planner (msspr_sim/ant_planner.h) gives a unit
// direction from the torso's xy toward the goal; the direction-following
// expert (a SacPolicy trained in online-ant-xy, msspr_train_expert) sees the
// 27 body values ob[2:] and that direction, and acts with tanh(mean), plus
// N(0, noise_std^2) per value clipped to [-1, 1] for datasets.
// And the expert's own evaluation on a maze's tasks (success and speed).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "msspr_core/sac.h"
#include "msspr_eval/eval_result.h"
#include "msspr_sim/ant_maze.h"
#include "msspr_sim/ant_planner.h"
#include "msspr_sim/maze_map.h"

namespace msspr::agent {

// The expert's input: ob[2:] (the 27 body values of a 29-D ant observation)
// then the unit direction (2), as float32. Throws std::invalid_argument when
// ob does not have 29 values.
std::vector<float> AntExpertInput(const Eigen::VectorXd& ob, const Eigen::Vector2d& dir);

class AntWaypointExpert {
 public:
  static constexpr int kInputDim = sim::AntMaze::kObsDim - 2 + 2;  // 27 + 2
  // Keeps references to `policy` and `map` (they must outlive the expert).
  // noise_std 0: noise-free (evaluation); OGBench's datasets use 0.2. The
  // noise is drawn from a stream seeded by `seed`. Throws
  // std::invalid_argument when the policy is not 29 -> 8 or noise_std < 0.
  AntWaypointExpert(core::SacPolicy& policy, const sim::MazeMap& map, double noise_std = 0.0,
                    uint64_t seed = 0);

  // One step for the 29-D observation `ob` heading to goal_xy: dir =
  // AntPlanner::Direction(ob[0:2], goal_xy); a = tanh(mean(AntExpertInput(ob,
  // dir))); with noise, a + N(0, noise_std^2) per value, clipped to [-1, 1].
  Eigen::VectorXd Act(const Eigen::VectorXd& ob, const Eigen::Vector2d& goal_xy);
  // The policy's tanh(mean) for `ob` and a given direction (no planner, no noise).
  Eigen::VectorXd Deterministic(const Eigen::VectorXd& ob, const Eigen::Vector2d& dir);

  // Of the last Act: the direction, the input, tanh(mean), and the noisy
  // action before clipping (equal to tanh(mean) without noise).
  const Eigen::Vector2d& last_direction() const { return last_dir_; }
  const std::vector<float>& last_input() const { return last_input_; }
  const Eigen::VectorXd& last_deterministic() const { return last_det_; }
  const Eigen::VectorXd& last_unclipped() const { return last_unclipped_; }
  double noise_std() const { return noise_std_; }
  sim::AntPlanner& planner() { return planner_; }

 private:
  core::SacPolicy* policy_;
  sim::AntPlanner planner_;
  double noise_std_;
  std::mt19937_64 rng_;
  Eigen::Vector2d last_dir_ = Eigen::Vector2d::Zero();
  std::vector<float> last_input_;
  Eigen::VectorXd last_det_, last_unclipped_;
};

// The expert's evaluation: OGBench's tasks of one ant maze, noise-free.
struct AntExpertEvalOptions {
  std::string maze = "medium";  // "medium" or "large"
  std::vector<int> tasks{1, 2, 3, 4, 5};
  int episodes = 50;     // per task
  int max_steps = 1000;  // the episode ends on success or here
  uint64_t seed = 0;     // episode e of task t: sim::EvalEpisodeSeed(seed, t, e)
  // Called after each episode with (task, episode, success, steps); may be empty.
  std::function<void(int, int, bool, int)> on_episode;
};

struct AntExpertEvalResult : TaskSuccessResult {
  // The torso's mean speed along its path, m/s: the summed xy path length
  // over the summed time (0.1 s per control step), per task and over all.
  std::vector<double> speed;
  double mean_speed = 0.0;
  int64_t steps = 0;  // control steps run in all
};

// Runs the tasks x episodes with a fresh AntMaze of options.maze; throws
// std::invalid_argument for a bad maze or task.
AntExpertEvalResult EvaluateAntExpert(core::SacPolicy& policy, const AntExpertEvalOptions& options);

}  // namespace msspr::agent
