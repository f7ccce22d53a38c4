// Internal to msspr_core: what SAC's trainer (sac_trainer.cc) and the rest of SAC
// (sac.cc: the agent, the replay buffer, the exported policy) share.
#pragma once

#include <cstdint>
#include <string>

#include "msspr_core/sac.h"

namespace msspr::core::sac_internal {

constexpr char kSacCheckpointKind[] = "sac";
constexpr char kSacPolicyKind[] = "sac_policy";

// The YAML header of a SAC checkpoint or policy file.
struct SacHeader {
  SacOptions options;
  int64_t obs_dim = 0, action_dim = 0, step = 0, episode = 0, updates = 0;
  std::string rng;
};

std::string HeaderToYaml(const SacHeader& h);
// Throws CheckpointError naming `path` for a bad header.
SacHeader ParseHeader(const std::string& yaml, const std::string& path);

}  // namespace msspr::core::sac_internal
