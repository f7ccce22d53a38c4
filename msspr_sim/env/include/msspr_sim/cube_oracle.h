// OGBench's "play" oracle for cube-single data collection
// (ogbench/manipspace/oracles/plan/cube_plan.py, plan_oracle.py; facts in
// OGBench's manipspace oracle): at each cycle start an
// open-loop pick-and-place plan of keyframes, sampled every 0.05 s, plus
// smoothed Gaussian noise; each step's action drives the measured pinch
// pose and opening toward the plan's sample. Deterministic by seed.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <random>
#include <vector>

#include "msspr_sim/cube_env.h"

namespace msspr::sim {

// One plan sample: pinch x, y, z (m), yaw (rad), grip (0 open, 1 closed).
using CubePlanSample = Eigen::Matrix<double, 5, 1>;

struct CubePlayOracleOptions {
  double control_dt = 0.05;   // s per action
  double time_jitter = 0.08;  // s, U(-j, j) on every keyframe time but the first
  // Noise: N(0, 1) x action scale x noise_scale per sample, then smoothed.
  double noise_scale = 0.1;
  std::array<double, 5> action_scale{0.05, 0.05, 0.05, 0.3, 1.0};
};

// One plan sample: pinch x, y, z (m), yaw (rad), grip (0 open, 1 closed).
using CubePlanSample = Eigen::Matrix<double, 5, 1>;

// A keyframe of a plan: the time from the previous keyframe (s; 0 for the first), the pinch
// pose and the grip (0 open, 1 closed).
struct PlanKeyframe {
  double time;
  Eigen::Vector3d position;
  Eigen::Quaterniond rotation;
  double grip;
};

// OGBench's plan engine (plan_oracle.py): the keyframe times summed, every time but the
// first moved by its own U(-jitter, jitter), samples every options.control_dt while
// t < the last time (positions and grip linear in time, orientation along the SO(3)
// geodesic), plus Gaussian noise (action scale x noise_scale) smoothed along time. Draws
// from `rng` in that order: the jitters, then the noise.
std::vector<CubePlanSample> SamplePlan(std::vector<PlanKeyframe> keyframes, double jitter,
                                       const CubePlayOracleOptions& options, std::mt19937_64& rng);

// The action driving the measured pinch pose and opening toward plan sample `x`:
// (x - current) / action scale, clipped to [-1, 1]; the yaw difference is not wrapped
// (OGBench's).
std::array<double, 5> ActionTowardSample(const CubePlanSample& x, const Eigen::Vector3d& pinch,
                                         double pinch_yaw, double opening,
                                         const std::array<double, 5>& action_scale);

// What a pick-and-place plan starts from: the measured pinch pose, the cube's pose, the
// target's, and the box of the final random pose.
struct PickAndPlace {
  Eigen::Vector3d pinch;
  Eigen::Matrix3d pinch_rotation;
  double pinch_yaw = 0;
  Eigen::Vector3d cube;
  double cube_yaw = 0;
  Eigen::Vector3d target;
  double target_yaw = 0;
  Eigen::Vector3d final_low, final_high;
};

// What a pick-and-place plan of `env` (an arm env: its measured pinch, its start box for the
// final pose) starts from, the cube at `cube` (yaw `cube_yaw`), going to `target`.
template <class Env>
PickAndPlace PickAndPlaceFrom(const Env& env, const Eigen::Vector3d& cube, double cube_yaw,
                              const Eigen::Vector3d& target, double target_yaw) {
  PickAndPlace s;
  s.pinch = env.PinchPosition();
  s.pinch_rotation = env.PinchRotation();
  s.pinch_yaw = env.PinchYaw();
  s.cube = cube;
  s.cube_yaw = cube_yaw;
  s.target = target;
  s.target_yaw = target_yaw;
  s.final_low = env.options().init_low;
  s.final_high = env.options().init_high;
  return s;
}

// OGBench's cube plan (cube_plan.py): above the cube (0.1 + U(0, 0.1) m), down, close, up,
// a jittered clearance point, above the target, down, open, up, a random final pose; the
// pick and place yaws the cube's and the target's symmetric yaws nearest the effector's.
// Draws from `rng`: the pick height, the place height, the clearance jitter, the final pose,
// then SamplePlan's.
std::vector<CubePlanSample> PlanPickAndPlace(const PickAndPlace& scene,
                                             const CubePlayOracleOptions& options,
                                             std::mt19937_64& rng);

// SciPy's gaussian_filter1d with sigma 0.5 (5 taps, reflected edges:
// x[-1] = x[0], x[-2] = x[1]) along time, per column. [T, 5] -> [T, 5].
std::vector<CubePlanSample> SmoothPlanNoise(const std::vector<CubePlanSample>& noise);

// yaw wrapped into [0, 2 pi).
double YawIn0To2Pi(double yaw);

// The object's symmetric yaw (object_yaw + k pi/2, k = -4..4) nearest
// effector_yaw, with both yaws first taken in [0, 2 pi) as OGBench's
// plan oracle does (get_yaw, shortest_yaw): the result is always within
// pi/4 of the effector's yaw, modulo 2 pi.
double NearestSymmetricYaw(double object_yaw, double effector_yaw);

class CubePlayOracle {
 public:
  explicit CubePlayOracle(uint64_t seed, const CubePlayOracleOptions& options = {});

  // The action for env's current state, clipped to [-1, 1]. Plans a cycle
  // on the first call and whenever the current plan is used up; a used-up
  // plan also draws a new target (env.SetGoal) in the env's object box.
  CubeEnv::Action Act(CubeEnv& env);

  // The current plan (with noise), one sample per control step.
  const std::vector<CubePlanSample>& plan() const { return plan_; }
  // Cycles planned so far.
  int cycles() const { return cycles_; }

 private:
  void Plan(const CubeEnv& env);

  CubePlayOracleOptions options_;
  std::mt19937_64 rng_;
  std::vector<CubePlanSample> plan_;
  size_t step_ = 0;  // index into plan_ of the next action
  int cycles_ = 0;
};

}  // namespace msspr::sim
