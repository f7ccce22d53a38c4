// Internal: conversions from urdfdom's types, shared by ArmModel (forward
// kinematics) and CubeSceneMjcf (the MJCF generated from the same model).
#ifndef MSSPR_SIM_SRC_URDF_UTIL_H_
#define MSSPR_SIM_SRC_URDF_UTIL_H_

#include <urdf_model/pose.h>

#include <Eigen/Geometry>

namespace msspr::sim::internal {

// A URDF origin (xyz + quaternion, normalised here) as a rigid transform.
inline Eigen::Isometry3d ToEigen(const urdf::Pose& p) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = Eigen::Vector3d(p.position.x, p.position.y, p.position.z);
  t.linear() = Eigen::Quaterniond(p.rotation.w, p.rotation.x, p.rotation.y, p.rotation.z)
                   .normalized()
                   .toRotationMatrix();
  return t;
}

}  // namespace msspr::sim::internal

#endif  // MSSPR_SIM_SRC_URDF_UTIL_H_
