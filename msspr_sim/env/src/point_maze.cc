#include "msspr_sim/point_maze.h"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>

#include "msspr_sim/random_util.h"
#include "mujoco_util.h"
#include "offscreen_renderer.h"

namespace msspr::sim {

using internal::DataDeleter;
using internal::InstallMujocoHandlers;
using internal::LoadInlineModel;
using internal::ModelDeleter;

struct PointMaze::Impl {
  // Physics: the model without visual-only geoms.
  std::unique_ptr<mjModel, ModelDeleter> model;
  std::unique_ptr<mjData, DataDeleter> data;
  // Rendering (only with enable_rendering): the full model, posed from the
  // physics qpos before each frame.
  std::unique_ptr<mjModel, ModelDeleter> render_model;
  std::unique_ptr<mjData, DataDeleter> render_data;
  std::unique_ptr<internal::OffscreenRenderer> renderer;
};

PointMaze::PointMaze(const PointMazeOptions& options)
    : options_(options), map_(MazeMap::FromName(options.maze)), impl_(std::make_unique<Impl>()) {
  if (options_.image_size < 1 || options_.image_size > 4096) {
    throw std::invalid_argument("PointMaze: image_size must be in [1, 4096], got " +
                                std::to_string(options_.image_size));
  }
  InstallMujocoHandlers();
  impl_->model = LoadInlineModel(map_.ToMjcf(options_.image_size, /*visuals=*/false),
                                 "pointmaze_" + map_.name() + "_physics");
  mjModel* m = impl_->model.get();
  if (m->nq != 2 || m->nv != 2) throw std::logic_error("PointMaze: model must have nq = nv = 2");
  impl_->data.reset(mj_makeData(m));
  if (!impl_->data) throw std::runtime_error("MuJoCo: mj_makeData failed");
  mj_forward(m, impl_->data.get());

  if (options_.enable_rendering) {
    const int s = options_.image_size;
    impl_->render_model = LoadInlineModel(map_.ToMjcf(s), "pointmaze_" + map_.name());
    m = impl_->render_model.get();
    if (m->nq != 2) throw std::logic_error("PointMaze: render model must have nq = 2");
    impl_->render_data.reset(mj_makeData(m));
    if (!impl_->render_data) throw std::runtime_error("MuJoCo: mj_makeData failed");
    mj_forward(m, impl_->render_data.get());
    const int camera = mj_name2id(m, mjOBJ_CAMERA, "track");
    if (camera < 0) throw std::logic_error("PointMaze: no camera 'track'");
    impl_->renderer = std::make_unique<internal::OffscreenRenderer>(m, s, camera);
    impl_->renderer->scene().flags[mjRND_SHADOW] = 0;
    impl_->renderer->scene().flags[mjRND_SKYBOX] = 0;
  }
}

PointMaze::~PointMaze() = default;

Eigen::Vector2d PointMaze::Reset(const Eigen::Vector2d& start, const Eigen::Vector2d& goal) {
  if (!start.allFinite() || !goal.allFinite()) {
    throw std::invalid_argument("PointMaze::Reset: start and goal must be finite");
  }
  mjModel* m = impl_->model.get();
  mjData* d = impl_->data.get();
  mj_resetData(m, d);
  d->qpos[0] = start.x();
  d->qpos[1] = start.y();
  mj_forward(m, d);
  goal_ = goal;
  steps_ = 0;
  return state();
}

Eigen::Vector2d PointMaze::ResetToTask(int task_id, uint64_t seed) {
  const MazeMap::Task& task = map_.TaskById(task_id, "PointMaze::ResetToTask");
  std::mt19937_64 rng(seed);
  Eigen::Vector2d start = map_.CellCenter(task.start);
  Eigen::Vector2d goal = map_.CellCenter(task.goal);
  for (int k = 0; k < 2; ++k) start[k] += Uniform(rng, -1.0, 1.0);
  for (int k = 0; k < 2; ++k) goal[k] += Uniform(rng, -1.0, 1.0);
  for (int k = 0; k < 2; ++k) start[k] += Uniform(rng, -0.1, 0.1);  // qpos noise
  return Reset(start, goal);
}

Eigen::Vector2d PointMaze::ResetRandom(uint64_t seed) {
  std::mt19937_64 rng(seed);
  const std::vector<Cell> free = map_.FreeCells();
  const std::vector<Cell> vertices = map_.VertexCells();
  const Cell start_cell = free[UniformIndex(rng, free.size())];
  const Cell goal_cell = vertices[UniformIndex(rng, vertices.size())];
  Eigen::Vector2d start = map_.CellCenter(start_cell);
  Eigen::Vector2d goal = map_.CellCenter(goal_cell);
  for (int k = 0; k < 2; ++k) start[k] += Uniform(rng, -1.0, 1.0);
  for (int k = 0; k < 2; ++k) goal[k] += Uniform(rng, -1.0, 1.0);
  for (int k = 0; k < 2; ++k) start[k] += Uniform(rng, -0.1, 0.1);  // qpos noise
  return Reset(start, goal);
}

Eigen::Vector2d PointMaze::Step(const Eigen::Vector2d& action) {
  if (!action.allFinite()) {
    throw std::invalid_argument("PointMaze::Step: action must be finite");
  }
  mjModel* m = impl_->model.get();
  mjData* d = impl_->data.get();
  for (int k = 0; k < 2; ++k) {
    d->qpos[k] += kActionScale * std::clamp(action[k], -1.0, 1.0);
    d->qvel[k] = 0.0;
  }
  for (int s = 0; s < kFrameSkip; ++s) mj_step(m, d);
  ++steps_;
  return state();
}

Eigen::Vector2d PointMaze::state() const {
  const mjData* d = impl_->data.get();
  return {d->qpos[0], d->qpos[1]};
}

bool PointMaze::success() const { return (state() - goal_).norm() <= options_.success_radius; }

void PointMaze::Render(uint8_t* rgb) const {
  const mjData* d = impl_->data.get();
  RenderPose(d->qpos[0], d->qpos[1], rgb);
}

void PointMaze::RenderPose(double x, double y, uint8_t* rgb) const {
  if (!impl_->renderer) {
    throw std::logic_error("PointMaze::Render: construct with enable_rendering = true");
  }
  mjModel* m = impl_->render_model.get();
  mjData* d = impl_->render_data.get();
  d->qpos[0] = x;
  d->qpos[1] = y;
  // Positions only: the render model never steps.
  mj_kinematics(m, d);
  mj_comPos(m, d);
  mj_camlight(m, d);
  impl_->renderer->Render(m, d, rgb);
}

std::vector<uint8_t> PointMaze::Render() const {
  std::vector<uint8_t> rgb(static_cast<size_t>(options_.image_size) * options_.image_size * 3);
  Render(rgb.data());
  return rgb;
}

std::vector<uint8_t> PointMaze::RenderAt(const Eigen::Vector2d& xy) const {
  // The physics state is never touched: only the render model is posed.
  std::vector<uint8_t> rgb(static_cast<size_t>(options_.image_size) * options_.image_size * 3);
  RenderPose(xy.x(), xy.y(), rgb.data());
  return rgb;
}

std::vector<uint8_t> PointMaze::RenderGoal() const { return RenderAt(goal_); }

std::vector<PointMaze::AgentJoint> PointMaze::AgentJoints() const {
  return internal::ModelJoints(impl_->model.get());
}

double PointMaze::AgentRadius() const {
  const mjModel* m = impl_->model.get();
  const int g = mj_name2id(m, mjOBJ_GEOM, "agent_geom");
  if (g < 0) throw std::logic_error("PointMaze: the model has no geom 'agent_geom'");
  return m->geom_size[3 * g];
}

}  // namespace msspr::sim
