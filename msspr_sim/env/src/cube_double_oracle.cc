#include "msspr_sim/cube_double_oracle.h"

#include <array>
#include <stdexcept>

#include "msspr_sim/expert.h"  // EpisodeSeed
#include "msspr_sim/random_util.h"
#include "play_recording.h"

namespace msspr::sim {
namespace {

// The pick-and-place plan of cube i to `target` (yaw `target_yaw`) from env's state.
std::vector<CubePlanSample> PlanCube(const CubeDoubleEnv& env, int i, const Eigen::Vector3d& target,
                                     double target_yaw, const CubePlayOracleOptions& options,
                                     std::mt19937_64& rng) {
  return PlanPickAndPlace(
      PickAndPlaceFrom(env, env.CubePosition(i), env.CubeYaw(i), target, target_yaw), options, rng);
}

CubeDoubleEnv::Action Toward(const CubeDoubleEnv& env, const CubePlanSample& x,
                             const CubePlayOracleOptions& options) {
  return ActionTowardSample(x, env.PinchPosition(), env.PinchYaw(), env.Opening(),
                            options.action_scale);
}

// A cube's goal counts as reached well inside the success distance, so that a cube the plan
// drops a little off is not left at the edge of success.
constexpr double kPlaced = 0.02;

}  // namespace

CubeDoublePlayOracle::CubeDoublePlayOracle(uint64_t seed, const CubePlayOracleOptions& options)
    : options_(options), rng_(Mix64(seed)), p_stack_(Uniform(rng_, 0.0, 0.25)) {}

CubeDoubleEnv::Action CubeDoublePlayOracle::Act(CubeDoubleEnv& env) {
  if (step_ >= plan_.size()) {
    // The env's current target first (ResetForCollection drew it), then a new one per plan.
    const int target = plan_.empty() && env.target_cube() >= 0 ? env.target_cube()
                                                               : env.SetNewTarget(rng_, p_stack_);
    plan_ = PlanCube(env, target, env.GoalPosition(target), env.GoalYaw(target), options_, rng_);
    step_ = 0;
    ++cycles_;
  }
  return Toward(env, plan_[step_++], options_);
}

CubeDoubleTaskOracle::CubeDoubleTaskOracle(uint64_t seed, const CubePlayOracleOptions& options)
    : options_(options), rng_(Mix64(seed)) {}

CubeDoubleEnv::Action CubeDoubleTaskOracle::Act(const CubeDoubleEnv& env) {
  if (step_ >= plan_.size()) {
    plan_.clear();
    step_ = 0;
    moving_ = -1;
    const auto placed = [&](int i) {
      return (env.CubePosition(i) - env.GoalPosition(i)).norm() <= kPlaced;
    };
    // Goal i is ready: no other cube on it, and a stacked goal has its cube below in place.
    const auto ready = [&](int i) {
      const int j = 1 - i;
      const Eigen::Vector3d g = env.GoalPosition(i);
      if (g.z() > 0.04) return placed(j);
      return (env.CubePosition(j) - g).head<2>().norm() > 0.045;
    };
    for (int i = 0; i < CubeDoubleEnv::kCubes && moving_ < 0; ++i)
      if (!placed(i) && env.IsTop(i) && ready(i)) {
        moving_ = i;
        destination_ = env.GoalPosition(i);
      }
    if (moving_ < 0 && !(placed(0) && placed(1))) {
      // Park a cube on top that is not placed (or sits where the other must go).
      for (int i = 0; i < CubeDoubleEnv::kCubes && moving_ < 0; ++i)
        if (env.IsTop(i) && (!placed(i) || !ready(1 - i))) moving_ = i;
      const std::array<Eigen::Vector3d, 4> corners = {
          Eigen::Vector3d(0.33, 0.27, 0.02), Eigen::Vector3d(0.52, 0.27, 0.02),
          Eigen::Vector3d(0.33, -0.27, 0.02), Eigen::Vector3d(0.52, -0.27, 0.02)};
      for (const Eigen::Vector3d& c : corners) {
        bool free = true;
        for (int j = 0; j < CubeDoubleEnv::kCubes; ++j)
          free = free && (env.GoalPosition(j) - c).head<2>().norm() > 0.08 &&
                 (j == moving_ || (env.CubePosition(j) - c).head<2>().norm() > 0.08);
        if (free) {
          destination_ = c;
          break;
        }
      }
    }
    if (moving_ >= 0) plan_ = PlanCube(env, moving_, destination_, 0.0, options_, rng_);
  }
  if (plan_.empty()) return CubeDoubleEnv::Action{0, 0, 0, 0, -1};  // hold, gripper open
  return Toward(env, plan_[step_++], options_);
}

PlayEpisode CollectCubeDoubleEpisode(CubeDoubleEnv& env, const CubeDoubleCollectOptions& options,
                                     uint64_t index) {
  if (options.episode_length < 1)
    throw std::invalid_argument("CollectCubeDoubleEpisode: episode_length must be >= 1");
  if (options.images && !env.options().enable_rendering)
    throw std::invalid_argument(
        "CollectCubeDoubleEpisode: images need an env with enable_rendering");
  PlayEpisode ep;
  ep.index = index;
  ep.seed = EpisodeSeed(options.seed, index);
  ep.length = options.episode_length;
  env.ResetForCollection(ep.seed);
  CubeDoublePlayOracle oracle(Mix64(ep.seed ^ internal::kOracleSalt), options.oracle);
  internal::RecordPlayEpisode(env, oracle, options.images, &ep);
  return ep;
}

}  // namespace msspr::sim
