// cube-double's scripted oracles and play episodes. Both act through OGBench's cube plan
// (PlanPickAndPlace of cube_oracle.h: its keyframes, jitter and smoothed noise).
// - CubeDoublePlayOracle makes the play data (OGBench's cube-double-play): the plan for the
//   env's target cube, then a new target (CubeDoubleEnv::SetNewTarget with this episode's
//   p_stack ~ U(0, 0.25)) and plan whenever a plan ends.
// - CubeDoubleTaskOracle solves an evaluation task: each plan moves one cube that is on top
//   and not at its goal to its goal, once that goal is free (and, for a stacked goal, the
//   cube below is at its own); when no cube can go (task 4's swap, a cube on the wrong one),
//   a cube on top is first parked at a free corner of the table.
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "msspr_sim/cube_dataset.h"
#include "msspr_sim/cube_double_env.h"
#include "msspr_sim/cube_oracle.h"

namespace msspr::sim {

class CubeDoublePlayOracle {
 public:
  explicit CubeDoublePlayOracle(uint64_t seed, const CubePlayOracleOptions& options = {});
  CubeDoubleEnv::Action Act(CubeDoubleEnv& env);
  double p_stack() const { return p_stack_; }
  int cycles() const { return cycles_; }

 private:
  CubePlayOracleOptions options_;
  std::mt19937_64 rng_;
  double p_stack_;
  std::vector<CubePlanSample> plan_;
  size_t step_ = 0;
  int cycles_ = 0;
};

class CubeDoubleTaskOracle {
 public:
  explicit CubeDoubleTaskOracle(uint64_t seed, const CubePlayOracleOptions& options = {});
  // The action toward env's goals; once both cubes are at their goals it holds still.
  CubeDoubleEnv::Action Act(const CubeDoubleEnv& env);
  // The cube of the current plan (-1: none) and where the plan takes it.
  int moving() const { return moving_; }
  const Eigen::Vector3d& destination() const { return destination_; }

 private:
  CubePlayOracleOptions options_;
  std::mt19937_64 rng_;
  std::vector<CubePlanSample> plan_;
  size_t step_ = 0;
  int moving_ = -1;
  Eigen::Vector3d destination_ = Eigen::Vector3d::Zero();
};

using CubeDoubleCollectOptions = PlayCollectOptions<CubePlayOracleOptions>;

// Episode `index` of cube-double-play: env.ResetForCollection(EpisodeSeed(seed, index)), the
// play oracle seeded from it; rows as cube-single's (37 floats). Replaying the stored
// actions from the same reset reproduces the rows. Throws std::invalid_argument if
// episode_length < 1 or images are asked of a non-rendering env.
PlayEpisode CollectCubeDoubleEpisode(CubeDoubleEnv& env, const CubeDoubleCollectOptions& options,
                                     uint64_t index);

}  // namespace msspr::sim
