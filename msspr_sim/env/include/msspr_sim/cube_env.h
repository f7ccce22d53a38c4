// OGBench's cube-single environment on the URDF arm: the 5-D action, the
// IK-driven servo targets, 25 x 2 ms physics steps per action, the 28-D
// state observation and the success rule (OGBench's cube-single,
// sections 3 to 5), the five evaluation tasks and their seeded resets,
// collection resets and headless camera images. The play oracle is in
// cube_oracle.h, episode collection in cube_dataset.h.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "msspr_sim/arm_env.h"
#include "msspr_sim/arm_ik.h"
#include "msspr_sim/arm_model.h"
#include "msspr_sim/cube_scene.h"

namespace msspr::sim {

// The arm's options (ArmEnvOptions: URDF, scene, IK, substeps, action scale, pinch clip box,
// random start box, images) and the cube's.
struct CubeEnvOptions : ArmEnvOptions {
  double success_distance = 0.04;  // m, cube centre to goal centre
  // Data collection: cube and target xy drawn in this box (m).
  Eigen::Vector2d object_low{0.30, -0.30};
  Eigen::Vector2d object_high{0.55, 0.30};
  int max_episode_steps = 200;
};

// One of OGBench's cube-single evaluation tasks: the cube centre's start and
// goal xy (m); z is 0.02 for both.
struct CubeTask {
  const char* name;
  Eigen::Vector2d start, goal;
};
// The 5 tasks of manipulation.md section 5 (task ids 1 to 5 are [0] to [4]).
const std::array<CubeTask, 5>& CubeSingleTasks();

// Decodes a 28-D cube-single observation (CubeEnv::GetObservation): the cube
// centre (m) and its yaw (rad).
Eigen::Vector3d CubePositionFromObservation(const float* obs);
// The gripper's pinch point (m) of a 28-D observation (also of cube-double's and the
// scene's, which share the arm's first 19 numbers).
Eigen::Vector3d PinchPositionFromObservation(const float* obs);
// Moves the cube of a 28-D observation by `delta` (m), the rest unchanged.
void ShiftCubeInObservation(float* obs, const Eigen::Vector3d& delta);
double CubeYawFromObservation(const float* obs);

class CubeEnv {
 public:
  using Options = CubeEnvOptions;
  static constexpr int kObservationSize = 28;
  static constexpr int kActionSize = 5;
  using Observation = std::array<float, kObservationSize>;
  using Action = std::array<double, kActionSize>;

  // Parses the URDF, generates and compiles the scene. Throws UrdfError for
  // a bad URDF and std::runtime_error when MuJoCo rejects the scene. The arm
  // starts at OGBench's home joints, gripper open, the cube at (0.3, 0, 0.02).
  explicit CubeEnv(const CubeEnvOptions& options);
  ~CubeEnv();
  CubeEnv(const CubeEnv&) = delete;
  CubeEnv& operator=(const CubeEnv&) = delete;

  // One control step: the action (not clipped; callers clip to [-1, 1], as
  // OGBench's) moves the target pinch pose from the measured one, the IK
  // turns it into arm servo targets, then `substeps` physics steps run.
  // Returns whether the cube is within success_distance of the goal after it.
  bool Step(const Action& action);

  // Starts an evaluation episode of task `task` (1 to 5) as OGBench does,
  // deterministically from `seed`: a random arm pose (PlacePinch at a random
  // pinch pose, gripper open); the goal observation made by putting the cube
  // at the goal (identity orientation) and taking two uniformly random
  // actions; then the state restored, the arm re-randomised, and the cube at
  // the task's start + U(-0.01, 0.01) in x and y, yaw U(0, 2 pi). The goal
  // marker sits at the goal. Returns the first observation; throws
  // std::out_of_range for a bad task id.
  Observation ResetToTask(int task, uint64_t seed);
  // Starts a data-collection episode deterministically from `seed`: a random
  // arm pose (gripper open), the cube at rest at a random xy in the object
  // box (z 0.02, yaw U(0, 2 pi)) and the goal marker at another (the first
  // target of the play oracle). No goal observation. Returns the first
  // observation.
  Observation ResetForCollection(uint64_t seed);
  // A goal given as an observation (a user's goal, not a task's): the goal
  // marker moves to its cube position and yaw, goal_observation() becomes
  // `goal`, and with enable_rendering goal_image() is re-rendered: the scene
  // posed as `goal` (arm joints, opening, cube position and yaw), then the
  // state restored exactly, so the episode goes on unchanged.
  void SetGoalObservation(const Observation& goal);
  // The scene posed as observation `obs` (as above), rendered; the state is
  // restored. Throws std::logic_error unless enable_rendering.
  std::vector<uint8_t> RenderObservation(const Observation& obs);
  // The goal observation of the current episode (zeros before a reset).
  const Observation& goal_observation() const { return goal_observation_; }
  // With enable_rendering, the goal image of the current episode, rendered
  // with the goal observation; empty otherwise or before a reset.
  const std::vector<uint8_t>& goal_image() const { return goal_image_; }

