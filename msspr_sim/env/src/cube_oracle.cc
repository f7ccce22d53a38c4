#include "msspr_sim/cube_oracle.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "msspr_sim/random_util.h"

namespace msspr::sim {
namespace {

double Yaw(const Eigen::Quaterniond& q) {
  return std::atan2(2 * (q.w() * q.z() + q.x() * q.y()), 1 - 2 * (q.y() * q.y() + q.z() * q.z()));
}

// Index under SciPy's "reflect" boundary (d c b a | a b c d | d c b a).
int Reflect(int i, int n) {
  const int period = 2 * n;
  i %= period;
  if (i < 0) i += period;
  return i < n ? i : period - 1 - i;
}

}  // namespace

double YawIn0To2Pi(double yaw) {
  double y = std::fmod(yaw, 2 * M_PI);
  if (y < 0) y += 2 * M_PI;
  return y;
}

double NearestSymmetricYaw(double object_yaw, double effector_yaw) {
  // Both taken in [0, 2 pi) first (OGBench's get_yaw); then the candidates
  // base + k pi/2 (k = -4..4) span [base - 2 pi, base + 2 pi], which holds a
  // symmetric yaw within pi/4 of any effector yaw in [0, 2 pi).
  const double base = YawIn0To2Pi(object_yaw), near = YawIn0To2Pi(effector_yaw);
  double best = base;
  for (int k = -4; k <= 4; ++k) {
    const double candidate = base + k * M_PI / 2;
    if (std::abs(candidate - near) < std::abs(best - near)) best = candidate;
  }
  return best;
}

std::vector<CubePlanSample> SmoothPlanNoise(const std::vector<CubePlanSample>& noise) {
  // gaussian_filter1d(sigma = 0.5, truncate = 4): radius 2.
  double w[5];
  double sum = 0;
  for (int k = -2; k <= 2; ++k) sum += w[k + 2] = std::exp(-0.5 * k * k / 0.25);
  for (double& x : w) x /= sum;
  const int n = static_cast<int>(noise.size());
  std::vector<CubePlanSample> out(noise.size(), CubePlanSample::Zero());
  for (int t = 0; t < n; ++t)
    for (int k = -2; k <= 2; ++k) out[t] += w[k + 2] * noise[Reflect(t + k, n)];
  return out;
}

std::vector<CubePlanSample> SamplePlan(std::vector<PlanKeyframe> k, double jitter,
                                       const CubePlayOracleOptions& options, std::mt19937_64& rng) {
  // Increments to times, then an independent jitter per keyframe but the first.
  for (size_t i = 1; i < k.size(); ++i) k[i].time += k[i - 1].time;
  for (size_t i = 1; i < k.size(); ++i) k[i].time += Uniform(rng, -jitter, jitter);

  // Samples every control_dt while t < t_end: positions and grip linear in
  // time, orientation along the SO(3) geodesic.
  std::vector<CubePlanSample> plan;
  size_t seg = 0;
  for (int s = 0;; ++s) {
    const double t = s * options.control_dt;
    if (!(t < k.back().time)) break;
    while (seg + 2 < k.size() && t >= k[seg + 1].time) ++seg;
    const PlanKeyframe &a = k[seg], &b = k[seg + 1];
    const double alpha = std::clamp((t - a.time) / (b.time - a.time), 0.0, 1.0);
    CubePlanSample x;
    x.head<3>() = a.position + alpha * (b.position - a.position);
    x[3] = Yaw(a.rotation.slerp(alpha, b.rotation));
    x[4] = a.grip + alpha * (b.grip - a.grip);
    plan.push_back(x);
  }
  std::vector<CubePlanSample> noise(plan.size());
  for (auto& n : noise)
    for (int i = 0; i < 5; ++i)
      n[i] = StandardNormal(rng) * options.action_scale[i] * options.noise_scale;
  const std::vector<CubePlanSample> smooth = SmoothPlanNoise(noise);
  for (size_t s = 0; s < plan.size(); ++s) plan[s] += smooth[s];
  return plan;
}

std::array<double, 5> ActionTowardSample(const CubePlanSample& x, const Eigen::Vector3d& p,
                                         double pinch_yaw, double opening,
                                         const std::array<double, 5>& scale) {
  const double current[5] = {p.x(), p.y(), p.z(), pinch_yaw, opening};
  std::array<double, 5> a;
  // The yaw difference is not wrapped (OGBench's).
  for (int i = 0; i < 5; ++i) a[i] = std::clamp((x[i] - current[i]) / scale[i], -1.0, 1.0);
  return a;
}

CubePlayOracle::CubePlayOracle(uint64_t seed, const CubePlayOracleOptions& options)
    : options_(options), rng_(Mix64(seed)) {}

std::vector<CubePlanSample> PlanPickAndPlace(const PickAndPlace& s,
                                             const CubePlayOracleOptions& options,
                                             std::mt19937_64& rng) {
  const auto u = [&](double lo, double hi) { return Uniform(rng, lo, hi); };
  std::vector<PlanKeyframe> k;
  // initial: the measured pinch pose, gripper open.
  const Eigen::Vector3d p0 = s.pinch;
  const Eigen::Quaterniond q0(s.pinch_rotation);
  k.push_back({0.0, p0, q0, 0.0});
  // pick: above the cube, at the cube's symmetric yaw nearest the current
  // yaw (both taken in [0, 2 pi), as OGBench's get_yaw does).
  const double pick_yaw = NearestSymmetricYaw(s.cube_yaw, s.pinch_yaw);
  const Eigen::Vector3d cube = s.cube;
  const Eigen::Vector3d above_cube = cube + Eigen::Vector3d(0, 0, 0.1 + u(0, 0.1));
  const Eigen::Quaterniond pick_rot = PinchDown(pick_yaw);
  k.push_back({0.4, above_cube, pick_rot, 0.0});
  k.push_back({0.6, cube, pick_rot, 0.0});        // pick_start
  k.push_back({0.4, cube, pick_rot, 1.0});        // pick_end: closes in between
  k.push_back({0.4, above_cube, pick_rot, 1.0});  // postpick
  // place: above the target, at its symmetric yaw nearest postpick's (the
  // pick yaw read back from its rotation, so in [0, 2 pi) too).
  const Eigen::Vector3d target = s.target;
  const Eigen::Vector3d above_target = target + Eigen::Vector3d(0, 0, 0.1 + u(0, 0.1));
  const Eigen::Quaterniond place_rot = PinchDown(NearestSymmetricYaw(s.target_yaw, pick_yaw));
  // clearance: the SE(3) midpoint of postpick and place, at the initial
  // height, jittered (its draws come after place's, as its pose needs place).
  Eigen::Vector3d clearance = (above_cube + above_target) / 2;
  clearance.z() = p0.z();
  clearance += Eigen::Vector3d(u(-0.1, 0.1), u(-0.1, 0.1), u(0, 0.2));
  k.push_back({0.4, clearance, pick_rot.slerp(0.5, place_rot), 1.0});
  k.push_back({0.4, above_target, place_rot, 1.0});
  k.push_back({0.6, target, place_rot, 1.0});        // place_start
  k.push_back({0.4, target, place_rot, 0.0});        // place_end: opens in between
  k.push_back({0.4, above_target, place_rot, 0.0});  // postplace
  // final: a random pose in the start box.
  Eigen::Vector3d final_p;
  for (int i = 0; i < 3; ++i) final_p[i] = u(s.final_low[i], s.final_high[i]);
  k.push_back({0.4, final_p, PinchDown(u(-M_PI, M_PI)), 0.0});
  return SamplePlan(std::move(k), options.time_jitter, options, rng);
}

void CubePlayOracle::Plan(const CubeEnv& env) {
  plan_ = PlanPickAndPlace(
      PickAndPlaceFrom(env, env.CubePosition(), env.CubeYaw(), env.GoalPosition(), env.GoalYaw()),
      options_, rng_);
  step_ = 0;
  ++cycles_;
}

CubeEnv::Action CubePlayOracle::Act(CubeEnv& env) {
  if (plan_.empty()) {
    Plan(env);
  } else if (step_ >= plan_.size()) {
    // Cycle over: a new target in the object box, and a plan from here.
    const CubeEnvOptions& eo = env.options();
    const Eigen::Vector3d target(Uniform(rng_, eo.object_low.x(), eo.object_high.x()),
                                 Uniform(rng_, eo.object_low.y(), eo.object_high.y()), 0.02);
    env.SetGoal(target, Uniform(rng_, 0.0, 2 * M_PI));
    Plan(env);
  }
  return ActionTowardSample(plan_[step_++], env.PinchPosition(), env.PinchYaw(), env.Opening(),
                            options_.action_scale);
}

}  // namespace msspr::sim
