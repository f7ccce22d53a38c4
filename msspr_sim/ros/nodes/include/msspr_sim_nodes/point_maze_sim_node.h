// msspr_sim_node: serves a PointMaze over ROS (docs/nodes.md "msspr_sim_node").
// Publishes observations, camera/goal images, tf2 and /clock; takes actions in
// lockstep (one step per action) or real time (fixed rate, last action held).
#pragma once

#include <geometry_msgs/Twist.h>
#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <tf2_ros/transform_broadcaster.h>

#include <Eigen/Core>
#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <string>

#include "msspr/Action.h"
#include "msspr/Observation.h"
#include "msspr/Pause.h"
#include "msspr/Reset.h"
#include "msspr/SetGoal.h"
#include "msspr_sim/point_maze.h"
#include "msspr_sim_nodes/maze_markers.h"
#include "msspr_sim_nodes/robot_model.h"
#include "msspr_sim_nodes/sim_node_base.h"

namespace msspr::ros_bridge {

struct PointMazeSimNodeOptions : SimNodeCommonOptions {  // control_rate 10 Hz: real time
  std::string maze = "medium";
  int max_episode_steps = 1000;
  int initial_task = -1;  // -1: wait for reset; 0: random; 1..5: task
  // Collection mode (SimNodeCommonOptions): random resets (ResetRandom) with
  // the navigate or stitch expert node driving.
  std::string world_frame = "world";
  std::string agent_frame = "agent";
  // The robot description to check against the simulation and to follow in
  // tf2 (searched up the namespaces; absent: tf2 world -> agent only).
  std::string robot_description = "robot_description";
  bool publish_markers = true;  // markers: walls, goal, recent path (latched)
  int path_length = 500;        // points of the path marker
  double marker_rate = 5.0;     // Hz of wall time, at most
  // Standard messages beside the native ones (config/robots/pointmaze_base.yaml):
  // nav_msgs/Odometry on odom (odom_frame -> base_frame, and that tf), the goal as
  // geometry_msgs/PoseStamped on goal_pose (latched, once per episode or goal), and
  // geometry_msgs/Twist commands on cmd_vel: action = linear.{x,y} / cmd_vel_max_speed.
  bool standard_topics = true;
  std::string odom_frame = "odom";
  std::string base_frame = "base_link";
  double cmd_vel_max_speed = 2.0;  // m/s of a full action (0.2 m per 0.1 s step)
};

// Reads ~params into PointMazeSimNodeOptions, logs every value; throws std::invalid_argument.
PointMazeSimNodeOptions LoadPointMazeSimNodeOptions(const ros::NodeHandle& pnh);

class PointMazeSimNode : public SimNodeBase {
 public:
  PointMazeSimNode(ros::NodeHandle nh, ros::NodeHandle pnh, const PointMazeSimNodeOptions& options);

 private:
  // SimNodeBase's hooks
  void DoStep(const std::vector<double>& action) override;
  uint32_t EpisodeStep() const override { return static_cast<uint32_t>(env_->steps()); }
  void Publish() override;
  bool Reset(msspr::Reset::Request& req, msspr::Reset::Response& res) override;
  bool SetGoal(msspr::SetGoal::Request& req, msspr::SetGoal::Response& res) override;
  void StartCollectionEpisode(uint64_t seed, const std::string& split) override {
    StartEpisode(0, seed, split);
  }
  void StartInitialEpisode() override;
  void OnWatchdogTick() override { markers_.MaybePublish(false); }
  uint32_t StandardObservationSubscribers() const override { return odom_pub_.getNumSubscribers(); }
  uint32_t StandardCommandPublishers() const override { return cmd_vel_sub_.getNumPublishers(); }
  void OnCmdVel(const geometry_msgs::Twist::ConstPtr& msg);
  // Odometry, its tf and (when it changed) the goal pose, stamped with the observation.
  void PublishStandard(const msspr::Observation& o);

  // Starts the next episode: task 1..5 or 0 random.
  // With `start`, the episode starts exactly there with `goal` (custom tasks).
  void StartEpisode(int task_id, uint64_t seed, const std::string& split,
                    const Eigen::Vector2d* start = nullptr,
                    const Eigen::Vector2d& goal = Eigen::Vector2d::Zero());
  msspr::Observation MakeObservation() const;

  PointMazeSimNodeOptions options_;
  std::unique_ptr<sim::PointMaze> env_;
  ros::Publisher joint_state_pub_;
  std::optional<PointRobotModel> robot_;  // from robot_description, checked
  MazeMarkerPublisher markers_;           // walls, goal, path (publish_markers)
  tf2_ros::TransformBroadcaster tf_;
  ros::Publisher odom_pub_, goal_pose_pub_;
  ros::Subscriber cmd_vel_sub_;
  bool goal_dirty_ = true;
  Eigen::Vector2d last_position_ = Eigen::Vector2d::Zero();
  int last_position_step_ = -1;
};

}  // namespace msspr::ros_bridge
