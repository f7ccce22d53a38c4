// Differential inverse kinematics for an ArmModel's arm joints, as OGBench's
// cube tasks do it (ogbench/manipspace/controllers/diff_ik.py; facts in
// OGBench's manipspace controller): damped least squares on the
// 6-D pose error of one frame, a capped step, a few iterations.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

#include "msspr_sim/arm_model.h"

namespace msspr::sim {

struct ArmIkOptions {
  int max_iterations = 20;
  double position_tolerance = 1e-4;  // m
  double rotation_tolerance = 1e-4;  // rad
  double damping = 1e-12;            // lambda in J^T (J J^T + lambda I)^-1
  double max_step = M_PI / 4;        // rad; a step's largest |dq_i| is scaled down to this
  // OGBench does not limit the IK; its servos' ctrlrange clips the targets to
  // the joint range instead. Clamping each iterate to the URDF limits gives
  // the same targets when no limit is hit and keeps the solver's model
  // consistent with what the servos will do when one is.
  bool clamp_to_limits = true;
};

struct ArmIkResult {
  Eigen::VectorXd q;          // [num_dofs()] the final configuration (gripper unchanged)
  bool converged = false;     // both tolerances met
  int iterations = 0;         // steps taken
  double position_error = 0;  // m, at q
  double rotation_error = 0;  // rad, at q
};

// The 6-D error (target - current): position difference and the rotation
// vector of target * current^-1 with its angle in (-pi, pi], both in the root
// frame (MuJoCo's mju_quat2Vel of the quaternion difference with dt 1).
Eigen::Matrix<double, 6, 1> PoseError(const Eigen::Isometry3d& target,
                                      const Eigen::Isometry3d& current);

class ArmIk {
 public:
  // Keeps a reference to `arm`, which must outlive the solver. Throws
  // std::invalid_argument for options out of range.
  explicit ArmIk(const ArmModel& arm, const ArmIkOptions& options = {});

  // The 6 x num_arm_joints geometric Jacobian of link `link`'s origin at q:
  // rows 0-2 the linear velocity, rows 3-5 the angular velocity, root frame.
  Eigen::Matrix<double, 6, Eigen::Dynamic> Jacobian(int link, const Eigen::VectorXd& q) const;

  // Moves the arm joints of q0 [num_dofs()] so that link `link` reaches
  // `target` (root frame). Never throws for unreachable targets: the result
  // says whether the tolerances were met.
  ArmIkResult Solve(const Eigen::Isometry3d& target, int link, const Eigen::VectorXd& q0) const;

  const ArmIkOptions& options() const { return options_; }

 private:
  const ArmModel& arm_;
  ArmIkOptions options_;
};

}  // namespace msspr::sim
