// The ant-maze side of msspr_sim_node (~env antmaze-medium | antmaze-large):
// serves a sim::AntMaze (OGBench's ant in the point maze's maps) with the
// point-maze node's interface: the same topics, messages and services
// (observation, action, episode, reset, set_goal, pause, /clock,
// /diagnostics), lockstep or real-time stepping at 10 Hz; plus the ant's
// robot_description (msspr_sim/urdf/ant.urdf, checked against the MuJoCo
// model), sensor_msgs/JointState of the eight hinges on joint_states, tf2 of
// the torso in the world (from the free joint) and of every leg link, and
// markers (walls, goal, path). States only; datasets come from
// `msspr_collect --env antmaze-*` (docs/ant_mazes.md).
#pragma once

#include <ros/ros.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "msspr/Observation.h"
#include "msspr_sim/ant_maze.h"
#include "msspr_sim/env_id.h"
#include "msspr_sim_nodes/ant_robot_model.h"
#include "msspr_sim_nodes/maze_markers.h"
#include "msspr_sim_nodes/sim_node_base.h"

namespace msspr::ros_bridge {

struct AntSimNodeOptions : SimNodeCommonOptions {
  AntSimNodeOptions() {
    control_rate = 10.0;
  }  // Hz, real-time stepping (0.1 s per step: real time)
  sim::EnvId env = sim::EnvId::kAntMazeMedium;
  int max_episode_steps = 1000;  // OGBench's antmaze-medium/large episodes
  int initial_task = -1;         // -1: wait for reset; 0: random; 1..5: task
  std::string world_frame = "world";
  std::string base_frame = "torso";  // the URDF's root link
  // The URDF served: robot_description (searched up the namespaces) when set,
  // else the file ~urdf, which the node then loads into robot_description.
  std::string robot_description = "robot_description";
  std::string urdf;  // default: the package's msspr_sim/urdf/ant.urdf
  bool publish_markers = true;
  double marker_rate = 5.0;  // Hz at most
  int path_length = 500;     // points of the path marker
};

// Reads the ~params (env given by ~env); throws std::invalid_argument naming a bad one.
AntSimNodeOptions LoadAntSimNodeOptions(const ros::NodeHandle& pnh, sim::EnvId env);

class AntSimNode : public SimNodeBase {
 public:
  AntSimNode(ros::NodeHandle nh, ros::NodeHandle pnh, const AntSimNodeOptions& options);
  ~AntSimNode() override;

 private:
  void DoStep(const std::vector<double>& action) override;
  uint32_t EpisodeStep() const override { return static_cast<uint32_t>(env_->steps()); }
  void Publish() override;
  bool Reset(msspr::Reset::Request& req, msspr::Reset::Response& res) override;
  bool SetGoal(msspr::SetGoal::Request& req, msspr::SetGoal::Response& res) override;
  void StartCollectionEpisode(uint64_t seed, const std::string& split) override;
  void StartInitialEpisode() override;
  void OnWatchdogTick() override { markers_.MaybePublish(false); }

  void StartEpisode(int task_id, uint64_t seed, const Eigen::Vector2d* start,
                    const Eigen::Vector2d& goal);
  msspr::Observation MakeObservation() const;
  void PublishRobot(const ros::Time& stamp);

  AntSimNodeOptions options_;
  std::unique_ptr<sim::AntMaze> env_;
  AntRobotModel robot_;
  ros::Publisher joint_state_pub_;
  tf2_ros::TransformBroadcaster tf_;
  tf2_ros::StaticTransformBroadcaster static_tf_;
  MazeMarkerPublisher markers_;  // walls, goal, path (publish_markers)
};

}  // namespace msspr::ros_bridge
