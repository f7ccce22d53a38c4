// The cube-single play oracle (sim::CubePlayOracle) as a goal-reaching client
// that sees only what goes over ROS: the 28-D observation and the goal
// observation. It keeps a mirror sim::CubeEnv, poses it from each
// observation (arm joints, opening, cube position and yaw, goal marker from
// the goal's cube) and asks the oracle for an action; when the oracle's plan
// is used up (the play oracle would then draw a random new target) a fresh
// oracle plans again toward the same goal. Issue 11.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "msspr_sim/cube_env.h"
#include "msspr_sim/cube_oracle.h"

namespace msspr::ros_bridge {

class CubeGoalOracle {
 public:
  // urdf_path: the arm simulated by the sim (its robot_description). The
  // oracle's noise is off by default (goal reaching, not play data).
  CubeGoalOracle(const std::string& urdf_path, uint64_t seed,
                 sim::CubePlayOracleOptions options = NoNoise());
  ~CubeGoalOracle();

  static sim::CubePlayOracleOptions NoNoise() {
    sim::CubePlayOracleOptions o;
    o.noise_scale = 0.0;
    return o;
  }

  // Starts a new episode (a fresh plan at the next Act).
  void Reset(uint64_t seed);
  // The action in [-1, 1] for observation `obs` toward goal observation `goal` (28 floats each).
  sim::CubeEnv::Action Act(const float* obs, const float* goal);
  // Play (data collection, no goal): the oracle's own cycles, as
  // msspr_collect's; the first target is drawn in the object box from the
  // episode's seed (the sim does not send its own), later ones by the oracle.
  sim::CubeEnv::Action ActPlay(const float* obs);
  int plans() const { return plans_; }

 private:
  void Pose(const float* obs, const float* goal);  // goal may be null: the mirror's own stays
  std::unique_ptr<sim::CubeEnv> mirror_;
  sim::CubePlayOracleOptions options_;
  std::unique_ptr<sim::CubePlayOracle> oracle_;
  uint64_t seed_ = 0;
  int plans_ = 0;
};

}  // namespace msspr::ros_bridge
