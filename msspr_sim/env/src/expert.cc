#include "msspr_sim/expert.h"

#include <algorithm>
#include <stdexcept>
#include <vector>

#include "msspr_sim/random_util.h"

namespace msspr::sim {
namespace {

// Distance to the goal cell's centre at which the navigate expert counts its
// goal as reached (the evaluation success radius).
constexpr double kGoalReachedRadius = 1.0;
// BFS distance of the stitch goal from the start cell.
constexpr int kStitchDistance = 4;
// Salt so the expert's stream differs from env.ResetRandom(episode_seed).
constexpr uint64_t kExpertSalt = 0x5EED0E7BE27ULL;

Eigen::Vector2d NoisyClipped(const Eigen::Vector2d& dir, double noise_std, std::mt19937_64& rng) {
  Eigen::Vector2d a = dir;
  if (noise_std > 0.0) {
    for (int k = 0; k < 2; ++k) a[k] += noise_std * StandardNormal(rng);
  }
  return a.cwiseMax(-1.0).cwiseMin(1.0);
}

Eigen::Vector2d UnitToward(const Eigen::Vector2d& from, const Eigen::Vector2d& to) {
  const Eigen::Vector2d d = to - from;
  const double n = d.norm();
  return n > 1e-12 ? Eigen::Vector2d(d / n) : Eigen::Vector2d::Zero();
}

}  // namespace

uint64_t EpisodeSeed(uint64_t base_seed, uint64_t episode_index) {
  return Mix64(Mix64(base_seed) ^ (episode_index * 0xD1B54A32D192ED03ULL));
}

Eigen::Vector2d BfsDirection(const MazeMap& map, const Eigen::Vector2d& state, Cell goal_cell,
                             const Eigen::Vector2d& goal_point) {
  const Cell here = map.XYToCell(state);
  if (here == goal_cell) return UnitToward(state, goal_point);
  const std::vector<Cell> path = map.ShortestPath(here, goal_cell);
  if (path.size() < 2) return Eigen::Vector2d::Zero();
  return UnitToward(state, map.CellCenter(path[1]));
}

GoalExpert::GoalExpert(const MazeMap& map, double noise_std, uint64_t seed)
    : map_(&map), noise_std_(noise_std), rng_(seed) {
  if (!(noise_std >= 0.0)) throw std::invalid_argument("GoalExpert: noise_std must be >= 0");
}

Eigen::Vector2d GoalExpert::Act(const Eigen::Vector2d& state, const Eigen::Vector2d& goal) {
  const Eigen::Vector2d dir = BfsDirection(*map_, state, map_->XYToCell(goal), goal);
  return NoisyClipped(dir, noise_std_, rng_);
}

DatasetKind ParseDatasetKind(const std::string& name) {
  if (name == "navigate") return DatasetKind::kNavigate;
  if (name == "stitch") return DatasetKind::kStitch;
  throw std::invalid_argument("unknown dataset kind '" + name + "'; valid: navigate stitch");
}

std::string DatasetKindName(DatasetKind kind) {
  return kind == DatasetKind::kNavigate ? "navigate" : "stitch";
}

CollectionExpert::CollectionExpert(const MazeMap& map, DatasetKind kind, double noise_std,
                                   uint64_t episode_seed)
    : map_(&map), kind_(kind), noise_std_(noise_std), rng_(Mix64(episode_seed ^ kExpertSalt)) {
  if (!(noise_std >= 0.0)) throw std::invalid_argument("CollectionExpert: noise_std must be >= 0");
}

void CollectionExpert::DrawGoal(const Eigen::Vector2d& state) {
  if (kind_ == DatasetKind::kNavigate) {
    const std::vector<Cell> vertices = map_->VertexCells();
    goal_cell_ = vertices[UniformIndex(rng_, vertices.size())];
  } else {
    const Cell here = map_->XYToCell(state);
    const std::vector<int> dist = map_->BfsDistances(here);
    std::vector<Cell> candidates;
    for (const Cell& c : map_->FreeCells()) {
      if (dist[static_cast<size_t>(c.i) * map_->cols() + c.j] == kStitchDistance) {
        candidates.push_back(c);
      }
    }
    if (candidates.empty()) {
      // Only in components smaller than the stitch distance (none in our maps):
      // fall back to the farthest reachable cell.
      Cell best = here;
      int best_d = 0;
      for (const Cell& c : map_->FreeCells()) {
        const int d = dist[static_cast<size_t>(c.i) * map_->cols() + c.j];
        if (d > best_d) best = c, best_d = d;
      }
      candidates.push_back(best);
    }
    goal_cell_ = candidates[UniformIndex(rng_, candidates.size())];
  }
  has_goal_ = true;
  ++num_goals_;
}

Eigen::Vector2d CollectionExpert::Act(const Eigen::Vector2d& state) {
  if (!has_goal_) DrawGoal(state);
  if (kind_ == DatasetKind::kNavigate &&
      (state - map_->CellCenter(goal_cell_)).norm() <= kGoalReachedRadius) {
    DrawGoal(state);
  }
  const Eigen::Vector2d dir = BfsDirection(*map_, state, goal_cell_, map_->CellCenter(goal_cell_));
  return NoisyClipped(dir, noise_std_, rng_);
}

}  // namespace msspr::sim
