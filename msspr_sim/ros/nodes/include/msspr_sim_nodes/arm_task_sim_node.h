// msspr_sim_node's side for the arm's tasks: ~env cube-single (CubeSimNode, cube_sim_node.h),
// puzzle-3x3 | puzzle-4x4 (PuzzleSimNode: the arm and a grid of push buttons, "Lights Out"),
// cube-double (CubeDoubleSimNode: two cubes) and scene (SceneSimNode: a cube, two lock
// buttons, a drawer and a window). All share ArmTaskSimNode: the same topics,
// messages and services (observation, action, episode, camera/image, goal_image, reset, set_goal,
// pause, /clock, /diagnostics), lockstep or real-time stepping, the arm's robot_description,
// joint_states and tf2, gripper/joint_states, goal_observation and the end-effector commands
// (ee_twist with gripper_command); each adds its objects:
// - the puzzles: buttons/joint_states (names buttonbox_joint_k, position the cap's slide in
//   m, velocity, and as effort the button's state 0 or 1) and markers (a box and a cap per
//   button, the cap red in state 0 and blue in state 1, sent again when a state changes);
// - cube-double: cube_<i>_pose (geometry_msgs/PoseStamped) and tf2 world -> cube_<i> and
//   cube_<i>_goal, and markers for the cubes and their goals;
// - the scene: buttons/joint_states (as the puzzles'), slides/joint_states (drawer_slide and
//   window_slide: position in m, velocity, and as effort 1 while locked, 0 when free),
//   cube_pose and tf2 world -> cube, cube_goal, drawer (the tray) and window (the sliding
//   pane); markers for all of them, the buttons' caps red in state 0 and white in state 1, the
//   drawer's and the window's handles red while locked and white when free (OGBench's colours).
#pragma once

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TwistStamped.h>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>
#include <std_msgs/Float64MultiArray.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>
#include <visualization_msgs/MarkerArray.h>

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "msspr/Observation.h"
#include "msspr/Reset.h"
#include "msspr/SetGoal.h"
#include "msspr_sim/cube_double_env.h"
#include "msspr_sim/cube_env.h"
#include "msspr_sim/env_id.h"
#include "msspr_sim/puzzle_env.h"
#include "msspr_sim/scene_env.h"
#include "msspr_sim_nodes/arm_messages.h"
#include "msspr_sim_nodes/sim_node_base.h"

namespace msspr::ros_bridge {

struct ArmTaskSimNodeOptions : SimNodeCommonOptions {
  ArmTaskSimNodeOptions() { control_rate = 20.0; }  // Hz, real-time stepping (1 / 0.05 s)
  sim::EnvId env = sim::EnvId::kPuzzle3x3;          // cube-single, puzzle-*, cube-double, scene
  int max_episode_steps = 500;        // Load...: OGBench's cap of the env (sim::EvalEpisodeCap)
  int initial_task = -1;              // -1: wait for reset; 1..5: task
  std::string world_frame = "world";  // the URDF's root link
  std::string robot_description = "robot_description";
  std::string urdf;  // default: the package's ur5e_2f85.urdf
  bool standard_topics = true;
};

// Reads ~params into ArmTaskSimNodeOptions for `id`, logs every value; throws
// std::invalid_argument.
ArmTaskSimNodeOptions LoadArmTaskSimNodeOptions(const ros::NodeHandle& pnh, sim::EnvId id);

// The buttons' joint states (see above), stamped `stamp`.
sensor_msgs::JointState MakePuzzleButtonStates(const sim::PuzzleEnv& env, const ros::Time& stamp);
// A goal observation's button states, read from its one-hot entries; throws
// std::invalid_argument unless each button's pair is (1, 0) or (0, 1).
sim::LightsOutState PuzzleGoalStates(const std::vector<float>& goal, int buttons);

// A box and a cap per button (tops `tops`, states `states`) in namespaces button_boxes and
// button_caps, ids 0.., the caps coloured `off` (state 0) or `on` (state 1).
void AppendButtonMarkers(const std::vector<Eigen::Vector3d>& tops, const std::vector<int>& states,
                         const std::array<float, 3>& off, const std::array<float, 3>& on,
                         const std::string& frame, visualization_msgs::MarkerArray* markers);

// The joint states of `buttons` buttons of a puzzle or scene env (see above), stamped `stamp`;
// button k's velocity is observation entry first + 4 k + 3.
template <class Env>
sensor_msgs::JointState MakeButtonStates(const Env& env, int buttons, int first,
                                         const ros::Time& stamp) {
  sensor_msgs::JointState js;
  js.header.stamp = stamp;
  const typename Env::Observation o = env.GetObservation();
  for (int k = 0; k < buttons; ++k) {
    js.name.push_back("buttonbox_joint_" + std::to_string(k));
    js.position.push_back(env.ButtonJoint(k));
    js.velocity.push_back(o[static_cast<size_t>(first + 4 * k + 3)]);
    js.effort.push_back(env.button_states()[static_cast<size_t>(k)]);
  }
  return js;
}

// The scene's buttons and slides (see above), stamped `stamp`.
sensor_msgs::JointState MakeSceneButtonStates(const sim::SceneEnv& env, const ros::Time& stamp);
sensor_msgs::JointState MakeSceneSlideStates(const sim::SceneEnv& env, const ros::Time& stamp);

template <class Env>
class ArmTaskSimNode : public SimNodeBase {
 public:
  ~ArmTaskSimNode() override;

