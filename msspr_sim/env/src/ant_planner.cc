#include "msspr_sim/ant_planner.h"

#include <array>

namespace msspr::sim {
namespace {

// OGBench's neighbour order: (-1, 0), (0, -1), (1, 0), (0, 1).
constexpr std::array<std::array<int, 2>, 4> kNeighbours = {{{-1, 0}, {0, -1}, {1, 0}, {0, 1}}};
constexpr double kOffset = 1.5 * kCellSize;  // 6 m: offset + half a cell

}  // namespace

AntPlanner::AntPlanner(const MazeMap& map) : map_(&map) {}

Cell AntPlanner::XYToCell(const Eigen::Vector2d& xy) {
  return {static_cast<int>((xy.y() + kOffset) / kCellSize),
          static_cast<int>((xy.x() + kOffset) / kCellSize)};
}

Eigen::Vector2d AntPlanner::Subgoal(const Eigen::Vector2d& xy, const Eigen::Vector2d& goal_xy) {
  const Cell here = XYToCell(xy);
  const Cell goal = XYToCell(goal_xy);
  if (goal != cached_goal_ || dist_.empty()) {
    dist_ = map_->BfsDistances(goal);  // -1 for walls, unreachable cells, or a wall goal
    cached_goal_ = goal;
  }
  const auto dist = [this](Cell c) {
    return map_->IsWall(c) ? -1 : dist_[static_cast<size_t>(c.i) * map_->cols() + c.j];
  };
  Cell best = here;
  // OGBench's BFS map holds -1 on walls; a torso in a wall cell (or outside
  // the map) therefore has no lower neighbour and keeps its own cell.
  int best_dist = dist(here);
  for (const auto& n : kNeighbours) {
    const Cell c{here.i + n[0], here.j + n[1]};
    if (map_->IsWall(c)) continue;
    if (dist(c) < best_dist) {
      best = c;
      best_dist = dist(c);
    }
  }
  return map_->CellCenter(best);
}

Eigen::Vector2d AntPlanner::Direction(const Eigen::Vector2d& xy, const Eigen::Vector2d& goal_xy) {
  const Eigen::Vector2d d = Subgoal(xy, goal_xy) - xy;
  return d / (d.norm() + 1e-6);
}

}  // namespace msspr::sim
