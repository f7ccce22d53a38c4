// V(s, g) of a point-maze state policy over the free cells of its maze, as RViz
// markers: one CUBE_LIST coloured by value (viridis, purple low, yellow high)
// and a text label with the range. msspr_policy_node publishes them on
// value_markers when ~value_marker_maze names a maze. This header does not
// include torch.
#pragma once

#include <visualization_msgs/MarkerArray.h>

#include <string>
#include <vector>

namespace msspr::core {
class Policy;
}

namespace msspr::ros_bridge {

class ValueMarkers {
 public:
  // A grid of per_cell x per_cell points in each free cell of `maze` (a
  // sim::MazeMap name); throws std::invalid_argument for an unknown maze.
  ValueMarkers(const std::string& maze, int per_cell);

  // The markers of V(s, goal) = min over the twin Q of Q(s, pi(s, goal), goal)
  // at every grid point s; goal is [2]. Throws c10::Error when inference fails.
  visualization_msgs::MarkerArray Make(core::Policy& policy, const std::vector<float>& goal) const;

  bool empty() const { return points_.empty(); }

 private:
  int per_cell_;
  std::vector<float> points_;                  // [N, 2] grid over the free cells
  std::vector<double> label_xy_ = {0.0, 0.0};  // where the range label sits
};

}  // namespace msspr::ros_bridge
