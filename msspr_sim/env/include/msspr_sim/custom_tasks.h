// Custom evaluation tasks: explicit (start, goal) pairs in metres, beside the
// maze's five official tasks. One YAML format is shared by msspr_eval
// --tasks-file, msspr_train --eval-tasks-file and msspr_make_tasks:
//
//   maze: medium            # optional; checked against the maze in use
//   tasks:
//     - {id: 1, start: [0.0, 0.0], goal: [8.0, 0.0]}
//
// A custom task's episodes start exactly at `start` (no reset noise), as the
// sim node's reset service does for an explicit start.
#ifndef MSSPR_SIM_CUSTOM_TASKS_H_
#define MSSPR_SIM_CUSTOM_TASKS_H_

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "msspr_sim/maze_map.h"

namespace msspr::sim {

struct CustomTask {
  int id = 0;
  Eigen::Vector2d start = Eigen::Vector2d::Zero(), goal = Eigen::Vector2d::Zero();
};

// Reads a tasks file. With a map, also checks that the file's maze: (when
// given) names it and that every start and goal lies in a free cell. Throws
// std::runtime_error naming the file, the task and what is wrong.
std::vector<CustomTask> LoadCustomTasks(const std::string& path, const MazeMap* map = nullptr);

// n tasks whose start and goal are the centres of two distinct free cells
// drawn uniformly at random, plus U[-noise, noise] per axis (clamped so that
// both stay inside their cells); deterministic for (map, n, seed). Pairs are
// at least min_cells BFS moves apart (1 = any two distinct cells). Ids are
// 1..n. Throws std::invalid_argument when no pair is that far apart.
std::vector<CustomTask> RandomCustomTasks(const MazeMap& map, int n, uint64_t seed,
                                          int min_cells = 1, double noise = 1.0);

// The YAML text of a tasks file (with maze: and a comment line per task giving
// the cells and their BFS distance).
std::string CustomTasksYaml(const MazeMap& map, const std::vector<CustomTask>& tasks,
                            const std::string& header_comment = "");

}  // namespace msspr::sim

#endif  // MSSPR_SIM_CUSTOM_TASKS_H_
