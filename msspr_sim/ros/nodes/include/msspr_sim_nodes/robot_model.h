// The point robot's URDF (msspr_sim/urdf/point_robot.urdf, robot_description):
// parsed with urdfdom and checked against the MuJoCo model that the sim runs,
// so that rviz's robot model, joint_states and tf2 describe the simulated
// agent and nothing else.
#pragma once

#include <ros/node_handle.h>

#include <Eigen/Core>
#include <string>
#include <vector>

#include "msspr_sim/point_maze.h"

namespace urdf {
class Vector3;
}

namespace msspr::ros_bridge {

// A URDF vector (an origin, an axis) as Eigen.
Eigen::Vector3d ToEigen(const urdf::Vector3& v);

// One joint of the chain from the world frame to the agent's link.
struct RobotChainJoint {
  std::string name, parent, child;
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();  // parent -> joint frame (no rotation)
  Eigen::Vector3d axis = Eigen::Vector3d::UnitX();   // unit translation axis
};

struct PointRobotModel {
  std::string name;                    // the URDF's robot name
  std::vector<RobotChainJoint> chain;  // world_frame ... agent_frame, one per MuJoCo slide joint
  double radius = 0;                   // the agent link's sphere
};

// Parses `urdf_xml` with urdfdom and checks it against `env`'s MuJoCo model:
// the root link is world_frame; the chain from it to the link agent_frame is
// prismatic joints with the MuJoCo slide joints' names, order and axes, and
// unrotated origins; their limits contain the maze (the MuJoCo joints are
// unlimited) or equal MuJoCo's; the agent link's sphere (visual and
// collision) has the MuJoCo radius, and the chain lifts its centre by that
// radius. Throws std::runtime_error starting with `source` and naming the
// element that is wrong.
PointRobotModel CheckPointRobotUrdf(const std::string& urdf_xml, const std::string& source,
                                    const sim::PointMaze& env, const std::string& world_frame,
                                    const std::string& agent_frame);

// "(x y z)", for messages.
std::string FormatVector(const Eigen::Vector3d& v);

// A node's robot description: the parameter `param` (searched up the
// namespaces) when it is set, else the file `urdf`, which is then loaded into
// `param` (in the node's namespace) so that rviz sees what the node uses.
// Empty `param`: the file, and no parameter. Throws when the file is unreadable.
struct RobotDescription {
  std::string key;     // the parameter's resolved name ("" without one)
  std::string xml;     // the URDF text
  std::string source;  // "parameter KEY" or the file's path, for messages
};
RobotDescription LoadRobotDescription(ros::NodeHandle& nh, const std::string& param,
                                      const std::string& urdf);

// Reads a whole file; throws std::runtime_error naming it.
std::string ReadTextFile(const std::string& path);

}  // namespace msspr::ros_bridge
