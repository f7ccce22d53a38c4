#include "msspr_sim/puzzle_oracle.h"

#include <cmath>
#include <utility>

#include "msspr_sim/cube_env.h"  // PinchDownRotation
#include "msspr_sim/random_util.h"

namespace msspr::sim {
namespace {

PuzzleEnv::Action Toward(const PuzzleEnv& env, const CubePlanSample& x,
                         const PuzzleOracleOptions& options) {
  return ActionTowardSample(x, env.PinchPosition(), env.PinchYaw(), env.Opening(),
                            options.plan.action_scale);
}

}  // namespace

std::vector<CubePlanSample> PlanButtonPress(const ArmEnv& env, const Eigen::Vector3d& top,
                                            double grip, const PuzzleOracleOptions& options,
                                            std::mt19937_64& rng) {
  const ArmEnvOptions& eo = env.arm_options();
  const Eigen::Vector3d p0 = env.PinchPosition();
  const Eigen::Quaterniond press_rot = PinchDown(top.x());  // OGBench's yaw slip
  const Eigen::Vector3d above = top + Eigen::Vector3d(0, 0, options.hover);
  const Eigen::Vector3d below = top - Eigen::Vector3d(0, 0, options.depth);
  const double d = (above - p0).norm();
  std::vector<PlanKeyframe> kf;
  kf.push_back({0.0, p0, Eigen::Quaterniond(env.PinchRotation()), grip});
  kf.push_back({0.4 * (0.5 + 4 * d), above, press_rot, 1.0});  // press_start
  kf.push_back({0.32, below, press_rot, 1.0});                 // press
  kf.push_back({0.32, above, press_rot, 1.0});                 // press_end
  Eigen::Vector3d final_p;
  for (int i = 0; i < 3; ++i) final_p[i] = Uniform(rng, eo.init_low[i], eo.init_high[i]);
  kf.push_back({0.5, final_p, PinchDown(Uniform(rng, -M_PI, M_PI)), grip});
  return SamplePlan(std::move(kf), options.plan.time_jitter, options.plan, rng);
}

PuzzlePlayOracle::PuzzlePlayOracle(uint64_t seed, const PuzzleOracleOptions& options)
    : options_(options), rng_(Mix64(seed)) {}

PuzzleEnv::Action PuzzlePlayOracle::Act(const PuzzleEnv& env) {
  if (step_ >= plan_.size()) {
    target_ = static_cast<int>(UniformIndex(rng_, static_cast<size_t>(env.num_buttons())));
    plan_ = PlanButtonPress(env, env.ButtonTop(target_), 1.0, options_, rng_);
    step_ = 0;
    ++cycles_;
  }
  return Toward(env, plan_[step_++], options_);
}

PuzzleTaskOracle::PuzzleTaskOracle(uint64_t seed, const PuzzleOracleOptions& options)
    : options_(options), rng_(Mix64(seed)) {}

PuzzleEnv::Action PuzzleTaskOracle::Act(const PuzzleEnv& env) {
  if (step_ >= plan_.size()) {
    plan_.clear();
    step_ = 0;
    target_ = -1;
    const auto presses = env.board().Solve(env.button_states(), env.goal_states());
    if (presses && !presses->empty()) {
      target_ = presses->front();
      plan_ = PlanButtonPress(env, env.ButtonTop(target_), 1.0, options_, rng_);
    }
  }
  if (plan_.empty()) return PuzzleEnv::Action{0, 0, 0, 0, 1};  // hold, gripper closed
  return Toward(env, plan_[step_++], options_);
}

}  // namespace msspr::sim
