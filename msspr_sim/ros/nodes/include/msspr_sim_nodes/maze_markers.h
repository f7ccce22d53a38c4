// The rviz markers of a maze scene, shared by the point-maze and ant-maze sim
// nodes: the walls (one cube per wall cell, as the MuJoCo blocks), the goal (a
// disc of the success radius) and the agent's recent path.
#pragma once

#include <ros/ros.h>
#include <visualization_msgs/MarkerArray.h>

#include <Eigen/Core>
#include <deque>
#include <functional>
#include <string>

#include "msspr_sim/maze_map.h"

namespace msspr::ros_bridge {

// Namespaces "walls", "goal" and "path" (deleted while it has under 2 points),
// in `frame`, stamped `stamp`.
visualization_msgs::MarkerArray MazeMarkers(const sim::MazeMap& map, const Eigen::Vector2d& goal_xy,
                                            double success_radius,
                                            const std::deque<Eigen::Vector2d>& path,
                                            const std::string& frame, const ros::Time& stamp);

// A sim node's markers topic: the agent's recent path, and the markers
// re-published (latched) when they changed, at most marker_rate times per
// second of wall time; an episode's first update goes out at once.
class MazeMarkerPublisher {
 public:
  // The markers for the path so far, stamped.
  using Make = std::function<visualization_msgs::MarkerArray(
      const std::deque<Eigen::Vector2d>& path, const ros::Time& stamp)>;
  // Advertises `markers` on nh; until then every call does nothing.
  void Advertise(ros::NodeHandle& nh, double marker_rate, int path_length, Make make);
  // A new episode, or a goal moved: the path restarts (new episode), and the
  // next update is published at once.
  void NewEpisode() {
    path_.clear();
    due_ = true;
  }
  void GoalMoved() { due_ = dirty_ = true; }
  // The agent is at xy at `stamp`: extends the path and publishes when due.
  void Update(const Eigen::Vector2d& xy, const ros::Time& stamp);
  // Publishes a pending change when the rate allows (or now_anyway); for a
  // watchdog timer, so that the last change of a paused sim goes out.
  void MaybePublish(bool now_anyway);

 private:
  ros::Publisher pub_;
  double rate_ = 5.0;
  int path_length_ = 500;
  Make make_;
  std::deque<Eigen::Vector2d> path_;
  bool due_ = true, dirty_ = false;
  ros::Time stamp_;
  ros::WallTime last_;
};

}  // namespace msspr::ros_bridge
