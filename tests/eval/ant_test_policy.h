// A tiny untrained locomotion expert for the ant tests: a SacTrainer in
// online-ant-xy (16-wide networks) writes its actor, DIR/sac_policy.pt, at
// step 0. Shared by tests/eval and tests/ros (no ROS here).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "msspr_core/sac.h"
#include "msspr_eval/ant_expert.h"

namespace msspr::testing_util {

// Writes dir/sac_policy.pt (29 inputs, 8 actions); returns its path.
inline std::string WriteTinyAntExpert(const std::string& dir, uint64_t seed = 0) {
  core::SacOptions o;
  o.hidden = 16;
  o.batch_size = 8;
  o.buffer_size = 64;
  o.steps = 16;
  o.random_steps = 16;
  o.checkpoint_every = 0;
  o.seed = seed;
  core::SacTrainer trainer(
      o, [] { return std::make_unique<agent::AntXyOnlineEnv>(); }, dir);
  trainer.SaveCheckpoint();
  return trainer.policy_path();
}

}  // namespace msspr::testing_util
