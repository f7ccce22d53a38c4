// msspr_sim_node: serves a PointMaze over ROS (README "msspr_sim_node").
// Publishes observations, camera/goal images, tf2 and /clock; takes actions in
// lockstep (one step per action) or real time (fixed rate, last action held).
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include <Eigen/Core>
#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <deque>
#include <optional>
#include <tf2_ros/transform_broadcaster.h>

#include "msspr/Action.h"
#include "msspr/Observation.h"
#include "msspr/Pause.h"
#include "msspr/Reset.h"
#include "msspr/SetGoal.h"
#include "msspr_sim/point_maze.h"
#include "action_counters.h"
#include "robot_model.h"

namespace msspr::ros_bridge {

struct SimNodeOptions {
  std::string maze = "medium";
  std::string observation_mode = "state";  // state | pixels | both
  int image_size = 64;
  std::string stepping = "lockstep";       // lockstep | realtime
  double control_rate = 10.0;              // Hz, real-time stepping
  double action_timeout = 0.5;             // s; an older action becomes zero (real time)
  double republish_timeout = 1.0;          // s; lockstep re-sends an unanswered observation
  int max_episode_steps = 1000;
  int initial_task = -1;                   // -1: wait for reset; 0: random; 1..5: task
  int seed = 0;
  // Collection mode: random resets with EpisodeSeed(seed, k), episodes of
  // episode_length steps, the last one's action triggering the next reset.
  bool auto_reset = false;
  int episode_length = 1001;
  int num_episodes = 0;                    // 0: unbounded
  int val_episodes = 0;                    // extra episodes tagged split "val"
  bool shutdown_when_done = true;
  int wait_for_subscribers = 0;            // observation subscribers before starting
  bool publish_clock = true;
  std::string world_frame = "world";
  std::string agent_frame = "agent";
  // The robot description to check against the simulation and to follow in
  // tf2 (searched up the namespaces; absent: tf2 world -> agent only).
  std::string robot_description = "robot_description";
  bool publish_markers = true;             // markers: walls, goal, recent path (latched)
  int path_length = 500;                   // points of the path marker
  double marker_rate = 5.0;                // Hz of wall time, at most
};

// Reads ~params into SimNodeOptions, logs every value; throws std::invalid_argument.
SimNodeOptions LoadSimNodeOptions(const ros::NodeHandle& pnh);

class SimNode {
 public:
  SimNode(ros::NodeHandle nh, ros::NodeHandle pnh, const SimNodeOptions& options);

  using Counters = ActionCounters;
  const Counters& counters() const { return counters_; }

 private:
  bool pixels() const { return options_.observation_mode != "state"; }
  void OnAction(const msspr::Action::ConstPtr& msg);
  bool OnReset(msspr::Reset::Request& req, msspr::Reset::Response& res);
  bool OnSetGoal(msspr::SetGoal::Request& req, msspr::SetGoal::Response& res);
  bool OnPause(msspr::Pause::Request& req, msspr::Pause::Response& res);
  void OnRealtimeTick(const ros::WallTimerEvent&);
  void OnWatchdog(const ros::WallTimerEvent&);
  void OnDiagnostics(const ros::WallTimerEvent&);

  // Starts the next episode: task 1..5 or 0 random.
  // With `start`, the episode starts exactly there with `goal` (custom tasks).
  void StartEpisode(int task_id, uint64_t seed, const std::string& split,
                    const Eigen::Vector2d* start = nullptr,
                    const Eigen::Vector2d& goal = Eigen::Vector2d::Zero());
  void DoStep(const Eigen::Vector2d& action);
  msspr::Observation MakeObservation() const;
  void Publish();
  void PublishMarkers(const ros::Time& stamp);
  // Publishes the markers when they changed and 1 / marker_rate s of wall time
  // have passed since the last time (or now_anyway).
  void MaybePublishMarkers(bool now_anyway);
  bool NextAutoEpisode();  // false when the collection is complete

  SimNodeOptions options_;
  ros::NodeHandle nh_, pnh_;
  std::unique_ptr<sim::PointMaze> env_;
  image_transport::ImageTransport it_;
  // goal_image is a plain latched publisher: image_transport publishes only to
  // transports that have a subscriber at that moment, which loses the latch.
  ros::Publisher obs_pub_, episode_pub_, clock_pub_, diag_pub_, goal_image_pub_;
  ros::Publisher joint_state_pub_, marker_pub_;
  std::optional<PointRobotModel> robot_;  // from robot_description, checked
  std::deque<Eigen::Vector2d> path_;      // recent positions, for the path marker
  bool markers_due_ = true, markers_dirty_ = false;
  ros::Time markers_stamp_;
  ros::WallTime last_marker_time_;
  image_transport::Publisher image_pub_;
  ros::Subscriber action_sub_;
  ros::ServiceServer reset_srv_, goal_srv_, pause_srv_;
  tf2_ros::TransformBroadcaster tf_;
  ros::WallTimer realtime_timer_, watchdog_timer_, diag_timer_;

  bool started_ = false, active_ = false, paused_ = false, done_ = false;
  int64_t episode_id_ = -1;
  uint64_t tick_ = 0;
  std::string env_name_;
  Eigen::Vector2d latest_action_ = Eigen::Vector2d::Zero();
  ros::WallTime latest_action_time_, last_publish_time_, wait_since_;
  bool have_action_ = false;
  Counters counters_;
};

}  // namespace msspr::ros_bridge
