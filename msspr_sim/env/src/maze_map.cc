#include "msspr_sim/maze_map.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <deque>
#include <sstream>
#include <stdexcept>

namespace msspr::sim {
namespace {

struct MapSpec {
  const char* name;
  std::vector<std::string> rows;
  std::vector<MazeMap::Task> tasks;
};

const std::vector<MapSpec>& Specs() {
  static const std::vector<MapSpec> specs = {
      // OGBench's open arena. The tasks are this project's own (OGBench has
      // no arena evaluation tasks): the two diagonals both ways and one side.
      {"arena",
       {"11111111", "10000001", "10000001", "10000001", "10000001", "10000001", "10000001",
        "11111111"},
       {{1, {1, 1}, {6, 6}},
        {2, {6, 1}, {1, 6}},
        {3, {6, 6}, {1, 1}},
        {4, {1, 6}, {6, 1}},
        {5, {1, 1}, {6, 1}}}},
      {"medium",
       {"11111111", "10011001", "10010001", "11000111", "10010001", "10100101", "10001001",
        "11111111"},
       {{1, {1, 1}, {6, 6}},
        {2, {6, 1}, {1, 6}},
        {3, {5, 3}, {4, 2}},
        {4, {6, 5}, {6, 1}},
        {5, {2, 6}, {1, 1}}}},
      {"large",
       {"111111111111", "100001000001", "101101010101", "100000010001", "101111011101",
        "100101000001", "110101010111", "100100010001", "111111111111"},
       {{1, {1, 1}, {7, 10}},
        {2, {5, 4}, {7, 1}},
        {3, {7, 4}, {1, 10}},
        {4, {3, 8}, {5, 4}},
        {5, {1, 1}, {5, 4}}}},
      {"giant",
       {"1111111111111111", "1010000001100001", "1010110101001101", "1000100100010001",
        "1011101111110101", "1000100010000101", "1110101001010111", "1000100100010001",
        "1010101111110101", "1011100010001101", "1000001000100001", "1111111111111111"},
       {{1, {1, 1}, {10, 14}},
        {2, {1, 14}, {10, 1}},
        {3, {8, 14}, {1, 1}},
        {4, {8, 3}, {5, 12}},
        {5, {5, 9}, {3, 8}}}},
  };
  return specs;
}

constexpr std::array<std::array<int, 2>, 4> kMoves = {{{-1, 0}, {1, 0}, {0, -1}, {0, 1}}};

std::string Format4g(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.4g", v);
  return buf;
}

}  // namespace

MazeMap::MazeMap(std::string name, std::vector<std::string> rows, std::vector<Task> tasks)
    : name_(std::move(name)),
      rows_(static_cast<int>(rows.size())),
      cols_(static_cast<int>(rows.at(0).size())),
      tasks_(std::move(tasks)) {
  wall_.resize(static_cast<size_t>(rows_) * cols_);
  for (int i = 0; i < rows_; ++i) {
    if (static_cast<int>(rows[i].size()) != cols_) {
      throw std::logic_error("MazeMap " + name_ + ": ragged row " + std::to_string(i));
    }
    for (int j = 0; j < cols_; ++j) wall_[Index({i, j})] = rows[i][j] == '1';
  }
  for (const Task& t : tasks_) {
    if (IsWall(t.start) || IsWall(t.goal)) {
      throw std::logic_error("MazeMap " + name_ + ": task " + std::to_string(t.id) +
                             " starts or ends in a wall");
    }
  }
}

MazeMap MazeMap::FromName(const std::string& name) {
  for (const MapSpec& s : Specs()) {
    if (name == s.name) return MazeMap(s.name, s.rows, s.tasks);
  }
  std::ostringstream msg;
  msg << "unknown maze name '" << name << "'; valid names:";
  for (const std::string& n : Names()) msg << ' ' << n;
  throw std::invalid_argument(msg.str());
}

const MazeMap::Task& MazeMap::TaskById(int id, const std::string& caller) const {
  const auto it =
      std::find_if(tasks_.begin(), tasks_.end(), [id](const Task& t) { return t.id == id; });
  if (it == tasks_.end()) {
    throw std::invalid_argument(caller + ": no task " + std::to_string(id) + " in maze " + name_ +
                                " (valid: 1.." + std::to_string(tasks_.size()) + ")");
  }
  return *it;
}

std::vector<std::string> MazeMap::Names() {
  std::vector<std::string> names;
  for (const MapSpec& s : Specs()) names.emplace_back(s.name);
  return names;
}

bool MazeMap::IsWall(Cell c) const {
  if (c.i < 0 || c.j < 0 || c.i >= rows_ || c.j >= cols_) return true;
  return wall_[Index(c)];
}

Eigen::Vector2d MazeMap::CellCenter(Cell c) const {
  return {kCellSize * c.j - kCellSize, kCellSize * c.i - kCellSize};
}

Cell MazeMap::XYToCell(const Eigen::Vector2d& xy) const {
  return {static_cast<int>(std::lround(xy.y() / kCellSize + 1.0)),
          static_cast<int>(std::lround(xy.x() / kCellSize + 1.0))};
}

std::vector<Cell> MazeMap::FreeCells() const {
  std::vector<Cell> cells;
  for (int i = 0; i < rows_; ++i) {
    for (int j = 0; j < cols_; ++j) {
      if (!IsWall({i, j})) cells.push_back({i, j});
    }
  }
  return cells;
}

std::vector<Cell> MazeMap::VertexCells() const {
  std::vector<Cell> cells;
  for (const Cell& c : FreeCells()) {
    const bool up = !IsWall({c.i - 1, c.j}), down = !IsWall({c.i + 1, c.j});
    const bool left = !IsWall({c.i, c.j - 1}), right = !IsWall({c.i, c.j + 1});
    const int n = up + down + left + right;
    const bool hallway = n == 2 && ((up && down) || (left && right));
    if (!hallway) cells.push_back(c);
  }
  return cells;
}

std::vector<int> MazeMap::BfsDistances(Cell from) const {
  std::vector<int> dist(static_cast<size_t>(rows_) * cols_, -1);
  if (IsWall(from)) return dist;
  std::deque<Cell> queue = {from};
  dist[Index(from)] = 0;
  while (!queue.empty()) {
    const Cell c = queue.front();
    queue.pop_front();
    for (const auto& m : kMoves) {
      const Cell n{c.i + m[0], c.j + m[1]};
      if (IsWall(n) || dist[Index(n)] >= 0) continue;
      dist[Index(n)] = dist[Index(c)] + 1;
      queue.push_back(n);
    }
  }
  return dist;
}

int MazeMap::BfsDistance(Cell from, Cell to) const {
  if (IsWall(from) || IsWall(to)) return -1;
  return BfsDistances(to)[Index(from)];
}

std::vector<Cell> MazeMap::ShortestPath(Cell from, Cell to) const {
  if (IsWall(from) || IsWall(to)) return {};
  // Distances to `to`; walk downhill from `from`, first move of kMoves wins.
  const std::vector<int> dist = BfsDistances(to);
  if (dist[Index(from)] < 0) return {};
  std::vector<Cell> path = {from};
  Cell c = from;
  while (c != to) {
    for (const auto& m : kMoves) {
      const Cell n{c.i + m[0], c.j + m[1]};
      if (!IsWall(n) && dist[Index(n)] == dist[Index(c)] - 1) {
        c = n;
        break;
      }
    }
    path.push_back(c);
  }
  return path;
}

std::string MazeMap::ToMjcf(int image_size, bool visuals) const {
  if (image_size < 1) throw std::invalid_argument("ToMjcf: image_size must be >= 1");
  const int buf = std::max(image_size, 64);
  std::ostringstream x;
  x << "<mujoco model=\"pointmaze_" << name_ << "\">\n"
    << "  <compiler autolimits=\"true\" angle=\"radian\"/>\n"
    << "  <option timestep=\"0.02\" integrator=\"RK4\" gravity=\"0 0 0\"/>\n"
    << "  <visual>\n"
    << "    <global offwidth=\"" << buf << "\" offheight=\"" << buf << "\"/>\n"
    << "    <quality shadowsize=\"0\"/>\n"
    << "    <headlight ambient=\"0.45 0.45 0.45\" diffuse=\"0.4 0.4 0.4\" specular=\"0 0 0\"/>\n"
    << "  </visual>\n"
    << "  <default>\n"
    << "    <joint limited=\"false\" armature=\"0\" damping=\"0\"/>\n"
    << "    <geom condim=\"3\" friction=\"1 0.5 0.5\" margin=\"0\" density=\"100\"/>\n"
    << "    <default class=\"tile\">\n"
    << "      <geom type=\"box\" contype=\"0\" conaffinity=\"0\" group=\"1\"/>\n"
    << "    </default>\n"
    << "  </default>\n"
    << "  <worldbody>\n"
    << "    <light directional=\"true\" castshadow=\"false\" pos=\"0 0 20\" dir=\"0.2 0.3 -1\""
    << " diffuse=\"0.35 0.35 0.35\" specular=\"0 0 0\"/>\n";
  // Floor: 2 x 2 m tiles under every cell, rgba a smooth function of the
  // tile centre (red grows with x, green with y) so the position can be read
  // from pixels.
  const double x_min = -kCellSize * 1.5, x_span = kCellSize * cols_;
  const double y_min = -kCellSize * 1.5, y_span = kCellSize * rows_;
  const double half_tile = kCellSize / 4.0;
  for (int i = 0; i < rows_ && visuals; ++i) {
    for (int j = 0; j < cols_; ++j) {
      if (IsWall({i, j})) continue;
      const Eigen::Vector2d c = CellCenter({i, j});
      for (int di = 0; di < 2; ++di) {
        for (int dj = 0; dj < 2; ++dj) {
          const double tx = c.x() + (dj == 0 ? -half_tile : half_tile);
          const double ty = c.y() + (di == 0 ? -half_tile : half_tile);
          const double u = std::clamp((tx - x_min) / x_span, 0.0, 1.0);
          const double v = std::clamp((ty - y_min) / y_span, 0.0, 1.0);
          x << "    <geom class=\"tile\" pos=\"" << Format4g(tx) << ' ' << Format4g(ty)
            << " -0.05\" size=\"" << Format4g(half_tile) << ' ' << Format4g(half_tile)
            << " 0.05\" rgba=\"" << Format4g(0.15 + 0.8 * u) << ' ' << Format4g(0.15 + 0.8 * v)
            << ' ' << Format4g(0.55 - 0.3 * u * v) << " 1\"/>\n";
        }
      }
    }
  }
  // Walls: 4 x 4 x 2 m blocks (the physics model keeps only those next to
  // a free cell, 8-neighbourhood: the agent cannot reach the others).
  const auto touches_free = [this](int i, int j) {
    for (int di = -1; di <= 1; ++di) {
      for (int dj = -1; dj <= 1; ++dj) {
        if (!IsWall({i + di, j + dj})) return true;
      }
    }
    return false;
  };
  for (int i = 0; i < rows_; ++i) {
    for (int j = 0; j < cols_; ++j) {
      if (!IsWall({i, j}) || (!visuals && !touches_free(i, j))) continue;
      const Eigen::Vector2d c = CellCenter({i, j});
      x << "    <geom name=\"wall_" << i << '_' << j << "\" type=\"box\" pos=\"" << Format4g(c.x())
        << ' ' << Format4g(c.y()) << ' ' << Format4g(kWallHeight / 2) << "\" size=\""
        << Format4g(kCellSize / 2) << ' ' << Format4g(kCellSize / 2) << ' '
        << Format4g(kWallHeight / 2)
        << "\" rgba=\"0.42 0.42 0.46 1\" contype=\"1\" conaffinity=\"1\"/>\n";
    }
  }
  // Agent: a sphere on two slide joints; qpos = (x, y) in world coordinates.
  // The camera tracks the agent's centre of mass from behind (-y) and above.
  x << "    <body name=\"agent\" pos=\"0 0 " << Format4g(kAgentRadius) << "\">\n"
    << "      <joint name=\"agent_x\" type=\"slide\" axis=\"1 0 0\"/>\n"
    << "      <joint name=\"agent_y\" type=\"slide\" axis=\"0 1 0\"/>\n"
    << "      <geom name=\"agent_geom\" type=\"sphere\" size=\"" << Format4g(kAgentRadius)
    << "\" rgba=\"0.1 0.2 1 1\" contype=\"1\" conaffinity=\"1\"/>\n"
    << "      <camera name=\"track\" mode=\"trackcom\" pos=\"0 -5 9\" fovy=\"50\""
    << " xyaxes=\"1 0 0 0 0.874157 0.485643\"/>\n"
    << "    </body>\n"
    << "  </worldbody>\n"
    << "</mujoco>\n";
  return x.str();
}

}  // namespace msspr::sim
