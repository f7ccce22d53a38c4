// The ant's URDF (msspr_sim/urdf/ant.urdf, robot_description): parsed with
// urdfdom and checked against the MuJoCo model that the sim runs, so that
// rviz's robot model, joint_states and tf2 describe the simulated ant.
#pragma once

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "msspr_sim/ant_maze.h"

namespace msspr::ros_bridge {

// One URDF joint below the torso: fixed (a leg's thigh) or one of the eight
// revolute hinges.
struct AntUrdfJoint {
  std::string name, parent, child;
  bool revolute = false;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // parent -> joint frame (no rotation)
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();   // unit rotation axis (revolute)
  int hinge = -1;  // revolute: index into sim::kAntHingeJoints (qpos[7 + hinge])
};

struct AntRobotModel {
  std::string name;                  // the URDF's robot name
  std::string base;                  // the root link (the torso)
  std::vector<AntUrdfJoint> joints;  // parents before children
  // The pose of joint j's child in its parent's frame for the hinge angles
  // `hinges` (8, kAntHingeJoints order, radians).
  Eigen::Isometry3d ChildPose(const AntUrdfJoint& j, const Eigen::VectorXd& hinges) const;
};

// Parses `urdf_xml` and checks it against `env`'s MuJoCo model: the root link
// is `base_frame` (MuJoCo's body "torso"); the eight hinges are revolute
// joints with the MuJoCo names, unrotated origins, axes and limits (radians)
// of the model; the other joints are fixed; and, for the hinge angles of a
// few seeded random poses, every link that MuJoCo also has lies where MuJoCo
// puts that body relative to the torso (within 1e-6 m). Throws
// std::runtime_error starting with `source` and naming what is wrong.
AntRobotModel CheckAntUrdf(const std::string& urdf_xml, const std::string& source,
                           const sim::AntMaze& env, const std::string& base_frame);

}  // namespace msspr::ros_bridge
