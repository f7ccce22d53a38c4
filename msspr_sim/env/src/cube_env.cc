#include "msspr_sim/cube_env.h"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "arm_rig.h"
#include "msspr_sim/random_util.h"
#include "mujoco_util.h"
#include "offscreen_renderer.h"

namespace msspr::sim {
namespace {

using internal::kArmHome;
using internal::kObservationCentre;
using internal::QuatYaw;

// Where the 28-D observation holds a position (m), as 10 x (position - kObservationCentre):
// the pinch at 12-14 (ArmRig::WriteProprio), the cube at 19-21; then the cube's quaternion
// (w, x, y, z) at 22-25 and its yaw's cosine and sine at 26-27.
constexpr int kPinchIndex = 12, kCubeIndex = 19, kCubeQuatIndex = 22, kCubeYawIndex = 26;
constexpr double kPositionScale = 10.0;

Eigen::Vector3d PositionAt(const float* obs, int index) {
  return kObservationCentre +
         Eigen::Vector3d(obs[index], obs[index + 1], obs[index + 2]) / kPositionScale;
}

}  // namespace

const std::array<CubeTask, 5>& CubeSingleTasks() {
  static const std::array<CubeTask, 5> tasks = {{
      {"horizontal", {0.425, 0.10}, {0.425, -0.10}},
      {"vertical1", {0.35, 0.00}, {0.50, 0.00}},
      {"vertical2", {0.50, 0.00}, {0.35, 0.00}},
      {"diagonal1", {0.35, -0.20}, {0.50, 0.20}},
      {"diagonal2", {0.35, 0.20}, {0.50, -0.20}},
  }};
  return tasks;
}

Eigen::Vector3d CubePositionFromObservation(const float* obs) {
  return PositionAt(obs, kCubeIndex);
}
Eigen::Vector3d PinchPositionFromObservation(const float* obs) {
  return PositionAt(obs, kPinchIndex);
}
void ShiftCubeInObservation(float* obs, const Eigen::Vector3d& delta) {
  for (int i = 0; i < 3; ++i) obs[kCubeIndex + i] += static_cast<float>(kPositionScale * delta[i]);
}
double CubeYawFromObservation(const float* obs) {
  return std::atan2(obs[kCubeYawIndex + 1], obs[kCubeYawIndex]);
}

Eigen::Matrix3d PinchDownRotation(double yaw) {
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Quaterniond PinchDown(double yaw) { return Eigen::Quaterniond(PinchDownRotation(yaw)); }

struct CubeEnv::Impl {
  Impl(const std::string& urdf_path, const ArmIkOptions& ik) : rig(urdf_path, ik) {}
  internal::ArmRig rig;
  internal::ModelPtr model;
  internal::DataPtr data;
  int cube_qpos = -1, cube_qvel = -1;
  int goal_mocap = -1;

  // Rendering (only with enable_rendering); it reads the physics data.
  std::unique_ptr<internal::OffscreenRenderer> renderer;
};

CubeEnv::CubeEnv(const CubeEnvOptions& options) : options_(options) {
  if (options.substeps < 1) throw std::invalid_argument("CubeEnvOptions: substeps must be >= 1");
  internal::InstallMujocoHandlers();
  impl_ = std::make_unique<Impl>(options.urdf_path, options.ik);
  mjcf_ = CubeSceneMjcf(impl_->rig.arm(), options.scene);
  impl_->model = internal::LoadInlineModel(mjcf_, "cube_single_scene");
  const mjModel* m = impl_->model.get();
  impl_->data.reset(mj_makeData(m));
  if (!impl_->data) throw std::runtime_error("MuJoCo: mj_makeData failed");
  impl_->rig.Bind(m, options.scene.pad_geoms[1], options.scene.gripper_travel, "CubeEnv");
  const auto require = [&](mjtObj type, const std::string& name, const char* what) {
    return internal::RequireId(m, type, name, what, "CubeEnv");
  };
  const int cube_joint = require(mjOBJ_JOINT, "object_joint_0", "joint");
  impl_->cube_qpos = m->jnt_qposadr[cube_joint];
  impl_->cube_qvel = m->jnt_dofadr[cube_joint];
  impl_->goal_mocap = m->body_mocapid[require(mjOBJ_BODY, "object_target_0", "body")];

  SetArmJoints(Eigen::Map<const Eigen::Matrix<double, 6, 1>>(kArmHome));
  SetOpening(0.0);

  if (options.enable_rendering) {
    const int size = options.image_size;
    if (size < 1 || size > 4096)
      throw std::invalid_argument("CubeEnvOptions: image_size must be in [1, 4096], got " +
                                  std::to_string(size));
    // Default visibility: geom groups 0-2 (floor, cube, robot visuals);
    // collision geoms and walls (3), sites (4) and a pixel-mode goal (5) hidden.
    const int camera = require(mjOBJ_CAMERA, options.camera, "camera");
    impl_->renderer = std::make_unique<internal::OffscreenRenderer>(m, size, camera);
  }
}

CubeEnv::~CubeEnv() = default;

const ArmModel& CubeEnv::arm() const { return impl_->rig.arm(); }

void CubeEnv::SetArmJoints(const Eigen::Matrix<double, 6, 1>& q) {
  impl_->rig.SetArmJoints(impl_->data.get(), q);
}

bool CubeEnv::PlacePinch(const Eigen::Vector3d& position, double yaw) {
  return impl_->rig.PlacePinch(impl_->data.get(), position, yaw);
}

void CubeEnv::SetOpening(double opening) { impl_->rig.SetOpening(impl_->data.get(), opening); }

void CubeEnv::SetCube(const Eigen::Vector3d& position, double yaw) {
  mjData* d = impl_->data.get();
  internal::PlaceFreeBody(d, impl_->cube_qpos, impl_->cube_qvel, position, yaw);
  mj_forward(impl_->model.get(), d);
}

void CubeEnv::SetGoal(const Eigen::Vector3d& position, double yaw) {
  internal::PlaceMocap(impl_->data.get(), impl_->goal_mocap, position, yaw);
  // No mj_forward: it would refresh the arm's poses that mj_step leaves one
  // substep old, so an oracle setting a new target mid-episode would change
  // the observations and a replay of the stored actions would not match.
  // The marker's pose updates at the next step (it never touches physics).
}

Eigen::Vector3d CubeEnv::PinchPosition() const {
  return impl_->rig.PinchPosition(impl_->data.get());
}

double CubeEnv::PinchYaw() const { return impl_->rig.PinchYaw(impl_->data.get()); }

Eigen::Matrix3d CubeEnv::PinchRotation() const {
  return impl_->rig.PinchRotation(impl_->data.get());
}

double CubeEnv::CubeYaw() const {
  const mjtNum* q = impl_->data->qpos + impl_->cube_qpos + 3;
  return QuatYaw(q[0], q[1], q[2], q[3]);
}

double CubeEnv::Opening() const { return impl_->rig.Opening(impl_->data.get()); }

Eigen::Vector3d CubeEnv::CubePosition() const {
  const mjtNum* q = impl_->data->qpos + impl_->cube_qpos;
  return Eigen::Vector3d(q[0], q[1], q[2]);
}

Eigen::Vector3d CubeEnv::GoalPosition() const {
  const mjtNum* p = impl_->data->mocap_pos + 3 * impl_->goal_mocap;
  return Eigen::Vector3d(p[0], p[1], p[2]);
}

double CubeEnv::GoalYaw() const {
  const mjtNum* q = impl_->data->mocap_quat + 4 * impl_->goal_mocap;
  return QuatYaw(q[0], q[1], q[2], q[3]);
}

bool CubeEnv::Success() const {
  return (CubePosition() - GoalPosition()).norm() <= options_.success_distance;
}

Eigen::Matrix<double, 6, 1> CubeEnv::ArmJoints() const {
  return impl_->rig.ArmJoints(impl_->data.get());
}

std::vector<double> CubeEnv::Qpos() const {
  return std::vector<double>(impl_->data->qpos, impl_->data->qpos + impl_->model->nq);
}

std::vector<double> CubeEnv::Qvel() const {
  return std::vector<double>(impl_->data->qvel, impl_->data->qvel + impl_->model->nv);
}

bool CubeEnv::Step(const Action& action) {
  const mjModel* m = impl_->model.get();
  mjData* d = impl_->data.get();
  last_ik_converged_ = impl_->rig.SetControls(d, action, options_.action_scale, options_.pinch_low,
                                              options_.pinch_high);
  for (int k = 0; k < options_.substeps; ++k) mj_step(m, d);
  // cfrc_ext (the contact feature) is filled only by this call.
  mj_rnePostConstraint(m, d);
  ++episode_steps_;
  return Success();
}

void CubeEnv::RandomizeArm(std::mt19937_64& rng) {
  impl_->rig.Randomize(impl_->data.get(), rng, options_.init_low, options_.init_high);
}

CubeEnv::Observation CubeEnv::ResetToTask(int task, uint64_t seed) {
  if (task < 1 || task > static_cast<int>(CubeSingleTasks().size()))
    throw std::out_of_range("CubeEnv::ResetToTask: task must be 1 to 5, got " +
                            std::to_string(task));
  const CubeTask& t = CubeSingleTasks()[task - 1];
  const mjModel* m = impl_->model.get();
  mjData* d = impl_->data.get();
  std::mt19937_64 rng(Mix64(seed));
  mj_resetData(m, d);
  const Eigen::Vector3d goal(t.goal.x(), t.goal.y(), 0.02);
  SetGoal(goal);

  // The goal observation: a random arm, the cube at rest at the goal, two
  // random actions. Only the cube decides success; the rest is "a state
  // with the cube there", as OGBench's goals are full observations.
  RandomizeArm(rng);
  SetCube(goal, 0.0);
  const std::vector<mjtNum> qpos(d->qpos, d->qpos + m->nq), qvel(d->qvel, d->qvel + m->nv),
      ctrl(d->ctrl, d->ctrl + m->nu), act(d->act, d->act + m->na);
  const mjtNum time = d->time;
  for (int k = 0; k < 2; ++k) {
    Action a;
    for (double& x : a) x = Uniform(rng, -1.0, 1.0);
    Step(a);
  }
  goal_observation_ = GetObservation();
  if (options_.enable_rendering) goal_image_ = Render();
  std::copy(qpos.begin(), qpos.end(), d->qpos);
  std::copy(qvel.begin(), qvel.end(), d->qvel);
  std::copy(ctrl.begin(), ctrl.end(), d->ctrl);
  std::copy(act.begin(), act.end(), d->act);
  d->time = time;

  RandomizeArm(rng);
  const double dx = Uniform(rng, -0.01, 0.01), dy = Uniform(rng, -0.01, 0.01);
  SetCube(Eigen::Vector3d(t.start.x() + dx, t.start.y() + dy, 0.02), Uniform(rng, 0.0, 2 * M_PI));
  episode_steps_ = 0;
  return GetObservation();
}

CubeEnv::Observation CubeEnv::GetObservation() const {
  const mjData* d = impl_->data.get();
  Observation o{};
  impl_->rig.WriteProprio(d, o.data());
  const Eigen::Vector3d cube = kPositionScale * (CubePosition() - kObservationCentre);
  for (int i = 0; i < 3; ++i) o[kCubeIndex + i] = static_cast<float>(cube[i]);
  const mjtNum* q = d->qpos + impl_->cube_qpos + 3;
  for (int i = 0; i < 4; ++i) o[kCubeQuatIndex + i] = static_cast<float>(q[i]);
  const double cube_yaw = QuatYaw(q[0], q[1], q[2], q[3]);
  o[kCubeYawIndex] = static_cast<float>(std::cos(cube_yaw));
  o[kCubeYawIndex + 1] = static_cast<float>(std::sin(cube_yaw));
  return o;
}

}  // namespace msspr::sim

namespace msspr::sim {

CubeEnv::Observation CubeEnv::ResetForCollection(uint64_t seed) {
  std::mt19937_64 rng(Mix64(seed));
  mj_resetData(impl_->model.get(), impl_->data.get());
  RandomizeArm(rng);
  const auto xy = [&] {
    return Eigen::Vector3d(Uniform(rng, options_.object_low.x(), options_.object_high.x()),
                           Uniform(rng, options_.object_low.y(), options_.object_high.y()), 0.02);
  };
  const Eigen::Vector3d cube = xy();
  SetCube(cube, Uniform(rng, 0.0, 2 * M_PI));
  const Eigen::Vector3d goal = xy();
  SetGoal(goal, Uniform(rng, 0.0, 2 * M_PI));
  mj_forward(impl_->model.get(), impl_->data.get());  // pose the marker too
  goal_observation_ = Observation{};
  goal_image_.clear();
  episode_steps_ = 0;
  return GetObservation();
}

std::vector<uint8_t> CubeEnv::RenderObservation(const Observation& obs) {
  if (!impl_->renderer)
    throw std::logic_error("CubeEnv::RenderObservation: construct with enable_rendering = true");
  const mjModel* m = impl_->model.get();
  mjData* d = impl_->data.get();
  // All of mjData, not only the state: after mj_step its poses are those of the
  // last substep's start (what observations and the next action read), which a
  // fresh mj_forward would change.
  internal::DataPtr saved(mj_makeData(m));
  if (!saved) throw std::runtime_error("CubeEnv::RenderObservation: mj_makeData failed");
  mj_copyData(saved.get(), m, d);
  Eigen::Matrix<double, 6, 1> q;
  for (int i = 0; i < 6; ++i) q[i] = obs[i];
  SetArmJoints(q);
  SetOpening(obs[17] / 3.0);
  SetCube(CubePositionFromObservation(obs.data()), CubeYawFromObservation(obs.data()));
  std::vector<uint8_t> rgb = Render();
  mj_copyData(d, m, saved.get());
  return rgb;
}

void CubeEnv::SetGoalObservation(const Observation& goal) {
  SetGoal(CubePositionFromObservation(goal.data()), CubeYawFromObservation(goal.data()));
  goal_observation_ = goal;
  if (impl_->renderer) goal_image_ = RenderObservation(goal);
}

void CubeEnv::Render(uint8_t* rgb) const {
  if (!impl_->renderer)
    throw std::logic_error("CubeEnv::Render: construct with enable_rendering = true");
  const mjModel* m = impl_->model.get();
  mjData* d = impl_->data.get();
  impl_->renderer->Render(m, d, rgb);
}

void CubeEnv::RenderStateOf(const CubeEnv& source, uint8_t* rgb) {
  if (!impl_->renderer)
    throw std::logic_error("CubeEnv::RenderStateOf: construct with enable_rendering = true");
  const mjModel* m = impl_->model.get();
  const mjModel* sm = source.impl_->model.get();
  if (m->nq != sm->nq || m->nv != sm->nv || m->nbody != sm->nbody || m->ngeom != sm->ngeom ||
      m->nu != sm->nu || m->nmocap != sm->nmocap || m->nbuffer != sm->nbuffer)
    throw std::invalid_argument(
        "CubeEnv::RenderStateOf: the source env's scene differs from this one's (another arm "
        "or scene options)");
  mj_copyData(impl_->data.get(), m, source.impl_->data.get());
  impl_->renderer->Render(m, impl_->data.get(), rgb);
}

std::vector<uint8_t> CubeEnv::Render() const {
  std::vector<uint8_t> rgb(static_cast<size_t>(options_.image_size) * options_.image_size * 3);
  Render(rgb.data());
  return rgb;
}

}  // namespace msspr::sim