  // Renders the current state: [S, S, 3] uint8 HWC, row 0 = top,
  // S = image_size. Throws std::logic_error unless enable_rendering.
  void Render(uint8_t* rgb) const;
  std::vector<uint8_t> Render() const;
  // Renders `source`'s scene as it stands, the image source->Render() would
  // give: its whole physics state is copied into this env (whose own state is
  // replaced) and rendered with this env's camera. One rendering env can so
  // draw many episodes that run without rendering. `source` must be built
  // from the same arm and scene (std::invalid_argument otherwise); throws
  // std::logic_error unless this env has enable_rendering.
  void RenderStateOf(const CubeEnv& source, uint8_t* rgb);
  // Steps since the last reset; an episode ends on success or at
  // max_episode_steps.
  int episode_steps() const { return episode_steps_; }
  bool EpisodeOver() const { return Success() || episode_steps_ >= options_.max_episode_steps; }

  // The 28-D state: arm q (6), arm qdot (6), 10 (pinch - c) (3), cos / sin of
  // the pinch yaw (2), 3 x opening (1), pad contact in [0, 1] (1),
  // 10 (cube - c) (3), cube quaternion wxyz (4), cos / sin of the cube yaw
  // (2); c = (0.425, 0, 0). float32, as OGBench's.
  Observation GetObservation() const;

  // State setters, each followed by mj_forward (but SetGoal). Arm joints
  // [6] (rad), with zero velocity and servo targets equal to them; the
  // gripper opening in [0, 1]; the cube centre (m) and yaw (rad) at rest;
  // the goal marker's centre (m) and yaw (rad): it moves the mocap target
  // only, the marker's drawn pose follows at the next step (Success and
  // GoalPosition see it at once).
  void SetArmJoints(const Eigen::Matrix<double, 6, 1>& q);
  // Solves the IK from the home joints for the pinch at `position` pointing
  // down with `yaw` (OGBench's initial placement); returns whether it converged.
  bool PlacePinch(const Eigen::Vector3d& position, double yaw);
  void SetOpening(double opening);
  void SetCube(const Eigen::Vector3d& position, double yaw);
  void SetGoal(const Eigen::Vector3d& position, double yaw = 0.0);

  Eigen::Vector3d PinchPosition() const;
  // ZYX yaw of the pinch frame, atan2(2 (wz + xy), 1 - 2 (y^2 + z^2)).
  double PinchYaw() const;
  Eigen::Matrix3d PinchRotation() const;
  // clip(finger travel / gripper travel, 0, 1): 0 open, 1 closed.
  double Opening() const;
  Eigen::Vector3d CubePosition() const;
  double CubeYaw() const;  // ZYX yaw of the cube's quaternion
  Eigen::Vector3d GoalPosition() const;
  double GoalYaw() const;
  bool Success() const;
  Eigen::Matrix<double, 6, 1> ArmJoints() const;
  // The full MuJoCo state: qpos [nq] and qvel [nv].
  std::vector<double> Qpos() const;
  std::vector<double> Qvel() const;
  // Whether the last Step's IK met its tolerances.
  bool last_ik_converged() const { return last_ik_converged_; }

  const ArmModel& arm() const;
  int observation_size() const { return kObservationSize; }
  const CubeEnvOptions& options() const { return options_; }
  const std::string& mjcf() const { return mjcf_; }

 private:
  struct Impl;
  // Random arm pose as at an episode start; gripper open.
  void RandomizeArm(std::mt19937_64& rng);

  CubeEnvOptions options_;
  std::string mjcf_;
  std::unique_ptr<Impl> impl_;
  bool last_ik_converged_ = true;
  Observation goal_observation_{};
  std::vector<uint8_t> goal_image_;
  int episode_steps_ = 0;
};

// The target orientation of OGBench's cube tasks: Rz(yaw) Rx(pi), the tool
// pointing straight down.
Eigen::Matrix3d PinchDownRotation(double yaw);
// The same as a quaternion: the oracles' grasp orientation at `yaw`.
Eigen::Quaterniond PinchDown(double yaw);

}  // namespace msspr::sim
