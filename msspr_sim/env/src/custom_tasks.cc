#include "msspr_sim/custom_tasks.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <set>
#include <sstream>
#include <stdexcept>

#include "msspr_sim/random_util.h"

namespace msspr::sim {

namespace {

Eigen::Vector2d ReadPoint(const YAML::Node& node, const std::string& where) {
  std::vector<double> v;
  try {
    v = node.as<std::vector<double>>();
  } catch (const std::exception&) {
    throw std::runtime_error(where + " must be a list of 2 numbers");
  }
  if (v.size() != 2 || !std::isfinite(v[0]) || !std::isfinite(v[1]))
    throw std::runtime_error(where + " must be 2 finite numbers (x, y in metres)");
  return Eigen::Vector2d(v[0], v[1]);
}

std::string Fixed3(double x) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.3f", x);
  return buf;
}

}  // namespace

std::vector<CustomTask> LoadCustomTasks(const std::string& path, const MazeMap* map) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const std::exception& e) {
    throw std::runtime_error(path + ": " + e.what());
  }
  if (!root.IsMap()) throw std::runtime_error(path + ": expected a map with a list 'tasks'");
  for (const auto& kv : root) {
    const std::string k = kv.first.as<std::string>();
    if (k != "tasks" && k != "maze")
      throw std::runtime_error(path + ": unknown key '" + k + "' (expected maze, tasks)");
  }
  if (map && root["maze"]) {
    const std::string maze = root["maze"].as<std::string>();
    if (maze != map->name())
      throw std::runtime_error(path + ": the tasks are for maze '" + maze + "', not '" +
                               map->name() + "'");
  }
  if (!root["tasks"] || !root["tasks"].IsSequence() || root["tasks"].size() == 0)
    throw std::runtime_error(path + ": needs a non-empty list 'tasks'");
  std::vector<CustomTask> out;
  std::set<int> ids;
  for (const auto& t : root["tasks"]) {
    if (!t.IsMap()) throw std::runtime_error(path + ": every task must be a map {id, start, goal}");
    for (const auto& kv : t) {
      const std::string k = kv.first.as<std::string>();
      if (k != "id" && k != "start" && k != "goal")
        throw std::runtime_error(path + ": unknown key '" + k +
                                 "' in a task (expected id, start, goal)");
    }
    if (!t["id"] || !t["start"] || !t["goal"])
      throw std::runtime_error(path + ": every task needs id, start and goal");
    CustomTask task;
    try {
      task.id = t["id"].as<int>();
    } catch (const std::exception&) {
      throw std::runtime_error(path + ": a task id must be an integer");
    }
    const std::string where = path + ": task " + std::to_string(task.id);
    task.start = ReadPoint(t["start"], where + ": start");
    task.goal = ReadPoint(t["goal"], where + ": goal");
    if (!ids.insert(task.id).second)
      throw std::runtime_error(path + ": task id " + std::to_string(task.id) + " appears twice");
    if (map) {
      for (const auto& [name, p] :
           {std::make_pair("start", task.start), std::make_pair("goal", task.goal)})
        if (map->IsWall(map->XYToCell(p)))
          throw std::runtime_error(where + ": " + name + " (" + Fixed3(p.x()) + ", " +
                                   Fixed3(p.y()) + ") is inside a wall of maze " + map->name());
    }
    out.push_back(task);
  }
  return out;
}

std::vector<CustomTask> RandomCustomTasks(const MazeMap& map, int n, uint64_t seed, int min_cells,
                                          double noise) {
  if (n < 1) throw std::invalid_argument("RandomCustomTasks: n must be at least 1");
  if (min_cells < 1) throw std::invalid_argument("RandomCustomTasks: min_cells must be at least 1");
  if (!(noise >= 0.0) || noise > kCellSize / 2)
    throw std::invalid_argument("RandomCustomTasks: noise must be in [0, " + Fixed3(kCellSize / 2) +
                                "] metres");
  const auto free = map.FreeCells();
  // Ordered pairs of free cells at least min_cells moves apart.
  std::vector<std::pair<Cell, Cell>> pairs;
  for (const Cell& a : free) {
    const auto dist = map.BfsDistances(a);
    for (const Cell& b : free) {
      const int d = dist[static_cast<size_t>(b.i * map.cols() + b.j)];
      if (d >= min_cells) pairs.emplace_back(a, b);
    }
  }
  if (pairs.empty())
    throw std::invalid_argument("RandomCustomTasks: maze " + map.name() +
                                " has no two free cells " + std::to_string(min_cells) +
                                " or more moves apart");
  std::mt19937_64 rng(Mix64(seed ^ 0x7A5C5EEDULL));
  // Keep the point off the walls: the agent's sphere has radius kAgentRadius.
  const double lim = std::min(noise, kCellSize / 2 - kAgentRadius);
  std::vector<CustomTask> out;
  for (int k = 0; k < n; ++k) {
    const auto& [a, b] = pairs[UniformIndex(rng, pairs.size())];
    CustomTask t;
    t.id = k + 1;
    t.start = map.CellCenter(a);
    t.goal = map.CellCenter(b);
    for (int d = 0; d < 2; ++d) t.start[d] += Uniform(rng, -lim, lim);
    for (int d = 0; d < 2; ++d) t.goal[d] += Uniform(rng, -lim, lim);
    // Millimetres, as the YAML file keeps them: in process and from the file alike.
    for (int d = 0; d < 2; ++d) {
      t.start[d] = std::round(t.start[d] * 1000.0) / 1000.0;
      t.goal[d] = std::round(t.goal[d] * 1000.0) / 1000.0;
    }
    out.push_back(t);
  }
  return out;
}

std::string CustomTasksYaml(const MazeMap& map, const std::vector<CustomTask>& tasks,
                            const std::string& header_comment) {
  std::ostringstream os;
  if (!header_comment.empty()) {
    std::istringstream lines(header_comment);
    std::string line;
    while (std::getline(lines, line)) os << "# " << line << "\n";
  }
  os << "maze: " << map.name() << "\n";
  os << "tasks:\n";
  for (const auto& t : tasks) {
    const Cell a = map.XYToCell(t.start), b = map.XYToCell(t.goal);
    os << "  - {id: " << t.id << ", start: [" << Fixed3(t.start.x()) << ", " << Fixed3(t.start.y())
       << "], goal: [" << Fixed3(t.goal.x()) << ", " << Fixed3(t.goal.y()) << "]}  # cell (" << a.i
       << "," << a.j << ") -> (" << b.i << "," << b.j << "), " << map.BfsDistance(a, b)
       << " moves\n";
  }
  return os.str();
}

}  // namespace msspr::sim
