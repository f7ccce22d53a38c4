// The puzzles' side of msspr_sim_node (~env puzzle-3x3 | puzzle-4x4): serves a
// sim::PuzzleEnv (the URDF arm and a grid of push buttons, "Lights Out") with the interface
// of cube-single's node (cube_sim_node.h): the same topics, messages and services
// (observation, action, episode, camera/image, goal_image, reset, set_goal, pause, /clock,
// /diagnostics), lockstep or real-time stepping, the arm's robot_description, joint_states
// and tf2; markers for the buttons (a cap per button, red in state 0 and blue in state 1,
// redrawn when a state changes). Standard messages beside those: the buttons as a
// sensor_msgs/JointState on buttons/joint_states (names buttonbox_joint_k, position the cap's
// slide in m, velocity, and as effort the button's state 0 or 1), the gripper on
// gripper/joint_states, the goal observation on goal_observation, and commands as an
// end-effector geometry_msgs/TwistStamped on ee_twist with a gripper_command, as the cube's.
#pragma once

#include <geometry_msgs/TwistStamped.h>
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

#include "msspr/Observation.h"
#include "msspr/Reset.h"
#include "msspr/SetGoal.h"
#include "msspr_sim/env_id.h"
#include "msspr_sim/puzzle_env.h"
#include "msspr_sim_nodes/arm_messages.h"
#include "msspr_sim_nodes/sim_node_base.h"

namespace msspr::ros_bridge {

struct PuzzleSimNodeOptions : SimNodeCommonOptions {
  PuzzleSimNodeOptions() { control_rate = 20.0; }  // Hz, real-time stepping (1 / 0.05 s)
  int side = 3;                                    // 3: puzzle-3x3, 4: puzzle-4x4
  int max_episode_steps = 500;                     // OGBench's puzzle episodes
  int initial_task = -1;                           // -1: wait for reset; 1..5: task
  std::string world_frame = "world";               // the URDF's root link
  std::string robot_description = "robot_description";
  std::string urdf;  // default: the package's ur5e_2f85.urdf
  bool standard_topics = true;
};

// The buttons' joint states (see above), stamped `stamp`.
sensor_msgs::JointState MakePuzzleButtonStates(const sim::PuzzleEnv& env, const ros::Time& stamp);
// A goal observation's button states, read from its one-hot entries; throws
// std::invalid_argument unless each button's pair is (1, 0) or (0, 1).
sim::LightsOutState PuzzleGoalStates(const std::vector<float>& goal, int buttons);

// Reads ~params into PuzzleSimNodeOptions for `id` (a puzzle), logs every value; throws
// std::invalid_argument.
PuzzleSimNodeOptions LoadPuzzleSimNodeOptions(const ros::NodeHandle& pnh, sim::EnvId id);

class PuzzleSimNode : public SimNodeBase {
 public:
  PuzzleSimNode(ros::NodeHandle nh, ros::NodeHandle pnh, const PuzzleSimNodeOptions& options);
  ~PuzzleSimNode() override;

 private:
  void DoStep(const std::vector<double>& action) override;
  uint32_t EpisodeStep() const override { return static_cast<uint32_t>(env_->episode_steps()); }
  void Publish() override;
  bool Reset(msspr::Reset::Request& req, msspr::Reset::Response& res) override;
  bool SetGoal(msspr::SetGoal::Request& req, msspr::SetGoal::Response& res) override;
  void StartCollectionEpisode(uint64_t seed, const std::string& split) override;
  void StartInitialEpisode() override;
  uint32_t StandardCommandPublishers() const override { return ee_twist_sub_.getNumPublishers(); }
  uint32_t StandardObservationSubscribers() const override {
    return joint_state_pub_.getNumSubscribers();
  }
  void OnEeTwist(const geometry_msgs::TwistStamped::ConstPtr& msg);
  void OnGripperCommand(const std_msgs::Float64MultiArray::ConstPtr& msg);
  // Steps the sim with each complete (twist, gripper command) pair (EeCommandPairs).
  void MaybeStepStandard();

  void StartEpisode(int task_id, uint64_t seed);
  void BeginEpisode(int task_id, uint64_t seed, const std::string& split,
                    const sim::PuzzleEnv::Observation& start);
  msspr::Observation MakeObservation() const;
  void PublishRobot(const ros::Time& stamp);
  void PublishMarkers();

  PuzzleSimNodeOptions options_;
  std::unique_ptr<sim::PuzzleEnv> env_;
  std::vector<float> goal_;
  sim::LightsOutState drawn_states_;  // the states the markers show
  ros::Publisher joint_state_pub_, marker_pub_, gripper_state_pub_, buttons_pub_, goal_obs_pub_;
  tf2_ros::TransformBroadcaster tf_;
  tf2_ros::StaticTransformBroadcaster static_tf_;
  ros::Subscriber ee_twist_sub_, gripper_cmd_sub_;
  EeCommandPairs standard_commands_;
};

}  // namespace msspr::ros_bridge
