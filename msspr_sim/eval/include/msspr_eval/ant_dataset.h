// OGBench's ant-maze datasets (data_gen_scripts/generate_locomaze.py) with the
// waypoint expert (ant_waypoint_expert.h): antmaze-{medium,large}-navigate and
// -stitch episodes in memory, and their .npz export (OGBench's keys, qpos and
// qvel kept).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "msspr_core/sac.h"
#include "msspr_sim/ant_maze.h"
#include "msspr_sim/expert.h"
#include "msspr_sim/maze_map.h"

namespace msspr::agent {

struct AntCollectOptions {
  sim::DatasetKind kind = sim::DatasetKind::kNavigate;
  int episode_length = 1001;  // rows per episode (OGBench: navigate 1001, stitch 201)
  double noise_std = 0.2;     // the expert's action noise (OGBench: 0.2)
  uint64_t seed = 0;          // base seed; episode k uses sim::EpisodeSeed(seed, k)
};

// OGBench's stitch goal: a cell exactly `steps` BFS moves from `start`, drawn
// uniformly among all such cells; `start` itself when there is none.
sim::Cell StitchGoalCell(const sim::MazeMap& map, sim::Cell start, std::mt19937_64& rng,
                         int steps = 4);

// One episode; row t holds the state before action t.
struct AntEpisode {
  uint64_t index = 0, seed = 0;
  int length = 0;
  std::vector<float> observations;  // [length, 29] float32: qpos then qvel
  // [length, 8] float32 in [-1, 1]: the noisy, clipped action; stepped with
  // exactly the stored value, but for the last row's (OGBench's last row is terminal).
  std::vector<float> actions;
  std::vector<double> qpos, qvel;   // [length, 15], [length, 14] (the rows' exact state)
  Eigen::VectorXd goal;             // the episode's first goal: the env's full 29-D goal state
  sim::Cell start_cell, goal_cell;  // the cells drawn at the reset
  // Every goal in force: the row it took effect from (0 for the first), its
  // cell and its xy. navigate: a new vertex goal each time the torso comes
  // within the success radius of the current one; stitch: one goal.
  std::vector<int> goal_rows;
  std::vector<sim::Cell> goal_cells;
  std::vector<Eigen::Vector2d> goal_xys;
};

// Collects episode `index` as generate_locomaze.py does: a start cell uniform
// over the free cells; the goal cell uniform over the vertex cells
// (navigate) or StitchGoalCell (stitch); start and goal xy the cells' centres
// + U[-1, 1] per axis; env.Reset(start, goal, .). Each row: the expert
// (AntWaypointExpert with options.noise_std) acts toward the current goal xy;
// navigate draws a new vertex goal (centre + the same noise) after a step
// that ends within env.options().success_radius of the goal. A function of
// (options, index) and the policy. Throws std::invalid_argument if
// episode_length < 1.
AntEpisode CollectAntEpisode(sim::AntMaze& env, core::SacPolicy& policy,
                             const AntCollectOptions& options, uint64_t index);

// Writes episodes as an OGBench-style .npz: observations [N, 29], actions
// [N, 8], terminals [N] (1 on each episode's last row), qpos [N, 15], qvel
// [N, 14], all float32; stored (uncompressed) unless compress. Written to a
// temporary file and renamed. Throws std::runtime_error naming the file.
void SaveAntNpz(const std::vector<const AntEpisode*>& episodes, const std::string& path,
                bool compress = false);

}  // namespace msspr::agent
