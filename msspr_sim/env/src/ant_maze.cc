#include "msspr_sim/ant_maze.h"

#include <stdexcept>

#include "ant_physics.h"
#include "msspr_sim/random_util.h"

namespace msspr::sim {

struct AntMaze::Impl {
  explicit Impl(const MazeMap& map) : physics(AntMjcf(&map), "antmaze_" + map.name()) {}
  internal::AntPhysics physics;
};

AntMaze::AntMaze(const AntMazeOptions& options)
    : options_(options), map_(MazeMap::FromName(options.maze)) {
  if (options_.max_episode_steps < 1) {
    throw std::invalid_argument("AntMaze: max_episode_steps must be >= 1");
  }
  if (!(options_.success_radius > 0.0)) {
    throw std::invalid_argument("AntMaze: success_radius must be > 0");
  }
  impl_ = std::make_unique<Impl>(map_);
  goal_ = impl_->physics.FullObservation();
}

AntMaze::~AntMaze() = default;

Eigen::VectorXd AntMaze::Reset(const Eigen::Vector2d& start_xy, const Eigen::Vector2d& goal_xy,
                               uint64_t seed) {
  if (!start_xy.allFinite() || !goal_xy.allFinite()) {
    throw std::invalid_argument("AntMaze::Reset: start and goal must be finite");
  }
  std::mt19937_64 rng(seed);
  internal::AntPhysics& p = impl_->physics;
  // The goal: a noisy pose after a few random steps, moved to goal_xy.
  p.ResetNoisy(rng);
  Eigen::VectorXd action(kActionDim);
  for (int t = 0; t < kGoalRandomSteps; ++t) {
    for (int k = 0; k < kActionDim; ++k) action[k] = Uniform(rng, -1.0, 1.0);
    p.Step(action);
  }
  p.SetXY(goal_xy);
  goal_ = p.FullObservation();
  // The real start.
  p.ResetNoisy(rng);
  p.SetXY(start_xy);
  steps_ = 0;
  return state();
}

Eigen::VectorXd AntMaze::ResetToTask(int task_id, uint64_t seed) {
  const MazeMap::Task& task = map_.TaskById(task_id, "AntMaze::ResetToTask");
  std::mt19937_64 rng(seed);
  Eigen::Vector2d start = map_.CellCenter(task.start);
  Eigen::Vector2d goal = map_.CellCenter(task.goal);
  for (int k = 0; k < 2; ++k) start[k] += Uniform(rng, -kCellNoise, kCellNoise);
  for (int k = 0; k < 2; ++k) goal[k] += Uniform(rng, -kCellNoise, kCellNoise);
  return Reset(start, goal, rng());
}

Eigen::VectorXd AntMaze::ResetRandom(uint64_t seed) {
  std::mt19937_64 rng(seed);
  const std::vector<Cell> free = map_.FreeCells();
  const std::vector<Cell> vertices = map_.VertexCells();
  const Cell start_cell = free[UniformIndex(rng, free.size())];
  const Cell goal_cell = vertices[UniformIndex(rng, vertices.size())];
  Eigen::Vector2d start = map_.CellCenter(start_cell);
  Eigen::Vector2d goal = map_.CellCenter(goal_cell);
  for (int k = 0; k < 2; ++k) start[k] += Uniform(rng, -kCellNoise, kCellNoise);
  for (int k = 0; k < 2; ++k) goal[k] += Uniform(rng, -kCellNoise, kCellNoise);
  return Reset(start, goal, rng());
}

Eigen::VectorXd AntMaze::Step(const Eigen::VectorXd& action) {
  impl_->physics.Step(action);
  ++steps_;
  return state();
}

Eigen::VectorXd AntMaze::state() const { return impl_->physics.FullObservation(); }
Eigen::VectorXd AntMaze::qpos() const { return impl_->physics.qpos(); }
Eigen::VectorXd AntMaze::qvel() const { return impl_->physics.qvel(); }
Eigen::Vector2d AntMaze::xy() const { return impl_->physics.xy(); }
double AntMaze::z() const { return impl_->physics.z(); }

void AntMaze::SetState(const Eigen::VectorXd& qpos, const Eigen::VectorXd& qvel) {
  impl_->physics.SetState(qpos, qvel);
}

void AntMaze::SetGoal(const Eigen::VectorXd& goal) {
  if (goal.size() != kObsDim) {
    throw std::invalid_argument("AntMaze::SetGoal: the goal must have 29 values, got " +
                                std::to_string(goal.size()));
  }
  goal_ = goal;
}

bool AntMaze::success() const { return (xy() - goal_xy()).norm() <= options_.success_radius; }

std::vector<PointMaze::AgentJoint> AntMaze::AgentJoints() const { return impl_->physics.Joints(); }

const mjModel* AntMaze::model() const { return impl_->physics.model(); }
const mjData* AntMaze::data() const { return impl_->physics.data(); }

}  // namespace msspr::sim
