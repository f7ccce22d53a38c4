// OGBench's puzzle-3x3 and puzzle-4x4 ("Lights Out") on the URDF arm: an R x R grid of
// push buttons on the table, each red (0) or blue (1); a press toggles the button and its
// row and column neighbours (lights_out.h). The arm, the 5-D action, 25 x 2 ms physics
// steps per action and the 19 proprioceptive entries are cube-single's (cube_env.h).
//
// Buttons: box k = i R + j at x = 0.425 - 0.05 (R - 1) + 0.1 i, y = -0.05 (R - 1) + 0.1 j;
// its cap slides down up to 2.4 cm on a spring. A press is seen once per action: the
// button's joint above -0.02 m before the substeps and at or below it after them. The
// observation is 19 + 4 N floats (55 for 3 x 3, 83 for 4 x 4): the proprio entries, then per
// button its state one-hot (state 0 -> (1, 0)), 120 x its joint position and its joint
// velocity. An episode succeeds when every state equals the goal's.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "msspr_sim/arm_env.h"
#include "msspr_sim/lights_out.h"

namespace msspr::sim {

struct PuzzleEnvOptions : ArmEnvOptions {
  // Random pinch poses (episode starts, the play oracle's final poses): OGBench's puzzle box.
  PuzzleEnvOptions() {
    init_low = {0.25, -0.20, 0.20};
    init_high = {0.60, 0.20, 0.25};
  }
  int side = 3;                // 3 (puzzle-3x3) or 4 (puzzle-4x4)
  double press_depth = -0.02;  // m: a button is pressed when its joint crosses this
  int goal_random_steps = 5;   // random actions after posing a task's goal (gripper closed)
  int max_episode_steps = 500;
};

class PuzzleEnv : public ArmEnv {
 public:
  using Options = PuzzleEnvOptions;
  // Parses the URDF, generates and compiles the scene. Throws UrdfError for a bad URDF,
  // std::invalid_argument for a side other than 3 or 4 and std::runtime_error when MuJoCo
  // rejects the scene. Every button starts up and in state 0, the arm at home.
  explicit PuzzleEnv(const PuzzleEnvOptions& options);

  int num_buttons() const { return board_.size(); }
  int observation_size() const { return kProprioSize + 4 * num_buttons(); }
  const LightsOut& board() const { return board_; }

  // One control step (as CubeEnv::Step), then the presses seen in it applied by the
  // Lights Out rule. Returns Success() after it.
  bool Step(const Action& action);

  // Starts an evaluation episode of task `task` (1 to 5, PuzzleTasks(side)) from `seed`:
  // the goal observation is made by setting the goal board, a random arm pose and
  // goal_random_steps uniformly random actions with the gripper closing (+1); then the
  // state is restored, the arm re-randomised and the start board set exactly. Returns the
  // first observation; throws std::out_of_range for a bad task id.
  Observation ResetToTask(int task, uint64_t seed);
  // Starts a data-collection episode from `seed`: a random arm pose (gripper open), every
  // button state U{0, 1}. No goal observation (the play oracle picks its targets).
  Observation ResetForCollection(uint64_t seed);

  Observation GetObservation() const;
  // The goal observation of the current task episode (zeros before one).
  const Observation& goal_observation() const { return goal_observation_; }
  // With enable_rendering, the goal image of the current task episode; empty otherwise.
  const std::vector<uint8_t>& goal_image() const { return goal_image_; }

  const LightsOutState& button_states() const { return states_; }
  // Sets every state (size num_buttons(), values 0 or 1; std::invalid_argument otherwise)
  // and the caps' colours.
  void SetButtonStates(const LightsOutState& states);
  const LightsOutState& goal_states() const { return goal_states_; }
  void SetGoalStates(const LightsOutState& states);
  bool Success() const { return states_ == goal_states_; }
  // Presses seen since the last reset.
  int presses() const { return presses_; }

  // Button k's top centre (the site btntop_k; m) and joint position (m, 0 = up).
  Eigen::Vector3d ButtonTop(int k) const;
  double ButtonJoint(int k) const;

  int episode_steps() const { return episode_steps_; }
  bool EpisodeOver() const { return Success() || episode_steps_ >= options_.max_episode_steps; }
  const PuzzleEnvOptions& options() const { return options_; }

 private:
  void ApplyButtonColours();

  PuzzleEnvOptions options_;
  LightsOut board_;
  std::vector<int> button_qpos_, button_qvel_, button_site_, button_geom_;
  LightsOutState states_, goal_states_;
  Observation goal_observation_;
  std::vector<uint8_t> goal_image_;
  int episode_steps_ = 0, presses_ = 0;
};

// One push button's MJCF (OGBench's button part): the box buttonbox_k at (x, y, 0.048), the cap
// on the slide joint buttonbox_joint_k (geom btngeom_k) and the site btntop_k `top_site` m above
// the box origin.
std::string PushButtonMjcf(int k, double x, double y, double top_site);

// The state an observation's one-hot pair (a, b) of button k shows, as the puzzles and the
// scene write it: (1, 0) is 0, (0, 1) is 1; throws std::invalid_argument naming button k
// otherwise.
int ButtonStateFromOneHot(float a, float b, int k);

// The button MJCF of an R x R puzzle (bodies buttonbox_k with the slide joint
// buttonbox_joint_k, the cap geom btngeom_k and the site btntop_k), for ArmSceneMjcf.
std::string PuzzleButtonsMjcf(int side);

}  // namespace msspr::sim
