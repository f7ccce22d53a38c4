// OGBench's scene on the URDF arm: a cube, two push buttons that lock and unlock a drawer and a
// window, the drawer and the window (ArmEnv's arm, action and step). Button 0 in state 0 locks
// the drawer (its slide damped at 1e6) and state 1 frees it (damping 2); button 1 does the
// same for the window. A button toggles when its cap crosses -0.02 m during a step, as the
// puzzles' (puzzle_env.h). Observation (40 floats): the 19 proprio entries; 10 (cube - c),
// the cube's quaternion wxyz and cos / sin of its yaw; per button its state one-hot, 120 x its
// joint and its joint velocity; 18 x the drawer's slide and its velocity; 15 x the window's
// slide and its velocity. Success: the cube within 4 cm of its goal, both button states, and
// the drawer and the window within 4 cm of theirs.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "msspr_sim/arm_env.h"

namespace msspr::sim {

struct SceneEnvOptions : ArmEnvOptions {
  // OGBench's scene box for random pinch poses.
  SceneEnvOptions() {
    init_low = {0.25, -0.20, 0.20};
    init_high = {0.60, 0.20, 0.35};
  }
  double success_distance = 0.04;  // m: the cube to its goal; the drawer and window slides
  double press_depth = -0.02;      // m: a button is pressed when its joint crosses this
  // Cube and target xy are drawn in this box (m).
  Eigen::Vector2d object_low{0.30, -0.07};
  Eigen::Vector2d object_high{0.45, 0.18};
  int max_episode_steps = 750;
};

// The scene's state beside the arm: where a task starts or ends.
struct SceneState {
  Eigen::Vector3d cube;        // centre (m)
  std::array<int, 2> buttons;  // 0 or 1
  double drawer = 0;           // slide (m): 0 closed, -0.16 open
  double window = 0;           // slide (m): 0 closed, 0.2 open
};

struct SceneTask {
  const char* name;
  SceneState start, goal;
};
// OGBench's five scene tasks (task ids 1 to 5 are [0] to [4]).
const std::array<SceneTask, 5>& SceneTasks();

class SceneEnv : public ArmEnv {
 public:
  using Options = SceneEnvOptions;
  static constexpr int kObservationSize = 40;
  static constexpr double kDrawerOpen = -0.16, kWindowOpen = 0.2;

  // Throws as ArmEnv's constructor. Both buttons in state 0 (drawer and window locked), both
  // closed, the cube at (0.3, 0, 0.02).
  explicit SceneEnv(const SceneEnvOptions& options);
  int observation_size() const { return kObservationSize; }

  // One control step, the presses seen in it, the locks; returns Success() after it.
  bool Step(const Action& action);

  // An evaluation episode of task `task` (1 to 5) from `seed`: the goal observation with
  // everything exactly at the goal (the cube with identity orientation), a random arm and two
  // random actions; then the state restored, the arm re-randomised, the cube at its start +
  // U(-0.01, 0.01) in x and y with yaw U(0, 2 pi), the buttons set, the drawer and window at
  // their starts + U(-0.01, 0.01) within their ranges. Throws std::out_of_range for a bad id.
  Observation ResetToTask(int task, uint64_t seed);

  // A data-collection episode from `seed`: a random arm (gripper open), the cube at rest at a
  // random xy of the object box (z 0.02, yaw U(0, 2 pi)), each button state U{0, 1}, the
  // drawer U(-0.16, 0), the window U(0, 0.2). No goal (the play oracle draws its targets).
  Observation ResetForCollection(uint64_t seed);

  Observation GetObservation() const;
  const Observation& goal_observation() const { return goal_observation_; }
  const std::vector<uint8_t>& goal_image() const { return goal_image_; }

  // Poses everything but the arm at rest (buttons up); the locks and colours follow.
  void SetSceneState(const SceneState& s, double cube_yaw = 0.0);
  SceneState GetSceneState() const;
  void SetGoalState(const SceneState& goal) { goal_ = goal; }
  const SceneState& goal_state() const { return goal_; }
  bool Success() const;
  // Moves the cube's goal marker (the play oracle's target; no physics, as CubeEnv::SetGoal).
  void SetCubeTarget(const Eigen::Vector3d& position, double yaw);
  Eigen::Vector3d CubeTargetPosition() const;  // the goal marker's
  double CubeTargetYaw() const;
  // Whether the cube is in the drawer's tray (x 0.21-0.45, y from the handle's - 0.27 to its
  // - 0.07, z 0-0.15; OGBench's test).
  bool CubeInDrawer() const;

  Eigen::Vector3d CubePosition() const;
  double CubeYaw() const;
  const double* CubeQpos() const;  // the cube's 7 qpos entries (x, y, z, quaternion w x y z)
  double Drawer() const;
  double Window() const;
  const std::array<int, 2>& button_states() const { return states_; }
  bool DrawerLocked() const { return states_[0] == 0; }
  bool WindowLocked() const { return states_[1] == 0; }
  Eigen::Vector3d ButtonTop(int k) const;
  Eigen::Vector3d DrawerHandle() const;  // the site drawer_handle_center (m)
  Eigen::Vector3d WindowHandle() const;  // the site window_handle_center (m)
  // The origins of the sliding bodies: the drawer's tray (drawer_link, (0.33, -0.41, 0.09)
  // when closed) and the window's pane (windowb_a, (0.206, 0.283, 0.202) when closed); both
  // keep the world's orientation.
  Eigen::Vector3d DrawerPosition() const;
  Eigen::Vector3d WindowPosition() const;
  double ButtonJoint(int k) const;  // button k's cap slide (m; 0 up, pressing is negative)

  // The scene state an observation of this env shows (cube centre and yaw, button states,
  // drawer and window slides); throws std::invalid_argument unless it has 40 entries and each
  // button's state entries are (1, 0) or (0, 1).
  static SceneState StateFromObservation(const std::vector<float>& obs, double* cube_yaw);

  int episode_steps() const { return episode_steps_; }
  bool EpisodeOver() const { return Success() || episode_steps_ >= options_.max_episode_steps; }
  const SceneEnvOptions& options() const { return options_; }

 private:
  void ApplyButtonStates();

  SceneEnvOptions options_;
  int cube_qpos_ = -1, cube_qvel_ = -1, drawer_qpos_ = -1, drawer_qvel_ = -1, window_qpos_ = -1,
      window_qvel_ = -1;
  int drawer_dof_ = -1, window_dof_ = -1, goal_mocap_ = -1;
  std::array<int, 2> button_qpos_{}, button_qvel_{}, button_site_{}, button_geom_{};
  int drawer_handle_site_ = -1, window_handle_site_ = -1, drawer_handle_geom_ = -1,
      window_handle_geom_ = -1, drawer_body_ = -1, window_body_ = -1;
  std::array<int, 2> states_{};
  SceneState goal_{};
  Observation goal_observation_;
  std::vector<uint8_t> goal_image_;
  int episode_steps_ = 0;
};

// The scene's objects (cube and goal marker, buttons, drawer, window) as MJCF.
std::string SceneObjectsMjcf(bool pixel_style);

}  // namespace msspr::sim
