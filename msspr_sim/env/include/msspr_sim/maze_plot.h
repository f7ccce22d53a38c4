// Top-down pictures of a maze with trajectories drawn on it (OpenCV).
#ifndef MSSPR_SIM_MAZE_PLOT_H_
#define MSSPR_SIM_MAZE_PLOT_H_

#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

#include "msspr_sim/maze_map.h"

namespace msspr::sim {

// Draws the maze (walls dark grey, free cells light), each trajectory as a
// polyline (green if success[k], red otherwise; blue if success is shorter
// than trajectories), start_goals[k] as a circle (start) and a cross (goal),
// and writes a PNG. pixels_per_cell sets the resolution. Throws
// std::runtime_error naming the path if it cannot be written.
void SaveTrajectoryPlot(const MazeMap& map,
                        const std::vector<std::vector<Eigen::Vector2d>>& trajectories,
                        const std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>>& start_goals,
                        const std::vector<bool>& success, const std::string& png_path,
                        int pixels_per_cell = 40);

}  // namespace msspr::sim

#endif  // MSSPR_SIM_MAZE_PLOT_H_
