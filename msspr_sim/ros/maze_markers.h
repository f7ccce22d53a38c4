// The rviz markers of a maze scene, shared by the point-maze and ant-maze sim
// nodes: the walls (one cube per wall cell, as the MuJoCo blocks), the goal (a
// disc of the success radius) and the agent's recent path.
#pragma once

#include <ros/time.h>
#include <visualization_msgs/MarkerArray.h>

#include <Eigen/Core>
#include <deque>
#include <string>

#include "msspr_sim/maze_map.h"

namespace msspr::ros_bridge {

// Namespaces "walls", "goal" and "path" (deleted while it has under 2 points),
// in `frame`, stamped `stamp`.
visualization_msgs::MarkerArray MazeMarkers(const sim::MazeMap& map, const Eigen::Vector2d& goal_xy,
                                            double success_radius,
                                            const std::deque<Eigen::Vector2d>& path,
                                            const std::string& frame, const ros::Time& stamp);

}  // namespace msspr::ros_bridge
