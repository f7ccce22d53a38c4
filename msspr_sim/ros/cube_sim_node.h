// The cube-single side of msspr_sim_node (~env cube-single, issue 11): serves
// a sim::CubeEnv (the URDF arm and one cube) with the point-maze node's
// interface: the same topics, messages and services (observation, action,
// episode, camera/image, goal_image, reset, set_goal, pause, /clock,
// /diagnostics), lockstep or real-time stepping; plus the arm's
// robot_description, sensor_msgs/JointState on joint_states and tf2 for
// every URDF link, the cube and the goal marker (own broadcaster: the
// Debian system has no robot_state_publisher). README "msspr_sim_node: cube-single".
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include "msspr/Action.h"
#include "msspr/Observation.h"
#include "msspr/Pause.h"
#include "msspr/Reset.h"
#include "msspr/SetGoal.h"
#include "msspr_sim/cube_env.h"
#include "sim_node_base.h"

namespace msspr::ros_bridge {

struct CubeSimNodeOptions : SimNodeCommonOptions {
  CubeSimNodeOptions() { control_rate = 20.0; }  // Hz, real-time stepping (1 / 0.05 s: real time)
  int max_episode_steps = 200;             // OGBench's cube-single episodes
  int initial_task = -1;                   // -1: wait for reset; 1..5: task
  // Collection mode (SimNodeCommonOptions): play resets, msspr_cube_oracle_node
  // in play mode driving.
  std::string world_frame = "world";       // the URDF's root link
  std::string cube_frame = "cube";
  std::string goal_frame = "cube_goal";
  // The URDF simulated and served: robot_description (searched up the
  // namespaces) when set, else the file ~urdf, which the node then loads
  // into robot_description (in its namespace).
  std::string robot_description = "robot_description";
  std::string urdf;                        // default: the package's ur5e_2f85.urdf
};

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

  void StartEpisode(int task_id, uint64_t seed);
  void BeginEpisode(int task_id, uint64_t seed, const std::string& split, const sim::CubeEnv::Observation& start);
  msspr::Observation MakeObservation() const;
  void PublishRobot(const ros::Time& stamp);
  void PublishStaticFrames();

  CubeSimNodeOptions options_;
  std::unique_ptr<sim::CubeEnv> env_;
  std::vector<float> goal_;  // the episode's goal observation (set_goal replaces it)
  ros::Publisher joint_state_pub_, marker_pub_;
  tf2_ros::TransformBroadcaster tf_;
  tf2_ros::StaticTransformBroadcaster static_tf_;
};

}  // namespace msspr::ros_bridge
