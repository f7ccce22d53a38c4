// What the arm's sim nodes (cube-single, the puzzles) share: the arm's standard messages
// from the simulated state, and the env built from robot_description or ~urdf.
#pragma once

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <geometry_msgs/TwistStamped.h>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>
#include <unistd.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdio>
#include <deque>
#include <fstream>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "msspr_sim/arm_model.h"
#include "msspr_sim_nodes/robot_model.h"

namespace msspr::ros_bridge {

// The pinch pose as the arm's controller measures it, a child of the world frame.
inline constexpr char kPinchControllerFrame[] = "pinch_controller";

struct ArmStandardMessages {
  // Every moving URDF joint (the mimic finger included): position, velocity.
  sensor_msgs::JointState joint_states;
  // The gripper as its own driver reports it: the first finger joint's position (m, 0 open
  // .. travel closed) and velocity, and as effort the norm of the finger's contact wrench
  // (N), saturating at 50 N (the observation's contact entry is effort / 50).
  sensor_msgs::JointState gripper_state;
  // tf2 of the moving URDF joints and the measured pinch pose (kPinchControllerFrame).
  std::vector<geometry_msgs::TransformStamped> transforms;
};

// From an arm env's qpos / qvel (arm joints first, then the left finger), the
// observation's contact entry (index 18) and the measured pinch pose.
ArmStandardMessages MakeArmStandardMessages(const sim::ArmModel& arm,
                                            const std::vector<double>& qpos,
                                            const std::vector<double>& qvel, double contact,
                                            const Eigen::Vector3d& pinch,
                                            const Eigen::Matrix3d& pinch_rotation,
                                            const ros::Time& stamp, const std::string& world_frame);
// A free body's pose from its 7 qpos entries from `q` (x, y, z, then the quaternion w, x, y,
// z): as a transform and as a PoseStamped in `frame`.
Eigen::Isometry3d FreeBodyPose(const double* q);
geometry_msgs::PoseStamped FreeBodyPoseMsg(const double* q, const ros::Time& stamp,
                                           const std::string& frame);
// A pose of position `p` turned `yaw` about z (a goal marker's).
Eigen::Isometry3d YawPose(const Eigen::Vector3d& p, double yaw);

// The fixed URDF joints, for /tf_static.
std::vector<geometry_msgs::TransformStamped> MakeArmStaticTransforms(const sim::ArmModel& arm);

// The end-effector command of an arm action: ee_twist's linear (m/s) = action[0:3] * kEeSpeed,
// angular.z (rad/s) = action[3] * kEeYawRate (OGBench's 0.05 m and 0.3 rad per 0.05 s step);
// gripper_command data[0] = action[4] (the change of the opening, 0 open .. 1 closed, over a
// step).
inline constexpr double kEeSpeed = 1.0;
inline constexpr double kEeYawRate = 6.0;

// The standard commands of an arm sim node, paired: the k-th ee_twist with the k-th
// gripper_command (each topic arrives in order; at most 10 of each wait).
class EeCommandPairs {
 public:
  void AddTwist(const geometry_msgs::TwistStamped& twist);
  void AddGrip(double grip);  // NaN for an empty gripper command
  // Takes the complete pairs in order. A pair whose twist is stamped before `now` (made for
  // an earlier step or episode, e.g. answering an episode's last observation after a reset;
  // a zero stamp counts as now) is dropped and counted, with a warning; each other pair
  // becomes the 5-D action passed to `step`.
  void Drain(const ros::Time& now, const std::function<void(const std::vector<float>&)>& step);
  uint64_t stale() const { return stale_; }

 private:
  std::deque<geometry_msgs::TwistStamped> twists_;
  std::deque<double> grips_;
  uint64_t stale_ = 0;
};

// The env of an arm sim node: the URDF of robot_description (searched up the namespaces)
// when set, else of the file `urdf`, which is then served as robot_description; written to
// a temporary file for the env, which parses a path. Throws std::runtime_error naming the
// URDF's source when the env rejects it, std::invalid_argument when its root link is not
// `world_frame`.
template <class Env, class EnvOptions>
std::unique_ptr<Env> MakeArmEnv(ros::NodeHandle& nh, const std::string& robot_description,
                                const std::string& urdf, const std::string& world_frame,
                                EnvOptions env_opt) {
  const RobotDescription desc = LoadRobotDescription(nh, robot_description, urdf);
  const std::string tmp = "/tmp/msspr_arm_sim_" + std::to_string(getpid()) + ".urdf";
  {
    std::ofstream f(tmp);
    f << desc.xml;
    if (!f) throw std::runtime_error("cannot write " + tmp);
  }
  env_opt.urdf_path = tmp;
  std::unique_ptr<Env> env;
  try {
    env = std::make_unique<Env>(env_opt);
  } catch (const std::exception& e) {
    std::remove(tmp.c_str());
    throw std::runtime_error(desc.source + ": " + e.what());
  }
  std::remove(tmp.c_str());
  const auto& root = env->arm().links().front().name;
  if (root != world_frame)
    throw std::invalid_argument(desc.source + ": the URDF's root link is '" + root +
                                "', ~world_frame is '" + world_frame + "'");
  ROS_INFO_STREAM_NAMED("msspr_sim", "robot_description "
                                         << desc.key << " (from " << desc.source << "): robot '"
                                         << env->arm().name() << "', " << env->arm().links().size()
                                         << " links; simulated from the same text");
  return env;
}

}  // namespace msspr::ros_bridge
