// OGBench's ant mazes (antmaze-medium, antmaze-large) on MuJoCo 2.2.2:
// the ant of ant_model.h inside the point maze's maps (maze_map.h), with the
// reset, goal construction, tasks and success test of OGBench's
// locomaze/maze.py. The API mirrors PointMaze's. No rendering yet.
//
// Threading: an AntMaze is not thread-safe; use one per thread.
#ifndef MSSPR_SIM_ANT_MAZE_H_
#define MSSPR_SIM_ANT_MAZE_H_

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "msspr_sim/ant_model.h"
#include "msspr_sim/env_id.h"
#include "msspr_sim/maze_map.h"
#include "msspr_sim/point_maze.h"

namespace msspr::sim {

struct AntMazeOptions {
  std::string maze = "medium";   // a MazeMap name ("medium", "large": AntMazeName of an EnvId)
  int max_episode_steps = 1000;  // for bookkeeping; Step() never auto-resets
  double success_radius = 0.5;   // metres, on the torso's xy
};

class AntMaze {
 public:
  // Observation: qpos (15) + qvel (14) = x, y, z, quaternion (w, x, y, z),
  // 8 hinge angles (kAntHingeJoints order, radians), 6 root velocities, 8
  // hinge velocities. Action: 8 motor controls in [-1, 1], kAntActuatorJoints
  // order.
  static constexpr int kObsDim = kAntQposDim + kAntQvelDim, kActionDim = kAntActionDim;
  static constexpr int kQposDim = kAntQposDim, kQvelDim = kAntQvelDim;
  static constexpr int kFrameSkip = kAntFrameSkip;
  // Random-action steps taken before the goal's xy is set (goal construction).
  static constexpr int kGoalRandomSteps = 5;
  // Noise added to the start and goal cell centres, U[-1, 1] m per axis.
  static constexpr double kCellNoise = 1.0;

  // Builds the model of options.maze; throws std::invalid_argument for a bad
  // maze name or options, std::runtime_error with MuJoCo's text otherwise.
  explicit AntMaze(const AntMazeOptions& options);
  ~AntMaze();
  AntMaze(const AntMaze&) = delete;
  AntMaze& operator=(const AntMaze&) = delete;

  // OGBench's evaluation reset of task task_id (1..5): start and goal xy are
  // the task's cell centres + U[-1, 1] per axis, then Reset(start, goal, .);
  // all seeded by `seed`. Returns the observation; throws
  // std::invalid_argument on a bad task id.
  Eigen::VectorXd ResetToTask(int task_id, uint64_t seed);
  // A uniformly drawn free start cell and vertex goal cell (+ the same
  // noise), then Reset(start, goal, .). Deterministic for the seed.
  Eigen::VectorXd ResetRandom(uint64_t seed);
  // OGBench's goal construction and start: noisy reset (qpos0 + U[-0.1, 0.1],
  // qvel 0.1 N(0, 1)), kGoalRandomSteps steps of U[-1, 1]^8 actions, xy :=
  // goal_xy: that full observation is the goal; then a second noisy reset
  // with xy := start_xy is the start. Zeroes the step count; returns the
  // observation.
  Eigen::VectorXd Reset(const Eigen::Vector2d& start_xy, const Eigen::Vector2d& goal_xy,
                        uint64_t seed);
  // ctrl = clip(action, -1, 1), 5 physics steps (0.1 s); returns the
  // observation. Throws std::invalid_argument on a non-finite action or a
  // size other than 8. Never auto-resets: check success() after each step.
  Eigen::VectorXd Step(const Eigen::VectorXd& action);

  // The 29-D observation (qpos then qvel).
  Eigen::VectorXd state() const;
  Eigen::VectorXd qpos() const;
  Eigen::VectorXd qvel() const;
  // The torso's (x, y) = state()[0:2], metres.
  Eigen::Vector2d xy() const;
  // The torso's height = state()[2], metres.
  double z() const;
  // Sets qpos (15) and qvel (14) (e.g. a dataset's state); the goal and step
  // count are kept. Throws std::invalid_argument on wrong sizes.
  void SetState(const Eigen::VectorXd& qpos, const Eigen::VectorXd& qvel);

  // The goal: a full 29-D observation, and its xy (= goal()[0:2]).
  const Eigen::VectorXd& goal() const { return goal_; }
  Eigen::Vector2d goal_xy() const { return goal_.head<2>(); }
  // Sets the 29-D goal; throws std::invalid_argument on another size.
  void SetGoal(const Eigen::VectorXd& goal);
  // ||xy - goal_xy|| <= success_radius.
  bool success() const;
  // Control steps since the last reset.
  int steps() const { return steps_; }
  // steps() >= max_episode_steps.
  bool truncated() const { return steps_ >= options_.max_episode_steps; }

  const MazeMap& map() const { return map_; }
  const AntMazeOptions& options() const { return options_; }
  // EnvId::kAntMazeMedium or kAntMazeLarge (env_id.h: AntMazeEnvIds,
  // AntMazeName); throws std::invalid_argument for a maze with no ant env id.
  EnvId env_id() const { return AntMazeEnvId(map_.name()); }

  // The ant's joints in model order (root free joint, then the hinges).
  std::vector<PointMaze::AgentJoint> AgentJoints() const;
  // The compiled model and its data (read-only; for tests, rendering and
  // robot-description checks).
  const mjModel* model() const;
  const mjData* data() const;

 private:
  struct Impl;
  AntMazeOptions options_;
  MazeMap map_;
  std::unique_ptr<Impl> impl_;
  Eigen::VectorXd goal_;
  int steps_ = 0;
};

}  // namespace msspr::sim

#endif  // MSSPR_SIM_ANT_MAZE_H_
