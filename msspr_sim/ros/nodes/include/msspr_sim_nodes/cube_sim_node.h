// The cube-single side of msspr_sim_node (~env cube-single): serves a sim::CubeEnv (the URDF
// arm and one cube) with the point-maze node's interface: the same topics, messages and
// services (observation, action, episode, camera/image, goal_image, reset, set_goal, pause,
// /clock, /diagnostics), lockstep or real-time stepping; plus the arm's robot_description,
// sensor_msgs/JointState on joint_states and tf2 for every URDF link, the cube and the goal
// marker (own broadcaster: the Debian system has no robot_state_publisher). It is the arm
// task node of arm_task_sim_node.h with the cube as its object.
// Standard messages beside those (config/robots/ur5e_cube.yaml,
// docs/bring_your_own_robot.md): the cube's pose as geometry_msgs/PoseStamped on cube_pose
// (as a perception system would give it), the gripper on gripper/joint_states, the goal
// observation on goal_observation, and commands as an end-effector
// geometry_msgs/TwistStamped on ee_twist plus a std_msgs/Float64MultiArray gripper command on
// gripper_command.
#pragma once

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>
#include <tf2_ros/transform_broadcaster.h>

#include <string>
#include <vector>

#include "msspr_sim/cube_env.h"
#include "msspr_sim_nodes/arm_messages.h"
#include "msspr_sim_nodes/arm_task_sim_node.h"

namespace msspr::ros_bridge {

struct CubeSimNodeOptions : ArmTaskSimNodeOptions {
  CubeSimNodeOptions() {
    env = sim::EnvId::kCubeSingle;
    max_episode_steps = 200;  // OGBench's cube-single episodes
  }
  std::string cube_frame = "cube";
  std::string goal_frame = "cube_goal";
};

// The cube's standard messages as the scene is now, stamped `stamp`.
struct CubeObjectMessages {
  // The cube's pose in the world frame; the quaternion as the free joint holds it.
  geometry_msgs::PoseStamped cube_pose;
  // tf2 of the cube and the goal marker.
  std::vector<geometry_msgs::TransformStamped> transforms;
};
CubeObjectMessages MakeCubeObjectMessages(const sim::CubeEnv& env, const ros::Time& stamp,
                                          const std::string& world_frame,
                                          const std::string& cube_frame,
                                          const std::string& goal_frame);

// Every standard message of the scene (what the node publishes at a step).
struct CubeStandardMessages {
  // Every moving URDF joint (the mimic finger included): position, velocity.
  sensor_msgs::JointState joint_states;
  // The gripper as its own driver reports it (ArmStandardMessages::gripper_state).
  sensor_msgs::JointState gripper_state;
  geometry_msgs::PoseStamped cube_pose;
  // tf2 of the moving URDF joints, the measured pinch pose (kPinchControllerFrame), the cube
  // and the goal marker.
  std::vector<geometry_msgs::TransformStamped> transforms;
};
inline constexpr const char* kCubePinchControllerFrame = kPinchControllerFrame;
CubeStandardMessages MakeCubeStandardMessages(const sim::CubeEnv& env, const ros::Time& stamp,
                                              const std::string& world_frame,
                                              const std::string& cube_frame,
                                              const std::string& goal_frame);
// The fixed URDF joints, for /tf_static.
std::vector<geometry_msgs::TransformStamped> MakeCubeStaticTransforms(const sim::CubeEnv& env);
// The end-effector command of a cube action (arm_messages.h: kEeSpeed, kEeYawRate).
inline constexpr double kCubeEeSpeed = kEeSpeed;
inline constexpr double kCubeEeYawRate = kEeYawRate;

// Reads ~params into CubeSimNodeOptions, logs every value; throws std::invalid_argument.
CubeSimNodeOptions LoadCubeSimNodeOptions(const ros::NodeHandle& pnh);

// The observation decoders live with CubeEnv (msspr_sim/cube_env.h).
using sim::CubePositionFromObservation;
using sim::CubeYawFromObservation;

class CubeSimNode : public ArmTaskSimNode<sim::CubeEnv> {
 public:
  CubeSimNode(ros::NodeHandle nh, ros::NodeHandle pnh, const CubeSimNodeOptions& options);

 private:
  void PublishObjects(const ros::Time& stamp) override;
  std::string ApplyGoal(const std::vector<float>& goal) override;

  CubeSimNodeOptions cube_options_;
  ros::Publisher cube_pose_pub_, marker_pub_;
  tf2_ros::TransformBroadcaster object_tf_;
};

}  // namespace msspr::ros_bridge
