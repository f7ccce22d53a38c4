// The puzzles' scripted oracles, on OGBench's button plan (ogbench/manipspace/oracles/plan/
// button_plan.py): from the measured pinch pose, 0.06 m above the button's top, down to
// 0.035 m below it (OGBench's plan says 0.025, see PuzzleOracleOptions::depth), back up, then a
// random pose in the env's start box; the gripper closed throughout. Keyframe times as OGBench's:
// 0.4 (0.5 + 4 d) s to the first (d: the distance to it, m), then 0.32, 0.32 and 0.5 s, each but
// the first jittered by U(-0.04, 0.04) s; smoothed noise and actions as the cube's play oracle
// (cube_oracle.h). The press yaw is the button top's x coordinate (in rad), a slip of OGBench's
// that its data carries and this copies.
//
// PuzzlePlayOracle makes the play data: a new target button, uniform over the board,
// whenever a plan ends. PuzzleTaskOracle solves an evaluation task: each plan presses the
// first button of the fewest presses from the current board to the goal (LightsOut::Solve,
// recomputed at every plan, so a stray press is repaired).
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "msspr_sim/cube_oracle.h"
#include "msspr_sim/puzzle_env.h"

namespace msspr::sim {

struct PuzzleOracleOptions {
  CubePlayOracleOptions plan{0.05, 0.04, 0.1, {0.05, 0.05, 0.05, 0.3, 1.0}};
  double hover = 0.06;  // m above the button top
  // m below it. OGBench's plan goes 0.025 m down; on this arm the servos lag the 0.32 s
  // press segment so that only 38 of 61 such presses (no noise) pushed the button past
  // -0.02 m, against 61 of 61 at 0.035 m (tests/sim/puzzle_env_test.cc checks the rate).
  double depth = 0.035;
};

// The plan that presses the button whose top is `top` from env's current pinch pose; `grip`
// is the gripper's target at the start and the end (the puzzles: 1, closed throughout; the
// scene: 0, closing on the way down); the final pose is random in env's start box.
std::vector<CubePlanSample> PlanButtonPress(const ArmEnv& env, const Eigen::Vector3d& top,
                                            double grip, const PuzzleOracleOptions& options,
                                            std::mt19937_64& rng);

class PuzzlePlayOracle {
 public:
  explicit PuzzlePlayOracle(uint64_t seed, const PuzzleOracleOptions& options = {});
  // The action for env's current state, clipped to [-1, 1]; plans the press of a random
  // button on the first call and whenever the plan is used up.
  PuzzleEnv::Action Act(const PuzzleEnv& env);
  int target() const { return target_; }
  int cycles() const { return cycles_; }

 private:
  PuzzleOracleOptions options_;
  std::mt19937_64 rng_;
  std::vector<CubePlanSample> plan_;
  size_t step_ = 0;
  int target_ = -1, cycles_ = 0;
};

class PuzzleTaskOracle {
 public:
  explicit PuzzleTaskOracle(uint64_t seed, const PuzzleOracleOptions& options = {});
  // The action for env's current state toward env.goal_states(); once the board is solved,
  // or when no press set solves it, it holds the pinch where it is.
  PuzzleEnv::Action Act(const PuzzleEnv& env);
  int target() const { return target_; }

 private:
  PuzzleOracleOptions options_;
  std::mt19937_64 rng_;
  std::vector<CubePlanSample> plan_;
  size_t step_ = 0;
  int target_ = -1;
};

}  // namespace msspr::sim
