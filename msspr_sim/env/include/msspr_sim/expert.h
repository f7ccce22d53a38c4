// OGBench's scripted point-maze experts: the BFS goal-reaching expert and the
// navigate / stitch data-collection procedures.
#ifndef MSSPR_SIM_EXPERT_H_
#define MSSPR_SIM_EXPERT_H_

#include <Eigen/Core>
#include <cstdint>
#include <random>
#include <string>

#include "msspr_sim/maze_map.h"

namespace msspr::sim {

// Seed of episode `episode_index` of a run with `base_seed` (splitmix64
// mixing). Used by the collector and by the ROS sim node for its auto-resets,
// so a live recording equals the direct writer.
uint64_t EpisodeSeed(uint64_t base_seed, uint64_t episode_index);

// The unit vector from `state` toward the centre of the next BFS cell on the
// way to `goal_cell` (toward `goal_point` itself once in the goal cell);
// zero if the state's cell is a wall or the goal is unreachable.
Eigen::Vector2d BfsDirection(const MazeMap& map, const Eigen::Vector2d& state, Cell goal_cell,
                             const Eigen::Vector2d& goal_point);

// BFS expert toward a given goal state, with optional Gaussian action noise.
class GoalExpert {
 public:
  explicit GoalExpert(const MazeMap& map, double noise_std = 0.0, uint64_t seed = 0);
  // BfsDirection toward goal's cell / goal point, + N(0, noise_std) per axis,
  // clipped to [-1,1].
  Eigen::Vector2d Act(const Eigen::Vector2d& state, const Eigen::Vector2d& goal);

 private:
  const MazeMap* map_;
  double noise_std_;
  std::mt19937_64 rng_;
};

enum class DatasetKind { kNavigate, kStitch };
// "navigate" or "stitch"; throws std::invalid_argument otherwise.
DatasetKind ParseDatasetKind(const std::string& name);
std::string DatasetKindName(DatasetKind kind);

// OGBench's point-maze data-collection procedure, one instance per episode.
// navigate: its own uniformly drawn vertex goal cell, redrawn when reached
// (state within 1.0 of the goal cell centre). stitch: a goal cell exactly 4
// BFS steps from the cell of the first state it sees, and it stays there
// once arrived (the noisy expert keeps steering to the goal centre).
class CollectionExpert {
 public:
  CollectionExpert(const MazeMap& map, DatasetKind kind, double noise_std, uint64_t episode_seed);
  // Unit BFS direction + N(0, noise_std) noise, clipped to [-1,1].
  Eigen::Vector2d Act(const Eigen::Vector2d& state);
  // The current goal cell (valid after the first Act).
  Cell goal_cell() const { return goal_cell_; }
  // Number of goals drawn so far.
  int num_goals() const { return num_goals_; }

 private:
  void DrawGoal(const Eigen::Vector2d& state);

  const MazeMap* map_;
  DatasetKind kind_;
  double noise_std_;
  std::mt19937_64 rng_;
  bool has_goal_ = false;
  Cell goal_cell_;
  int num_goals_ = 0;
};

}  // namespace msspr::sim

#endif  // MSSPR_SIM_EXPERT_H_
