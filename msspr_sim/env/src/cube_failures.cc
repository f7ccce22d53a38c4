#include "msspr_sim/cube_failures.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "msspr_sim/cube_env.h"

namespace msspr::sim {
namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace

void CubeEpisodeTracker::Start(const float* obs, const float* goal_obs) {
  last_ = CubePositionFromObservation(obs);
  goal_ = CubePositionFromObservation(goal_obs);
  last_pinch_ = PinchPositionFromObservation(obs);
  goal_pinch_ = PinchPositionFromObservation(goal_obs);
  start_ = last_;
  start_z_ = last_.z();
  lift_ = 0;
}

void CubeEpisodeTracker::Observe(const float* obs) {
  last_ = CubePositionFromObservation(obs);
  last_pinch_ = PinchPositionFromObservation(obs);
  lift_ = std::max(lift_, last_.z() - start_z_);
}

CubeOutcome CubeEpisodeTracker::Finish(bool success) const {
  CubeOutcome o;
  o.success = success;
  o.lift = lift_;
  o.goal_distance = (last_ - goal_).norm();
  o.above_goal = last_.z() - goal_.z();
  o.gripper_to_goal_gripper = (last_pinch_ - goal_pinch_).norm();
  const Eigen::Vector2d way = (goal_ - start_).head<2>();
  if (way.norm() > 1e-6) o.along_start_to_goal = (last_ - goal_).head<2>().dot(way.normalized());
  return o;
}

CubeFailures CountCubeFailures(const std::vector<CubeOutcome>& outcomes) {
  CubeFailures f;
  std::vector<double> misses, across, above, gripper, along;
  for (const CubeOutcome& e : outcomes) {
    ++f.episodes;
    if (e.success) continue;
    ++f.failed;
    if (e.lift * 100.0 < CubeFailures::kLiftedCm) {
      ++f.never_lifted;
      continue;
    }
    ++f.lifted_not_placed;
    const double d = e.goal_distance, z = e.above_goal;
    misses.push_back(d * 100.0);
    above.push_back(z * 100.0);
    across.push_back(std::sqrt(std::max(0.0, d * d - z * z)) * 100.0);
    gripper.push_back(e.gripper_to_goal_gripper * 100.0);
    along.push_back(e.along_start_to_goal * 100.0);
  }
  f.median_miss_cm = Median(misses);
  f.median_across_cm = Median(across);
  f.median_above_cm = Median(above);
  f.median_gripper_cm = Median(gripper);
  f.median_along_cm = Median(along);
  return f;
}

std::string DescribeCubeFailures(const CubeFailures& f) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(1);  // centimetres to the millimetre
  s << "failures: " << f.failed << " of " << f.episodes << " episodes";
  if (f.failed == 0) return s.str();
  s << ": " << f.never_lifted << " never lifted the cube " << CubeFailures::kLiftedCm
    << " cm (no grasp), " << f.lifted_not_placed << " lifted it";
  if (f.lifted_not_placed > 0)
    s << " and ended a median " << f.median_miss_cm << " cm from the goal (" << f.median_across_cm
      << " cm across, " << f.median_above_cm << " cm above, " << std::abs(f.median_along_cm)
      << " cm " << (f.median_along_cm < 0 ? "short of" : "past")
      << " it on the way from its start; the gripper a median " << f.median_gripper_cm
      << " cm from the goal's)";
  return s.str();
}

}  // namespace msspr::sim
