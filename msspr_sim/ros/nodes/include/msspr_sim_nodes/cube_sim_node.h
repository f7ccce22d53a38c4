// The cube-single side of msspr_sim_node (~env cube-single): serves
// a sim::CubeEnv (the URDF arm and one cube) with the point-maze node's
// interface: the same topics, messages and services (observation, action,
// episode, camera/image, goal_image, reset, set_goal, pause, /clock,
// /diagnostics), lockstep or real-time stepping; plus the arm's
// robot_description, sensor_msgs/JointState on joint_states and tf2 for
// every URDF link, the cube and the goal marker (own broadcaster: the
// Debian system has no robot_state_publisher). README "msspr_sim_node: cube-single".
// Standard messages beside those (config/robots/ur5e_cube.yaml,
// docs/bring_your_own_robot.md): the cube's pose as geometry_msgs/PoseStamped
// on cube_pose (as a perception system would give it), the gripper on
// gripper/joint_states, the goal observation on goal_observation, and
// commands as an end-effector geometry_msgs/TwistStamped on ee_twist plus a
// std_msgs/Float64MultiArray gripper command on gripper_command.
#pragma once

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <geometry_msgs/TwistStamped.h>
#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>
#include <std_msgs/Float64MultiArray.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "msspr/Action.h"
#include "msspr/Observation.h"
#include "msspr/Pause.h"
#include "msspr/Reset.h"
#include "msspr/SetGoal.h"
#include "msspr_sim/cube_env.h"
#include "msspr_sim_nodes/arm_messages.h"
#include "msspr_sim_nodes/sim_node_base.h"

namespace msspr::ros_bridge {

struct CubeSimNodeOptions : SimNodeCommonOptions {
  CubeSimNodeOptions() { control_rate = 20.0; }  // Hz, real-time stepping (1 / 0.05 s: real time)
  int max_episode_steps = 200;                   // OGBench's cube-single episodes
  int initial_task = -1;                         // -1: wait for reset; 1..5: task
  // Collection mode (SimNodeCommonOptions): play resets, msspr_cube_oracle_node
  // in play mode driving.
  std::string world_frame = "world";  // the URDF's root link
  std::string cube_frame = "cube";
  std::string goal_frame = "cube_goal";
  // The URDF simulated and served: robot_description (searched up the
  // namespaces) when set, else the file ~urdf, which the node then loads
  // into robot_description (in its namespace).
  std::string robot_description = "robot_description";
  std::string urdf;  // default: the package's ur5e_2f85.urdf
  // Standard messages beside the native ones (see above).
  bool standard_topics = true;
};

// The standard messages of the scene as it is now, stamped `stamp`.
struct CubeStandardMessages {
  // Every moving URDF joint (the mimic finger included): position, velocity.
  sensor_msgs::JointState joint_states;
  // The gripper as its own driver reports it: left_finger_joint's position
  // (m, 0 open .. gripper_travel closed) and velocity, and as effort the norm
  // of the finger's contact wrench (N), saturating at 50 N (the observation's
  // contact entry is effort / 50).
  sensor_msgs::JointState gripper_state;
  // The cube's pose in the world frame; the quaternion as the free joint holds it.
  geometry_msgs::PoseStamped cube_pose;
  // tf2 of the moving URDF joints, the cube, the goal marker and the measured
  // pinch pose (kCubePinchControllerFrame, a child of the world frame).
  std::vector<geometry_msgs::TransformStamped> transforms;
};
inline constexpr const char* kCubePinchControllerFrame = kPinchControllerFrame;
CubeStandardMessages MakeCubeStandardMessages(const sim::CubeEnv& env, const ros::Time& stamp,
                                              const std::string& world_frame,
                                              const std::string& cube_frame,
                                              const std::string& goal_frame);
// The fixed URDF joints, for /tf_static.
std::vector<geometry_msgs::TransformStamped> MakeCubeStaticTransforms(const sim::CubeEnv& env);
// The end-effector command of a cube action: ee_twist's linear (m/s) = action[0:3] * kCubeEeSpeed,
// angular.z (rad/s) = action[3] * kCubeEeYawRate (OGBench's 0.05 m and 0.3 rad per 0.05 s step);
// gripper_command data[0] = action[4] (the change of the opening, 0 open .. 1 closed, over a step).
inline constexpr double kCubeEeSpeed = kEeSpeed;
inline constexpr double kCubeEeYawRate = kEeYawRate;

// Reads ~params into CubeSimNodeOptions, logs every value; throws std::invalid_argument.
CubeSimNodeOptions LoadCubeSimNodeOptions(const ros::NodeHandle& pnh);

// The observation decoders live with CubeEnv (msspr_sim/cube_env.h).
using sim::CubePositionFromObservation;
using sim::CubeYawFromObservation;

class CubeSimNode : public SimNodeBase {
 public:
  CubeSimNode(ros::NodeHandle nh, ros::NodeHandle pnh, const CubeSimNodeOptions& options);
  ~CubeSimNode() override;

 private:
  // SimNodeBase's hooks
  void DoStep(const std::vector<double>& action) override;
  uint32_t EpisodeStep() const override { return static_cast<uint32_t>(env_->episode_steps()); }
  void Publish() override;
  bool Reset(msspr::Reset::Request& req, msspr::Reset::Response& res) override;
  bool SetGoal(msspr::SetGoal::Request& req, msspr::SetGoal::Response& res) override;
  void StartCollectionEpisode(uint64_t seed, const std::string& split) override;
  void StartInitialEpisode() override;
  uint32_t StandardCommandPublishers() const override { return ee_twist_sub_.getNumPublishers(); }
  // A recorder of the arm's standard topics counts as an observation subscriber.
  uint32_t StandardObservationSubscribers() const override {
    return joint_state_pub_.getNumSubscribers();
  }
  void OnEeTwist(const geometry_msgs::TwistStamped::ConstPtr& msg);
  void OnGripperCommand(const std_msgs::Float64MultiArray::ConstPtr& msg);
  // Steps the sim with each complete (twist, gripper command) pair (EeCommandPairs).
  void MaybeStepStandard();
  void PublishGoalObservation();

  void StartEpisode(int task_id, uint64_t seed);
  void BeginEpisode(int task_id, uint64_t seed, const std::string& split,
                    const sim::CubeEnv::Observation& start);
  msspr::Observation MakeObservation() const;
  void PublishRobot(const ros::Time& stamp);
  void PublishStaticFrames();

  CubeSimNodeOptions options_;
  std::unique_ptr<sim::CubeEnv> env_;
  std::vector<float> goal_;  // the episode's goal observation (set_goal replaces it)
  ros::Publisher joint_state_pub_, marker_pub_;
  tf2_ros::TransformBroadcaster tf_;
  tf2_ros::StaticTransformBroadcaster static_tf_;
  ros::Publisher gripper_state_pub_, cube_pose_pub_, goal_obs_pub_;
  ros::Subscriber ee_twist_sub_, gripper_cmd_sub_;
  EeCommandPairs standard_commands_;
};

}  // namespace msspr::ros_bridge
