#include "msspr_sim_nodes/maze_markers.h"

namespace msspr::ros_bridge {

visualization_msgs::MarkerArray MazeMarkers(const sim::MazeMap& map, const Eigen::Vector2d& goal_xy,
                                            double success_radius,
                                            const std::deque<Eigen::Vector2d>& recent,
                                            const std::string& frame, const ros::Time& stamp) {
  visualization_msgs::MarkerArray arr;
  auto base = [&](const std::string& ns, int type) {
    visualization_msgs::Marker m;
    m.header.stamp = stamp;
    m.header.frame_id = frame;
    m.ns = ns;
    m.id = 0;
    m.type = type;
    m.action = visualization_msgs::Marker::ADD;
    m.pose.orientation.w = 1.0;
    m.color.a = 1.0;
    return m;
  };
  // Walls: one cube per wall cell, as the MuJoCo scene's blocks.
  visualization_msgs::Marker walls = base("walls", visualization_msgs::Marker::CUBE_LIST);
  walls.scale.x = walls.scale.y = sim::kCellSize;
  walls.scale.z = sim::kWallHeight;
  walls.color.r = walls.color.g = walls.color.b = 0.35f;
  for (int i = 0; i < map.rows(); ++i)
    for (int j = 0; j < map.cols(); ++j)
      if (map.IsWall({i, j})) {
        const Eigen::Vector2d c = map.CellCenter({i, j});
        geometry_msgs::Point p;
        p.x = c.x();
        p.y = c.y();
        p.z = sim::kWallHeight / 2;
        walls.points.push_back(p);
      }
  arr.markers.push_back(walls);
  // Goal: a disc of the success radius on the floor.
  visualization_msgs::Marker goal = base("goal", visualization_msgs::Marker::CYLINDER);
  goal.pose.position.x = goal_xy.x();
  goal.pose.position.y = goal_xy.y();
  goal.pose.position.z = 0.1;
  goal.scale.x = goal.scale.y = 2 * success_radius;
  goal.scale.z = 0.1;
  goal.color.r = 1.0f;  // magenta: apart from the value colours and the red agent
  goal.color.g = 0.15f;
  goal.color.b = 0.85f;
  goal.color.a = 1.0f;  // opaque: transparent markers (value maps) do not wash it out
  arr.markers.push_back(goal);
  // The agent's recent path (this episode).
  visualization_msgs::Marker path = base("path", visualization_msgs::Marker::LINE_STRIP);
  path.scale.x = 0.15;
  path.color.r = 0.15f;
  path.color.g = 0.35f;
  path.color.b = 0.9f;
  for (const auto& q : recent) {
    geometry_msgs::Point p;
    p.x = q.x();
    p.y = q.y();
    p.z = 0.1;
    path.points.push_back(p);
  }
  if (path.points.size() < 2) path.action = visualization_msgs::Marker::DELETE;
  arr.markers.push_back(path);
  return arr;
}

void MazeMarkerPublisher::Advertise(ros::NodeHandle& nh, double marker_rate, int path_length,
                                    Make make) {
  pub_ = nh.advertise<visualization_msgs::MarkerArray>("markers", 1, /*latch=*/true);
  rate_ = marker_rate;
  path_length_ = path_length;
  make_ = std::move(make);
}

void MazeMarkerPublisher::Update(const Eigen::Vector2d& xy, const ros::Time& stamp) {
  if (!pub_) return;
  path_.push_back(xy);
  while (static_cast<int>(path_.size()) > path_length_) path_.pop_front();
  stamp_ = stamp;
  dirty_ = true;
  MaybePublish(due_);
  due_ = false;
}

void MazeMarkerPublisher::MaybePublish(bool now_anyway) {
  if (!pub_ || !dirty_) return;
  const ros::WallTime now = ros::WallTime::now();
  if (!now_anyway && (now - last_).toSec() < 1.0 / rate_) return;
  pub_.publish(make_(path_, stamp_));
  dirty_ = false;
  last_ = now;
}

}  // namespace msspr::ros_bridge
