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

// How SaveScalarFieldPlot colours values.
enum class ColorScale {
  kSequential,  // viridis from lo (dark) to hi (yellow)
  kDiverging,   // blue (lo) - white (0) - red (hi), for signed errors; lo = -hi
};

// A heatmap over the maze: each values[k] paints a square of side patch_m
// metres centred at points[k], over the maze's walls (dark grey) and free
// cells (light grey); a marker at `goal`; a colour bar with lo and hi on the
// right and `title` above. Values outside [lo, hi] are clipped. Throws
// std::invalid_argument on mismatched sizes or lo >= hi, std::runtime_error
// naming the path if it cannot be written.
void SaveScalarFieldPlot(const MazeMap& map, const std::vector<Eigen::Vector2d>& points,
                         const std::vector<double>& values, double patch_m, double lo, double hi,
                         ColorScale scale, const Eigen::Vector2d& goal, const std::string& title,
                         const std::string& png_path, int pixels_per_cell = 48);

}  // namespace msspr::sim

#endif  // MSSPR_SIM_MAZE_PLOT_H_
