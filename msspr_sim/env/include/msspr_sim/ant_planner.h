// OGBench's waypoint planner for the ant mazes (locomaze/maze.py
// get_oracle_subgoal, as data_gen_scripts/generate_locomaze.py uses it): BFS
// from the goal's cell over 4-neighbours; the subgoal is the centre of the
// free neighbour with the lowest BFS value, or of the current cell when none
// is lower; the expert is given the unit direction toward the subgoal.
#ifndef MSSPR_SIM_ANT_PLANNER_H_
#define MSSPR_SIM_ANT_PLANNER_H_

#include <Eigen/Core>
#include <vector>

#include "msspr_sim/maze_map.h"

namespace msspr::sim {

class AntPlanner {
 public:
  // Keeps a pointer to `map`, which must outlive the planner.
  explicit AntPlanner(const MazeMap& map);

  // OGBench's cell of a point: i = int((y + 6) / 4), j = int((x + 6) / 4)
  // (truncation toward zero, as Python's int()).
  static Cell XYToCell(const Eigen::Vector2d& xy);

  // The subgoal for a torso at xy heading to goal_xy: the centre of the
  // 4-neighbour of xy's cell (scanned up, left, down, right, as OGBench; the
  // first strictly lowest wins) whose BFS distance to goal_xy's cell is lower
  // than the current cell's, else the current cell's centre. BFS distances
  // are cached for the last goal cell. Cells outside the map count as walls.
  Eigen::Vector2d Subgoal(const Eigen::Vector2d& xy, const Eigen::Vector2d& goal_xy);
  // (subgoal - xy) / (|subgoal - xy| + 1e-6).
  Eigen::Vector2d Direction(const Eigen::Vector2d& xy, const Eigen::Vector2d& goal_xy);

  const MazeMap& map() const { return *map_; }

 private:
  const MazeMap* map_;
  Cell cached_goal_{-1, -1};
  std::vector<int> dist_;  // BFS distances to cached_goal_ (MazeMap::BfsDistances)
};

}  // namespace msspr::sim

#endif  // MSSPR_SIM_ANT_PLANNER_H_
