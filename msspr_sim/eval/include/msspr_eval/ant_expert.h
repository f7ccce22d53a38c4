// The ant's locomotion expert: OGBench's online-ant-xy (msspr_sim/ant_xy_env.h)
// as an OnlineEnv for msspr_core's soft actor-critic (msspr_core/sac.h), the
// environment msspr_train_expert trains the direction-following expert in.
#pragma once

#include <memory>
#include <vector>

#include "msspr_core/sac.h"
#include "msspr_sim/ant_xy_env.h"

namespace msspr::agent {

class AntXyOnlineEnv : public core::OnlineEnv {
 public:
  explicit AntXyOnlineEnv(const sim::AntXyEnvOptions& options = {});
  int obs_dim() const override { return sim::AntXyEnv::kObsDim; }
  int action_dim() const override { return sim::AntXyEnv::kActionDim; }
  std::vector<float> Reset(uint64_t seed) override;
  StepResult Step(const std::vector<float>& action) override;
  sim::AntXyEnv& env() { return env_; }

 private:
  sim::AntXyEnv env_;
};

}  // namespace msspr::agent
