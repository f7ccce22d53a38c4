// OGBench's cube-double on the URDF arm: two 4 cm cubes (cube 0 red, cube 1 blue) that collide
// with each other, each with its own goal marker; the arm, action and step of cube-single
// (ArmEnv). Observation: 37 floats, the 19 proprio entries, then per cube 10 (centre - c)
// (3), its quaternion wxyz (4) and cos / sin of its yaw (2), c = (0.425, 0, 0). An episode
// succeeds when both cubes are within 4 cm of their own goals (so the colours matter: task
// 4 swaps them).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "msspr_sim/arm_env.h"

namespace msspr::sim {

struct CubeDoubleEnvOptions : ArmEnvOptions {
  double success_distance = 0.04;  // m, each cube's centre to its goal's
  // Data collection: cube and target xy drawn in this box (m).
  Eigen::Vector2d object_low{0.30, -0.30};
  Eigen::Vector2d object_high{0.55, 0.30};
  int max_episode_steps = 500;
};

// One of OGBench's cube-double tasks: rows A and B, each a cube's start and goal centre (m).
// Each episode gives rows A / B to cubes 0 / 1 or 1 / 0 (OGBench's permute_blocks).
struct CubeDoubleTask {
  const char* name;
  std::array<Eigen::Vector3d, 2> start, goal;
};
// The 5 tasks (task ids 1 to 5 are [0] to [4]).
const std::array<CubeDoubleTask, 5>& CubeDoubleTasks();

class CubeDoubleEnv : public ArmEnv {
 public:
  using Options = CubeDoubleEnvOptions;
  static constexpr int kCubes = 2;
  static constexpr int kObservationSize = kProprioSize + 9 * kCubes;  // 37
  int observation_size() const { return kObservationSize; }

  // Throws as ArmEnv's constructor. The cubes start at (0.30, -0.05 / 0.05, 0.02), the arm at
  // home.
  explicit CubeDoubleEnv(const CubeDoubleEnvOptions& options);

  // One control step; returns Success() after it.
  bool Step(const Action& action);

  // An evaluation episode of task `task` (1 to 5) from `seed`: rows A / B permuted onto the
  // cubes; the goal observation with both cubes exactly at their goals (identity
  // orientation), a random arm and two random actions; then the state restored, the arm
  // re-randomised, each cube at its start + U(-0.01, 0.01) in x and y, yaw U(0, 2 pi); the
  // goal markers at the goals. Throws std::out_of_range for a bad task id.
  Observation ResetToTask(int task, uint64_t seed);
  // A data-collection episode from `seed`: a random arm (gripper open), each cube at rest at
  // an independent random xy of the object box (z 0.02, yaw U(0, 2 pi); OGBench draws no
  // overlap check, nor does this), and the first target by SetNewTarget with p_stack 0.5.
  Observation ResetForCollection(uint64_t seed);
  // OGBench's play target: the target cube uniform over the "top" cubes (no other cube higher
  // within 2 cm in xy); with two top cubes and U < p_stack, on top of the other one (its
  // centre + 4 cm), else at a random xy of the object box (z 0.02); yaw U(0, 2 pi). The other
  // cube's marker is parked at (0, 0, -0.3). Returns the target cube.
  int SetNewTarget(std::mt19937_64& rng, double p_stack);

  Observation GetObservation() const;
  const Observation& goal_observation() const { return goal_observation_; }
  const std::vector<uint8_t>& goal_image() const { return goal_image_; }

  void SetCube(int i, const Eigen::Vector3d& position, double yaw);
  // Moves cube i's goal marker (no physics; Success and GoalPosition see it at once).
  void SetGoal(int i, const Eigen::Vector3d& position, double yaw = 0.0);
  Eigen::Vector3d CubePosition(int i) const;
  double CubeYaw(int i) const;
  Eigen::Vector3d GoalPosition(int i) const;
  double GoalYaw(int i) const;
  bool CubeAtGoal(int i) const;
  bool Success() const { return CubeAtGoal(0) && CubeAtGoal(1); }
  // Which cube is on top (false: another cube is higher within 2 cm in xy).
  bool IsTop(int i) const;
  // The cube of the last SetNewTarget (the play target; -1 before one).
  int target_cube() const { return target_cube_; }

  int episode_steps() const { return episode_steps_; }
  bool EpisodeOver() const { return Success() || episode_steps_ >= options_.max_episode_steps; }
  const CubeDoubleEnvOptions& options() const { return options_; }

 private:
  CubeDoubleEnvOptions options_;
  std::array<int, kCubes> cube_qpos_{}, cube_qvel_{}, goal_mocap_{};
  Observation goal_observation_;
  std::vector<uint8_t> goal_image_;
  int episode_steps_ = 0, target_cube_ = -1;
};

// The objects' MJCF: the two cubes and their goal markers (hidden with pixel_style).
std::string CubeDoubleObjectsMjcf(bool pixel_style);

}  // namespace msspr::sim
