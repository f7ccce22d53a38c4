#include "msspr_sim/scene_oracle.h"

#include <cmath>
#include <stdexcept>
#include <utility>

#include "msspr_sim/cube_env.h"  // PinchDownRotation
#include "msspr_sim/expert.h"    // EpisodeSeed
#include "msspr_sim/random_util.h"
#include "play_recording.h"

namespace msspr::sim {
namespace {

// handle_yaw + k pi (k = -2..2) nearest the effector's yaw taken in [0, 2 pi) (OGBench's).
double NearestHalfTurnYaw(double handle_yaw, double effector_yaw) {
  const double near = YawIn0To2Pi(effector_yaw);
  double best = handle_yaw;
  for (int k = -2; k <= 2; ++k) {
    const double c = handle_yaw + k * M_PI;
    if (std::abs(c - near) < std::abs(best - near)) best = c;
  }
  return best;
}

constexpr double kDrawerYaw = 3.14, kWindowYaw = 1.57;  // the handle sites' yaws (OGBench's)
const Eigen::Vector3d kDrawerAxis(-0.0016, -1, 0);      // the handle's motion per metre of slide

// The cube's pick-and-place plan to `target` (yaw `target_yaw`) from env's state.
std::vector<CubePlanSample> PlanCube(const SceneEnv& env, const Eigen::Vector3d& target,
                                     double target_yaw, const CubePlayOracleOptions& options,
                                     std::mt19937_64& rng) {
  return PlanPickAndPlace(
      PickAndPlaceFrom(env, env.CubePosition(), env.CubeYaw(), target, target_yaw), options, rng);
}

// The handle plans that slide the drawer or the window to `goal` (m).
std::vector<CubePlanSample> PlanDrawer(const SceneEnv& env, double goal,
                                       const CubePlayOracleOptions& options, std::mt19937_64& rng) {
  const Eigen::Vector3d handle = env.DrawerHandle();
  return PlanHandleMove(env, handle, kDrawerYaw, handle + (goal - env.Drawer()) * kDrawerAxis, 0.12,
                        options, rng);
}
std::vector<CubePlanSample> PlanWindow(const SceneEnv& env, double goal,
                                       const CubePlayOracleOptions& options, std::mt19937_64& rng) {
  const Eigen::Vector3d handle = env.WindowHandle();
  return PlanHandleMove(env, handle, kWindowYaw,
                        handle + Eigen::Vector3d(goal - env.Window(), 0, 0), 0.06, options, rng);
}

SceneEnv::Action Toward(const SceneEnv& env, const CubePlanSample& x,
                        const CubePlayOracleOptions& options) {
  return ActionTowardSample(x, env.PinchPosition(), env.PinchYaw(), env.Opening(),
                            options.action_scale);
}

// Whether a row's cube (obs 19-21: 10 (centre - c)) leaves OGBench's health bounds.
bool Unhealthy(const float* obs) {
  const double y = obs[20] / 10.0, z = obs[21] / 10.0;
  return y >= 0.29 || (y <= -0.30 && (z < 0.06 || z > 0.08));
}

}  // namespace

std::vector<CubePlanSample> PlanHandleMove(const ArmEnv& env, const Eigen::Vector3d& handle,
                                           double handle_yaw, const Eigen::Vector3d& target,
                                           double above, const CubePlayOracleOptions& options,
                                           std::mt19937_64& rng) {
  const ArmEnvOptions& eo = env.arm_options();
  const Eigen::Quaterniond rot = PinchDown(NearestHalfTurnYaw(handle_yaw, env.PinchYaw()));
  const Eigen::Vector3d up(0, 0, above);
  std::vector<PlanKeyframe> kf;
  kf.push_back({0.0, env.PinchPosition(), Eigen::Quaterniond(env.PinchRotation()), 0.0});
  kf.push_back({0.4, handle + up, rot, 0.0});  // approach
  kf.push_back({0.2, handle, rot, 0.0});       // grasp_start
  kf.push_back({0.2, handle, rot, 1.0});       // grasp_end
  kf.push_back({0.2, target, rot, 1.0});       // move
  kf.push_back({0.2, target, rot, 0.0});       // release
  kf.push_back({0.2, target + up, rot, 0.0});  // clearance
  Eigen::Vector3d final_p;
  for (int i = 0; i < 3; ++i) final_p[i] = Uniform(rng, eo.init_low[i], eo.init_high[i]);
  kf.push_back({0.4, final_p, PinchDown(Uniform(rng, -M_PI, M_PI)), 0.0});
  return SamplePlan(std::move(kf), options.time_jitter, options, rng);
}

ScenePlayOracle::ScenePlayOracle(uint64_t seed, const SceneOracleOptions& options)
    : options_(options), rng_(Mix64(seed)) {}

SceneEnv::Action ScenePlayOracle::Act(SceneEnv& env) {
  if (step_ >= plan_.size()) {
    const double w[4] = {env.CubeInDrawer() ? 0.0 : 1.0, 1.0, env.DrawerLocked() ? 0.25 : 1.0,
                         env.WindowLocked() ? 0.25 : 1.0};
    double u = Uniform01(rng_) * (w[0] + w[1] + w[2] + w[3]);
    int pick = 0;
    while (pick < 3 && u >= w[pick]) u -= w[pick++];
    subtask_ = static_cast<Subtask>(pick);
    const SceneEnvOptions& eo = env.options();
    switch (subtask_) {
      case Subtask::kCube: {
        Eigen::Vector3d target;
        if (env.Drawer() < -0.12 && Uniform01(rng_) < 0.3) {
          target = Eigen::Vector3d(0.33 + Uniform(rng_, -0.005, 0.005),
                                   -0.24 + Uniform(rng_, -0.005, 0.005), 0.066);
        } else {
          target = Eigen::Vector3d(Uniform(rng_, eo.object_low.x(), eo.object_high.x()),
                                   Uniform(rng_, eo.object_low.y(), eo.object_high.y()), 0.02);
        }
        const double yaw = Uniform(rng_, 0.0, 2 * M_PI);
        env.SetCubeTarget(target, yaw);
        plan_ = PlanCube(env, target, yaw, options_.cube, rng_);
        break;
      }
      case Subtask::kButton:
        plan_ = PlanButtonPress(env, env.ButtonTop(static_cast<int>(UniformIndex(rng_, 2))), 0.0,
                                options_.button, rng_);
        break;
      case Subtask::kDrawer:
        plan_ = PlanDrawer(env, env.Drawer() >= -0.08 ? SceneEnv::kDrawerOpen : 0.0,
                           options_.handle, rng_);
        break;
      case Subtask::kWindow:
        plan_ = PlanWindow(env, env.Window() <= 0.1 ? SceneEnv::kWindowOpen : 0.0, options_.handle,
                           rng_);
        break;
    }
    step_ = 0;
    ++cycles_;
  }
  return Toward(env, plan_[step_++], options_.cube);
}

SceneTaskOracle::SceneTaskOracle(uint64_t seed, const SceneOracleOptions& options)
    : options_(options), rng_(Mix64(seed)) {}

SceneTaskOracle::Step SceneTaskOracle::NextStep(const SceneEnv& env) const {
  const SceneState& goal = env.goal_state();
  const bool cube_placed = (env.CubePosition() - goal.cube).norm() <= kPlaced;
  const bool drawer_open = env.Drawer() < kDrawerOpenEnough;
  const bool cube_goal_in_drawer = goal.cube.y() < kInDrawerY;
  // The drawer to `target`, unlocking it first.
  const auto drawer_to = [&](double target) {
    return env.DrawerLocked() ? Step{Subtask::kButton, 0, 0.0} : Step{Subtask::kDrawer, -1, target};
  };
  if (!cube_placed) {
    if (cube_goal_in_drawer && !env.CubeInDrawer())
      return drawer_open ? Step{Subtask::kCube, -1, 0.0} : drawer_to(SceneEnv::kDrawerOpen);
    if (!cube_goal_in_drawer)
      return env.CubeInDrawer() && !drawer_open ? drawer_to(SceneEnv::kDrawerOpen)
                                                : Step{Subtask::kCube, -1, 0.0};
    // In the tray: closing the drawer brings it to the goal (below).
  }
  if (std::abs(env.Drawer() - goal.drawer) > kPlaced) return drawer_to(goal.drawer);
  if (std::abs(env.Window() - goal.window) > kPlaced)
    return env.WindowLocked() ? Step{Subtask::kButton, 1, 0.0}
                              : Step{Subtask::kWindow, -1, goal.window};
  for (int k = 0; k < 2; ++k)
    if (env.button_states()[static_cast<size_t>(k)] != goal.buttons[static_cast<size_t>(k)])
      return Step{Subtask::kButton, k, 0.0};
  return Step{Subtask::kNone, -1, 0.0};
}

SceneEnv::Action SceneTaskOracle::Act(const SceneEnv& env) {
  if (step_ >= plan_.size()) {
    plan_.clear();
    step_ = 0;
    current_ = NextStep(env);
    switch (current_.subtask) {
      case Subtask::kNone:
        break;
      case Subtask::kCube: {
        const SceneState& goal = env.goal_state();
        const Eigen::Vector3d target =
            goal.cube.y() < kInDrawerY
                ? Eigen::Vector3d(kTrayX, env.DrawerHandle().y() + kTrayFromHandle, kTrayZ)
                : goal.cube;
        plan_ = PlanCube(env, target, 0.0, options_.cube, rng_);
        break;
      }
      case Subtask::kButton:
        plan_ = PlanButtonPress(env, env.ButtonTop(current_.button), 0.0, options_.button, rng_);
        break;
      case Subtask::kDrawer:
        plan_ = PlanDrawer(env, current_.target, options_.handle, rng_);
        break;
      case Subtask::kWindow:
        plan_ = PlanWindow(env, current_.target, options_.handle, rng_);
        break;
    }
  }
  if (plan_.empty()) return SceneEnv::Action{0, 0, 0, 0, -1};  // hold, gripper open
  return Toward(env, plan_[step_++], options_.cube);
}

PlayEpisode CollectSceneEpisode(SceneEnv& env, const SceneCollectOptions& options, uint64_t index) {
  if (options.episode_length < 1)
    throw std::invalid_argument("CollectSceneEpisode: episode_length must be >= 1");
  if (options.images && !env.options().enable_rendering)
    throw std::invalid_argument("CollectSceneEpisode: images need an env with enable_rendering");
  const uint64_t first = EpisodeSeed(options.seed, index);
  for (uint64_t attempt = 0; attempt < 20; ++attempt) {
    PlayEpisode ep;
    ep.index = index;
    ep.seed = attempt == 0 ? first : Mix64(first + attempt);
    ep.length = options.episode_length;
    env.ResetForCollection(ep.seed);
    ScenePlayOracle oracle(Mix64(ep.seed ^ internal::kOracleSalt), options.oracle);
    internal::RecordPlayEpisode(env, oracle, options.images, &ep);
    bool healthy = true;
    for (int t = 0; t < ep.length && healthy; ++t)
      healthy =
          !Unhealthy(ep.observations.data() + static_cast<size_t>(t) * SceneEnv::kObservationSize);
    if (healthy) return ep;
  }
  throw std::runtime_error("CollectSceneEpisode: episode " + std::to_string(index) +
                           " left the table's sight in 20 attempts");
}

}  // namespace msspr::sim
