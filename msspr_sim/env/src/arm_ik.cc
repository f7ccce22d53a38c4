#include "msspr_sim/arm_ik.h"

#include <Eigen/Cholesky>
#include <cmath>
#include <stdexcept>

namespace msspr::sim {

Eigen::Matrix<double, 6, 1> PoseError(const Eigen::Isometry3d& target,
                                      const Eigen::Isometry3d& current) {
  Eigen::Matrix<double, 6, 1> e;
  e.head<3>() = target.translation() - current.translation();
  const Eigen::Quaterniond dq(target.linear() * current.linear().transpose());
  // mju_quat2Vel: angle 2 atan2(|v|, w), wrapped to (-pi, pi].
  const double s = dq.vec().norm();
  if (s < 1e-14) {
    e.tail<3>().setZero();
  } else {
    double angle = 2 * std::atan2(s, dq.w());
    if (angle > M_PI) angle -= 2 * M_PI;
    e.tail<3>() = dq.vec() / s * angle;
  }
  return e;
}

ArmIk::ArmIk(const ArmModel& arm, const ArmIkOptions& options) : arm_(arm), options_(options) {
  if (options.max_iterations < 0 || !(options.max_step > 0) || !(options.damping >= 0))
    throw std::invalid_argument(
        "ArmIkOptions: need max_iterations >= 0, max_step > 0, damping >= 0");
}

Eigen::Matrix<double, 6, Eigen::Dynamic> ArmIk::Jacobian(int link, const Eigen::VectorXd& q) const {
  const auto& joints = arm_.arm_joint_links();
  const std::vector<Eigen::Isometry3d> poses = arm_.LinkPoses(q);
  const Eigen::Vector3d p = poses[link].translation();
  Eigen::Matrix<double, 6, Eigen::Dynamic> j =
      Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, joints.size());
  // Only joints that are ancestors of `link` move it.
  std::vector<bool> ancestor(arm_.links().size(), false);
  for (int l = link; l >= 0; l = arm_.links()[l].parent) ancestor[l] = true;
  for (size_t i = 0; i < joints.size(); ++i) {
    const int l = joints[i];
    if (!ancestor[l]) continue;
    // A revolute joint's axis passes through its child link's origin (the
    // joint frame; the motion is a pure rotation there).
    const Eigen::Vector3d axis = poses[l].linear() * arm_.links()[l].axis;
    j.block<3, 1>(0, i) = axis.cross(p - poses[l].translation());
    j.block<3, 1>(3, i) = axis;
  }
  return j;
}

ArmIkResult ArmIk::Solve(const Eigen::Isometry3d& target, int link,
                         const Eigen::VectorXd& q0) const {
  const int n = static_cast<int>(arm_.arm_joint_links().size());
  const Eigen::VectorXd lo = arm_.LowerLimits().head(n), hi = arm_.UpperLimits().head(n);
  ArmIkResult r;
  r.q = q0;
  for (;; ++r.iterations) {
    const Eigen::Matrix<double, 6, 1> e = PoseError(target, arm_.LinkPose(link, r.q));
    r.position_error = e.head<3>().norm();
    r.rotation_error = e.tail<3>().norm();
    r.converged = r.position_error <= options_.position_tolerance &&
                  r.rotation_error <= options_.rotation_tolerance;
    if (r.converged || r.iterations == options_.max_iterations) break;
    const Eigen::Matrix<double, 6, Eigen::Dynamic> j = Jacobian(link, r.q);
    const Eigen::Matrix<double, 6, 6> jjt =
        j * j.transpose() + options_.damping * Eigen::Matrix<double, 6, 6>::Identity();
    // LDLT rather than LLT: with lambda 1e-12, J J^T is near-singular at
    // singular configurations and LLT would fail there.
    Eigen::VectorXd dq = j.transpose() * jjt.ldlt().solve(e);
    const double biggest = dq.cwiseAbs().maxCoeff();
    if (biggest > options_.max_step) dq *= options_.max_step / biggest;
    r.q.head(n) += dq;
    if (options_.clamp_to_limits) r.q.head(n) = r.q.head(n).cwiseMax(lo).cwiseMin(hi);
  }
  return r;
}

}  // namespace msspr::sim
