// OGBench's point-maze maps (docs/datasets.md): wall grids, cell geometry, BFS over
// the free-cell graph, the evaluation tasks, and the MJCF of the scene.
#ifndef MSSPR_SIM_MAZE_MAP_H_
#define MSSPR_SIM_MAZE_MAP_H_

#include <Eigen/Core>
#include <string>
#include <vector>

namespace msspr::sim {

// Row i (top to bottom), column j.
struct Cell {
  int i = 0, j = 0;
};
inline bool operator==(Cell a, Cell b) { return a.i == b.i && a.j == b.j; }
inline bool operator!=(Cell a, Cell b) { return !(a == b); }

// Size of one maze cell (and of one wall block) in metres.
inline constexpr double kCellSize = 4.0;
// Height of the wall blocks in metres.
inline constexpr double kWallHeight = 2.0;
// Radius of the agent's sphere in metres.
inline constexpr double kAgentRadius = 0.7;

class MazeMap {
 public:
  // The map named "arena", "medium", "large" or "giant"; throws
  // std::invalid_argument naming the bad name and the valid ones.
  static MazeMap FromName(const std::string& name);
  // The valid names, in the order above.
  static std::vector<std::string> Names();

  const std::string& name() const { return name_; }
  int rows() const { return rows_; }
  int cols() const { return cols_; }

  // True for a wall cell; cells outside the map count as wall.
  bool IsWall(Cell c) const;
  // Centre of cell c in world coordinates: x = 4j - 4, y = 4i - 4.
  Eigen::Vector2d CellCenter(Cell c) const;
  // The cell whose centre is nearest to xy (may lie outside the map).
  Cell XYToCell(const Eigen::Vector2d& xy) const;
  // All free cells, row-major order.
  std::vector<Cell> FreeCells() const;
  // Free cells that are not straight hallway cells (a hallway cell has exactly
  // two free 4-neighbours, opposite each other), row-major order.
  std::vector<Cell> VertexCells() const;
  // A shortest 4-connected path over free cells, both ends included; empty if
  // either end is a wall or `to` is unreachable. Deterministic tie-breaking.
  std::vector<Cell> ShortestPath(Cell from, Cell to) const;
  // Number of moves of a shortest path, -1 if unreachable (or a wall end).
  int BfsDistance(Cell from, Cell to) const;
  // BFS distances from `from` to every cell, [rows * cols] row-major, -1 for
  // walls and unreachable cells.
  std::vector<int> BfsDistances(Cell from) const;

  struct Task {
    int id;
    Cell start;
    Cell goal;
  };
  // The 5 evaluation tasks, ids 1..5 (OGBench's for medium, large, giant;
  // this project's own corner-to-corner tasks for arena).
  const std::vector<Task>& Tasks() const { return tasks_; }
  // The task of id `id`; throws std::invalid_argument "<caller>: no task <id>
  // in maze <name> (valid: 1..<n>)".
  const Task& TaskById(int id, const std::string& caller) const;

  // The full MJCF of the maze: walls, the agent (sphere on two slide joints,
  // joints "agent_x", "agent_y"), floor tiles coloured by a position gradient,
  // and the tracking camera "track"; offscreen buffer >= image_size.
  // With visuals = false: the physics-only model (no floor tiles, no wall
  // blocks that touch no free cell), whose dynamics are identical and about
  // twice as fast to step.
  std::string ToMjcf(int image_size = 64, bool visuals = true) const;

 private:
  MazeMap(std::string name, std::vector<std::string> rows, std::vector<Task> tasks);
  int Index(Cell c) const { return c.i * cols_ + c.j; }

  std::string name_;
  int rows_ = 0, cols_ = 0;
  std::vector<bool> wall_;  // [rows * cols] row-major
  std::vector<Task> tasks_;
};

}  // namespace msspr::sim

#endif  // MSSPR_SIM_MAZE_MAP_H_
