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
#include "action_counters.h"

namespace msspr::ros_bridge {

struct CubeSimNodeOptions {
  std::string observation_mode = "state";  // state | pixels | both
  int image_size = 64;
  std::string stepping = "lockstep";       // lockstep | realtime
  double control_rate = 20.0;              // Hz, real-time stepping (1 / 0.05 s: real time)
  double action_timeout = 0.5;             // s; an older action becomes zero (real time)
  double republish_timeout = 1.0;          // s; lockstep re-sends an unanswered observation
  int max_episode_steps = 200;             // OGBench's cube-single episodes
  int initial_task = -1;                   // -1: wait for reset; 1..5: task
  int seed = 0;
  bool publish_clock = true;
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

class CubeSimNode {
 public:
  CubeSimNode(ros::NodeHandle nh, ros::NodeHandle pnh, const CubeSimNodeOptions& options);
  ~CubeSimNode();

  using Counters = ActionCounters;

 private:
  bool pixels() const { return options_.observation_mode != "state"; }
  void OnAction(const msspr::Action::ConstPtr& msg);
  bool OnReset(msspr::Reset::Request& req, msspr::Reset::Response& res);
  bool OnSetGoal(msspr::SetGoal::Request& req, msspr::SetGoal::Response& res);
  bool OnPause(msspr::Pause::Request& req, msspr::Pause::Response& res);
  void OnRealtimeTick(const ros::WallTimerEvent&);
  void OnWatchdog(const ros::WallTimerEvent&);
  void OnDiagnostics(const ros::WallTimerEvent&);

  void StartEpisode(int task_id, uint64_t seed);
  void DoStep(const sim::CubeEnv::Action& action);
  msspr::Observation MakeObservation() const;
  ros::Time Now() const;
  void Publish();
  void PublishRobot(const ros::Time& stamp);
  void PublishStaticFrames();

  CubeSimNodeOptions options_;
  ros::NodeHandle nh_, pnh_;
  std::unique_ptr<sim::CubeEnv> env_;
  std::vector<float> goal_;  // the episode's goal observation (set_goal replaces it)
  image_transport::ImageTransport it_;
  ros::Publisher obs_pub_, episode_pub_, clock_pub_, diag_pub_, goal_image_pub_, joint_state_pub_,
      marker_pub_;
  image_transport::Publisher image_pub_;
  ros::Subscriber action_sub_;
  ros::ServiceServer reset_srv_, goal_srv_, pause_srv_;
  tf2_ros::TransformBroadcaster tf_;
  tf2_ros::StaticTransformBroadcaster static_tf_;
  ros::WallTimer realtime_timer_, watchdog_timer_, diag_timer_;

  bool started_ = false, active_ = false, paused_ = false;
  int64_t episode_id_ = -1;
  uint64_t tick_ = 0;
  double control_dt_ = 0.05;
  sim::CubeEnv::Action latest_action_{};
  ros::WallTime latest_action_time_, last_publish_time_;
  bool have_action_ = false;
  Counters counters_;
};

}  // namespace msspr::ros_bridge
