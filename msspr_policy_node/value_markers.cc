#include "value_markers.h"

#include <torch/torch.h>

#include <algorithm>
#include <sstream>

#include "msspr_core/policy.h"
#include "msspr_sim/maze_map.h"

namespace msspr::ros_bridge {

namespace {

// Viridis, 5 stops, linear in between; t in [0, 1].
std_msgs::ColorRGBA Viridis(double t) {
  static const double stops[5][3] = {{0.267, 0.005, 0.329},
                                     {0.229, 0.322, 0.546},
                                     {0.128, 0.567, 0.551},
                                     {0.369, 0.789, 0.383},
                                     {0.993, 0.906, 0.144}};
  t = std::clamp(t, 0.0, 1.0) * 4.0;
  const int i = std::min(3, static_cast<int>(t));
  const double f = t - i;
  std_msgs::ColorRGBA c;
  c.r = static_cast<float>(stops[i][0] + f * (stops[i + 1][0] - stops[i][0]));
  c.g = static_cast<float>(stops[i][1] + f * (stops[i + 1][1] - stops[i][1]));
  c.b = static_cast<float>(stops[i][2] + f * (stops[i + 1][2] - stops[i][2]));
  c.a = 0.85f;
  return c;
}

}  // namespace

ValueMarkers::ValueMarkers(const std::string& maze, int per_cell) : per_cell_(per_cell) {
  const auto map = sim::MazeMap::FromName(maze);
  const int n = per_cell;
  for (const sim::Cell& c : map.FreeCells())
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) {
        const Eigen::Vector2d p =
            map.CellCenter(c) +
            sim::kCellSize * Eigen::Vector2d((b + 0.5) / n - 0.5, (a + 0.5) / n - 0.5);
        points_.push_back(static_cast<float>(p.x()));
        points_.push_back(static_cast<float>(p.y()));
      }
  // The range label: centred below the maze (its lowest row of free cells, minus a cell).
  double x0 = 1e9, x1 = -1e9, y0 = 1e9;
  for (size_t k = 0; k + 1 < points_.size(); k += 2) {
    x0 = std::min<double>(x0, points_[k]);
    x1 = std::max<double>(x1, points_[k]);
    y0 = std::min<double>(y0, points_[k + 1]);
  }
  label_xy_ = {0.5 * (x0 + x1), y0 - 0.75 * sim::kCellSize};
}

visualization_msgs::MarkerArray ValueMarkers::Make(core::Policy& policy,
                                                   const std::vector<float>& goal_xy) const {
  const int64_t n = static_cast<int64_t>(points_.size() / 2);
  torch::Tensor v;
  {
    torch::InferenceMode guard;
    const torch::Tensor obs =
        torch::from_blob(const_cast<float*>(points_.data()), {n, 2}, torch::kFloat32);
    const torch::Tensor goal = torch::tensor(goal_xy).unsqueeze(0).expand({n, 2}).contiguous();
    v = std::get<0>(policy.Q(obs, policy.Act(obs, goal), goal).min(-1))
            .to(torch::kCPU)
            .contiguous();
  }
  const float* q = v.data_ptr<float>();
  const float lo = *std::min_element(q, q + n), hi = *std::max_element(q, q + n);
  visualization_msgs::MarkerArray arr;
  visualization_msgs::Marker m;
  m.header.stamp = ros::Time::now();
  m.header.frame_id = "world";
  m.ns = "value";
  m.id = 0;
  m.type = visualization_msgs::Marker::CUBE_LIST;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  m.scale.x = m.scale.y = sim::kCellSize / per_cell_;
  m.scale.z = 0.02;
  for (int64_t k = 0; k < n; ++k) {
    geometry_msgs::Point p;
    p.x = points_[2 * k];
    p.y = points_[2 * k + 1];
    p.z = 0.01;
    m.points.push_back(p);
    m.colors.push_back(Viridis(hi > lo ? (q[k] - lo) / (hi - lo) : 1.0));
  }
  // The range, as text above the maze's origin.
  visualization_msgs::Marker label;
  label.header = m.header;
  label.ns = "value_range";
  label.type = visualization_msgs::Marker::TEXT_VIEW_FACING;
  label.action = visualization_msgs::Marker::ADD;
  label.pose.orientation.w = 1.0;
  label.pose.position.x = label_xy_[0];
  label.pose.position.y = label_xy_[1];
  label.pose.position.z = 3.0;
  label.scale.z = 1.2;
  label.color.a = 1.0;
  std::ostringstream txt;
  txt.precision(3);
  txt << "V(s, g) from " << lo << " (purple) to " << hi << " (yellow)";
  label.text = txt.str();
  arr.markers.push_back(m);
  arr.markers.push_back(label);
  return arr;
}

}  // namespace msspr::ros_bridge
