// OGBench's point-maze environment (docs/datasets.md) on MuJoCo 2.2.2, with
// optional headless 64x64 rendering (EGL surfaceless or OSMesa).
//
// Threading: a PointMaze is not thread-safe. A rendering PointMaze owns an
// offscreen GL context that it makes current on the calling thread for each
// render; use at most one rendering PointMaze per thread.
#ifndef MSSPR_SIM_POINT_MAZE_H_
#define MSSPR_SIM_POINT_MAZE_H_

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "msspr_sim/maze_map.h"

namespace msspr::sim {

struct PointMazeOptions {
  std::string maze = "medium";
  bool enable_rendering = false;  // create the offscreen GL context + mjrContext
  int image_size = 64;            // rendered images are [S, S, 3] uint8
  int max_episode_steps = 1000;   // for bookkeeping; Step() never auto-resets
  double success_radius = 1.0;    // metres
};

class PointMaze {
 public:
  static constexpr int kObsDim = 2, kActionDim = 2;
  // Position change per control step for a unit action, metres.
  static constexpr double kActionScale = 0.2;
  // Physics steps per control step (timestep 0.02 s, RK4).
  static constexpr int kFrameSkip = 5;

  // Builds the model of options.maze (and the GL context when rendering);
  // throws std::invalid_argument for a bad maze name or image size and
  // std::runtime_error with the MuJoCo / EGL error text on other failures.
  explicit PointMaze(const PointMazeOptions& options);
  ~PointMaze();
  PointMaze(const PointMaze&) = delete;
  PointMaze& operator=(const PointMaze&) = delete;

  // OGBench evaluation reset of task task_id (1..5): start and goal are the
  // task's cell centres plus U[-1,1] noise per axis, qpos gets U[-0.1,0.1]
  // noise; all seeded by `seed`. Returns the state; throws
  // std::invalid_argument on a bad task id.
  Eigen::Vector2d ResetToTask(int task_id, uint64_t seed);
  // Random start free cell (+ the same noise) and random vertex goal cell
  // (+ noise); deterministic for the seed. Returns the state.
  Eigen::Vector2d ResetRandom(uint64_t seed);
  // Places the agent exactly at `start` (zero velocity), sets the goal,
  // zeroes the step count. Returns the state.
  Eigen::Vector2d Reset(const Eigen::Vector2d& start, const Eigen::Vector2d& goal);
  // Clips the action to [-1,1]^2, qpos += 0.2 a, qvel = 0, then 5 physics
  // steps; returns the new state. Throws std::invalid_argument on a
  // non-finite action. Never auto-resets.
  Eigen::Vector2d Step(const Eigen::Vector2d& action);

  // Agent position (x, y), metres.
  Eigen::Vector2d state() const;
  Eigen::Vector2d goal() const { return goal_; }
  void SetGoal(const Eigen::Vector2d& g) { goal_ = g; }
  // ||state - goal|| <= success_radius.
  bool success() const;
  // Control steps since the last reset.
  int steps() const { return steps_; }
  // steps() >= max_episode_steps.
  bool truncated() const { return steps_ >= options_.max_episode_steps; }

  const MazeMap& map() const { return map_; }
  const PointMazeOptions& options() const { return options_; }

  // Renders the current state into rgb: [S, S, 3] uint8 HWC, row 0 = top,
  // S = image_size. Throws std::logic_error unless enable_rendering.
  void Render(uint8_t* rgb) const;
  std::vector<uint8_t> Render() const;
  // The image with the agent placed at xy; the state is restored afterwards.
  std::vector<uint8_t> RenderAt(const Eigen::Vector2d& xy) const;
  // RenderAt(goal()).
  std::vector<uint8_t> RenderGoal() const;

  // The agent's joints as the loaded MuJoCo model has them, in model order
  // (for checks of a robot description against the simulation).
  struct AgentJoint {
    std::string name;
    std::string type;  // "slide" (the point maze's only kind), "hinge", "ball" or "free"
    Eigen::Vector3d axis = Eigen::Vector3d::Zero();
    bool limited = false;
    double lower = 0, upper = 0;  // metres, when limited
  };
  std::vector<AgentJoint> AgentJoints() const;
  // Radius of the agent's sphere geom ("agent_geom") in the loaded model, metres.
  double AgentRadius() const;

 private:
  void RenderPose(double x, double y, uint8_t* rgb) const;

  struct Impl;
  PointMazeOptions options_;
  MazeMap map_;
  std::unique_ptr<Impl> impl_;
  Eigen::Vector2d goal_ = Eigen::Vector2d::Zero();
  int steps_ = 0;
};

}  // namespace msspr::sim

#endif  // MSSPR_SIM_POINT_MAZE_H_