 protected:
  ArmTaskSimNode(ros::NodeHandle nh, ros::NodeHandle pnh, const ArmTaskSimNodeOptions& options,
                 const typename Env::Options& env_options);

  // The env's own standard topics and markers at `stamp` (after every step and reset).
  virtual void PublishObjects(const ros::Time& stamp) = 0;
  // Makes `goal` (an observation of the env's size, finite) the episode's goal in the env;
  // returns "" or what is wrong with it.
  virtual std::string ApplyGoal(const std::vector<float>& goal) = 0;
  // The arm's messages and tf2, then PublishObjects.
  void PublishRobot(const ros::Time& stamp);

  const ArmTaskSimNodeOptions& options() const { return options_; }
  std::unique_ptr<Env> env_;

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
                    const std::vector<float>& start);
  void PublishGoalObservation();
  msspr::Observation MakeObservation() const;

  ArmTaskSimNodeOptions options_;
  std::vector<float> goal_;
  ros::Publisher joint_state_pub_, gripper_state_pub_, goal_obs_pub_;
  tf2_ros::TransformBroadcaster tf_;
  tf2_ros::StaticTransformBroadcaster static_tf_;
  ros::Subscriber ee_twist_sub_, gripper_cmd_sub_;
  EeCommandPairs standard_commands_;
};

class PuzzleSimNode : public ArmTaskSimNode<sim::PuzzleEnv> {
 public:
  PuzzleSimNode(ros::NodeHandle nh, ros::NodeHandle pnh, const ArmTaskSimNodeOptions& options);

 private:
  void PublishObjects(const ros::Time& stamp) override;
  std::string ApplyGoal(const std::vector<float>& goal) override;

  ros::Publisher buttons_pub_, marker_pub_;
  sim::LightsOutState drawn_states_;  // the states the markers show
};

class CubeDoubleSimNode : public ArmTaskSimNode<sim::CubeDoubleEnv> {
 public:
  CubeDoubleSimNode(ros::NodeHandle nh, ros::NodeHandle pnh, const ArmTaskSimNodeOptions& options);

 private:
  void PublishObjects(const ros::Time& stamp) override;
  std::string ApplyGoal(const std::vector<float>& goal) override;

  std::vector<ros::Publisher> cube_pose_pubs_;
  ros::Publisher marker_pub_;
  tf2_ros::TransformBroadcaster object_tf_;
};

class SceneSimNode : public ArmTaskSimNode<sim::SceneEnv> {
 public:
  SceneSimNode(ros::NodeHandle nh, ros::NodeHandle pnh, const ArmTaskSimNodeOptions& options);

 private:
  void PublishObjects(const ros::Time& stamp) override;
  // The goal observation's scene state becomes the goal (its cube centre moves the marker).
  std::string ApplyGoal(const std::vector<float>& goal) override;
  void PublishMarkers();

  ros::Publisher buttons_pub_, slides_pub_, cube_pose_pub_, marker_pub_;
  tf2_ros::TransformBroadcaster object_tf_;
  std::array<int, 2> drawn_states_{-1, -1};  // the button states the markers show
};

}  // namespace msspr::ros_bridge
