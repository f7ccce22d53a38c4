#include "msspr_sim/scene_env.h"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "arm_rig.h"
#include "msspr_sim/cube_scene.h"
#include "msspr_sim/puzzle_env.h"  // PushButtonMjcf, ButtonStateFromOneHot
#include "msspr_sim/random_util.h"

namespace msspr::sim {

using internal::QuatYaw;
namespace {

constexpr double kLocked = 1e6, kFree = 2.0;  // slide damping (N s / m)
// Cap colours: red in state 0, white in state 1; handles red when locked, white when free.
const float kRed[4] = {0.96f, 0.26f, 0.33f, 1.f}, kWhite[4] = {0.9f, 0.9f, 0.9f, 1.f};

}  // namespace

const std::array<SceneTask, 5>& SceneTasks() {
  using V = Eigen::Vector3d;
  const V in_drawer(0.33, -0.356, 0.065986);
  static const std::array<SceneTask, 5> tasks = {{
      {"open", {V(0.35, 0.05, 0.02), {1, 1}, 0.0, 0.0}, {V(0.35, 0.05, 0.02), {1, 1}, -0.16, 0.2}},
      {"unlock_and_lock",
       {V(0.35, -0.05, 0.02), {0, 0}, -0.16, 0.2},
       {V(0.35, -0.05, 0.02), {0, 0}, 0.0, 0.0}},
      {"rearrange_medium",
       {V(0.40, -0.05, 0.02), {1, 0}, 0.0, 0.2},
       {V(0.40, 0.15, 0.02), {1, 1}, -0.16, 0.0}},
      {"put_in_drawer", {V(0.35, 0.05, 0.02), {0, 0}, 0.0, 0.0}, {in_drawer, {1, 0}, 0.0, 0.0}},
      {"rearrange_hard", {V(0.35, 0.15, 0.02), {0, 0}, 0.0, 0.0}, {in_drawer, {0, 0}, 0.0, 0.2}},
  }};
  return tasks;
}

std::string SceneObjectsMjcf(bool pixel_style) {
  std::ostringstream x;
  const char* solid = " contype=\"1\" conaffinity=\"1\" group=\"1\"";
  CubeSceneOptions cube;
  cube.pixel_style = pixel_style;
  x << CubeObjectsMjcf(cube);  // the cube and its goal marker, as cube-single's
  // The buttons (OGBench's sites: 0.1254 and 0.1212 m high).
  x << PushButtonMjcf(0, 0.58, -0.05, 0.0774) << PushButtonMjcf(1, 0.58, 0.05, 0.0732);
  // The drawer: a case (x 0.212-0.448, y -0.52 to -0.32, z 0-0.168) and a tray sliding toward
  // +y (the slide's axis (-0.0016, -1, 0), OGBench's drift kept), 4.124 kg as OGBench's
  // mesh-derived mass; the handle bar at the grasp site.
  x << "    <body name=\"drawer_base\" pos=\"0.33 -0.42 0.084\">\n"
    << "      <geom type=\"box\" pos=\"0 0 -0.074\" size=\"0.118 0.1 0.01\"" << solid
    << " rgba=\"0.6 0.72 0.94 1\"/>\n"
    << "      <geom type=\"box\" pos=\"0 0 0.079\" size=\"0.118 0.1 0.005\"" << solid
    << " rgba=\"0.6 0.72 0.94 1\"/>\n"
    << "      <geom type=\"box\" pos=\"-0.113 0 0\" size=\"0.005 0.1 0.084\"" << solid
    << " rgba=\"0.6 0.72 0.94 1\"/>\n"
    << "      <geom type=\"box\" pos=\"0.113 0 0\" size=\"0.005 0.1 0.084\"" << solid
    << " rgba=\"0.6 0.72 0.94 1\"/>\n"
    << "      <geom type=\"box\" pos=\"0 -0.095 0\" size=\"0.118 0.005 0.084\"" << solid
    << " rgba=\"0.6 0.72 0.94 1\"/>\n"
    << "    </body>\n"
    << "    <body name=\"drawer_link\" pos=\"0.33 -0.41 0.09\">\n"
    << "      <joint name=\"drawer_slide\" type=\"slide\" axis=\"-0.0016 -1 0\" range=\"-0.16 0\""
       " damping=\"1000000\" frictionloss=\"2\" armature=\"0.001\"/>\n"
    << "      <inertial pos=\"0 0.009 -0.005\" mass=\"4.124\" diaginertia=\"0.0283 0.0184 "
       "0.017\"/>\n"
    << "      <geom type=\"box\" pos=\"0 0 -0.049\" size=\"0.094 0.084 0.005\"" << solid
    << " rgba=\"0.6 0.72 0.94 1\"/>\n"
    << "      <geom type=\"box\" pos=\"-0.089 0 0.003\" size=\"0.005 0.084 0.057\"" << solid
    << " rgba=\"0.6 0.72 0.94 1\"/>\n"
    << "      <geom type=\"box\" pos=\"0.089 0 0.003\" size=\"0.005 0.084 0.057\"" << solid
    << " rgba=\"0.6 0.72 0.94 1\"/>\n"
    << "      <geom type=\"box\" pos=\"0 -0.079 0.003\" size=\"0.094 0.005 0.057\"" << solid
    << " rgba=\"0.6 0.72 0.94 1\"/>\n"
    << "      <geom type=\"box\" pos=\"0 0.079 0.003\" size=\"0.094 0.005 0.057\"" << solid
    << " rgba=\"0.6 0.72 0.94 1\"/>\n"
    << "      <geom name=\"drawer_handle\" type=\"capsule\" fromto=\"-0.05 0.17 -0.01 0.05 0.17"
       " -0.01\" size=\"0.009\""
    << solid << " rgba=\"0.96 0.26 0.33 1\"/>\n"
    << "      <geom type=\"capsule\" fromto=\"-0.05 0.084 -0.01 -0.05 0.17 -0.01\" size=\"0.006\""
    << solid << " rgba=\"0.8 0.8 0.8 1\"/>\n"
    << "      <geom type=\"capsule\" fromto=\"0.05 0.084 -0.01 0.05 0.17 -0.01\" size=\"0.006\""
    << solid << " rgba=\"0.8 0.8 0.8 1\"/>\n"
    << "      <site name=\"drawer_handle_center\" pos=\"0.0003 0.17 -0.01\" size=\"0.005\""
       " group=\"4\"/>\n"
    << "    </body>\n";
  // The window: a frame (posts at x 0.084 and 0.516, a base plate, a top bar), a fixed pane
  // and a pane sliding along +x (0 closed, 0.2 open), 2.022 kg as OGBench's; its vertical
  // handle at the grasp site.
  x << "    <geom type=\"box\" pos=\"0.084 0.3 0.2\" size=\"0.01 0.03 0.2\"" << solid
    << " rgba=\"0.9 0.9 0.9 1\"/>\n"
    << "    <geom type=\"box\" pos=\"0.516 0.3 0.2\" size=\"0.01 0.03 0.2\"" << solid
    << " rgba=\"0.9 0.9 0.9 1\"/>\n"
    << "    <geom type=\"box\" pos=\"0.3 0.3 0.01\" size=\"0.226 0.03 0.01\"" << solid
    << " rgba=\"0.9 0.9 0.9 1\"/>\n"
    << "    <geom type=\"box\" pos=\"0.3 0.3 0.39\" size=\"0.226 0.03 0.01\"" << solid
    << " rgba=\"0.9 0.9 0.9 1\"/>\n"
    << "    <geom name=\"windowb_b\" type=\"box\" pos=\"0.4 0.313 0.202\" size=\"0.098 0.004"
       " 0.17\""
    << solid << " rgba=\"0 0.3 0.4 0.1\"/>\n"
    << "    <body name=\"windowb_a\" pos=\"0.206 0.283 0.202\">\n"
    << "      <joint name=\"window_slide\" type=\"slide\" axis=\"1 0 0\" range=\"0 0.2\""
       " damping=\"1000000\" frictionloss=\"2\" armature=\"0.001\"/>\n"
    << "      <inertial pos=\"0 0 0\" mass=\"2.022\" diaginertia=\"0.0195 0.0262 0.00675\"/>\n"
    << "      <geom type=\"box\" size=\"0.098 0.004 0.17\"" << solid
    << " rgba=\"0 0.3 0.4 0.1\"/>\n"
    << "      <geom name=\"window_handle\" type=\"capsule\" fromto=\"0.08 -0.058 -0.01 0.08 -0.058"
       " 0.08\" size=\"0.008\""
    << solid << " rgba=\"0.96 0.26 0.33 1\"/>\n"
    << "      <geom type=\"capsule\" fromto=\"0.08 -0.058 0 0.08 -0.004 0\" size=\"0.005\"" << solid
    << " rgba=\"0.8 0.8 0.8 1\"/>\n"
    << "      <geom type=\"capsule\" fromto=\"0.08 -0.058 0.07 0.08 -0.004 0.07\" size=\"0.005\""
    << solid << " rgba=\"0.8 0.8 0.8 1\"/>\n"
    << "      <site name=\"window_handle_center\" pos=\"0.08 -0.058 0.035\" size=\"0.005\""
       " group=\"4\"/>\n"
    << "    </body>\n";
  return x.str();
}

SceneEnv::SceneEnv(const SceneEnvOptions& options)
    : ArmEnv(options, "scene", SceneObjectsMjcf(options.scene.pixel_style), "SceneEnv"),
      options_(options) {
  const mjModel* m = model();
  const int cube = RequireId(mjOBJ_JOINT, "object_joint_0", "joint");
  cube_qpos_ = m->jnt_qposadr[cube];
  cube_qvel_ = m->jnt_dofadr[cube];
  goal_mocap_ = m->body_mocapid[RequireId(mjOBJ_BODY, "object_target_0", "body")];
  const int drawer = RequireId(mjOBJ_JOINT, "drawer_slide", "joint");
  drawer_qpos_ = m->jnt_qposadr[drawer];
  drawer_qvel_ = drawer_dof_ = m->jnt_dofadr[drawer];
  const int window = RequireId(mjOBJ_JOINT, "window_slide", "joint");
  window_qpos_ = m->jnt_qposadr[window];
  window_qvel_ = window_dof_ = m->jnt_dofadr[window];
  for (int k = 0; k < 2; ++k) {
    const std::string s = std::to_string(k);
    const int j = RequireId(mjOBJ_JOINT, "buttonbox_joint_" + s, "joint");
    button_qpos_[k] = m->jnt_qposadr[j];
    button_qvel_[k] = m->jnt_dofadr[j];
    button_site_[k] = RequireId(mjOBJ_SITE, "btntop_" + s, "site");
    button_geom_[k] = RequireId(mjOBJ_GEOM, "btngeom_" + s, "geom");
  }
  drawer_handle_site_ = RequireId(mjOBJ_SITE, "drawer_handle_center", "site");
  window_handle_site_ = RequireId(mjOBJ_SITE, "window_handle_center", "site");
  drawer_body_ = RequireId(mjOBJ_BODY, "drawer_link", "body");
  window_body_ = RequireId(mjOBJ_BODY, "windowb_a", "body");
  drawer_handle_geom_ = RequireId(mjOBJ_GEOM, "drawer_handle", "geom");
  window_handle_geom_ = RequireId(mjOBJ_GEOM, "window_handle", "geom");
  goal_observation_.assign(kObservationSize, 0.f);
  ApplyButtonStates();
  mj_forward(model(), data());
}

void SceneEnv::ApplyButtonStates() {
  mjModel* m = model();
  m->dof_damping[drawer_dof_] = states_[0] == 0 ? kLocked : kFree;
  m->dof_damping[window_dof_] = states_[1] == 0 ? kLocked : kFree;
  const auto paint = [&](int geom, const float* rgba) {
    std::copy(rgba, rgba + 4, m->geom_rgba + 4 * geom);
  };
  for (int k = 0; k < 2; ++k) paint(button_geom_[k], states_[k] == 0 ? kRed : kWhite);
  paint(drawer_handle_geom_, states_[0] == 0 ? kRed : kWhite);
  paint(window_handle_geom_, states_[1] == 0 ? kRed : kWhite);
}

bool SceneEnv::Step(const Action& action) {
  mjData* d = data();
  double before[2];
  for (int k = 0; k < 2; ++k) before[k] = d->qpos[button_qpos_[k]];
  StepPhysics(action);
  for (int k = 0; k < 2; ++k)
    if (before[k] > options_.press_depth && d->qpos[button_qpos_[k]] <= options_.press_depth)
      states_[k] = 1 - states_[k];
  ApplyButtonStates();
  // As OGBench's scene: observations read the final state.
  mj_forward(model(), d);
  mj_rnePostConstraint(model(), d);  // the pad contact feature
  ++episode_steps_;
  return Success();
}

void SceneEnv::SetSceneState(const SceneState& s, double cube_yaw) {
  mjData* d = data();
  internal::PlaceFreeBody(d, cube_qpos_, cube_qvel_, s.cube, cube_yaw);
  for (int k = 0; k < 2; ++k) {
    if (s.buttons[k] != 0 && s.buttons[k] != 1)
      throw std::invalid_argument("SceneEnv: button states are 0 or 1, got " +
                                  std::to_string(s.buttons[k]));
    states_[k] = s.buttons[k];
    d->qpos[button_qpos_[k]] = 0;
    d->qvel[button_qvel_[k]] = 0;
  }
  d->qpos[drawer_qpos_] = std::clamp(s.drawer, kDrawerOpen, 0.0);
  d->qvel[drawer_qvel_] = 0;
  d->qpos[window_qpos_] = std::clamp(s.window, 0.0, kWindowOpen);
  d->qvel[window_qvel_] = 0;
  ApplyButtonStates();
  mj_forward(model(), d);
}

SceneState SceneEnv::GetSceneState() const {
  return SceneState{CubePosition(), states_, Drawer(), Window()};
}

bool SceneEnv::Success() const {
  return (CubePosition() - goal_.cube).norm() <= options_.success_distance &&
         states_ == goal_.buttons &&
         std::abs(Drawer() - goal_.drawer) <= options_.success_distance &&
         std::abs(Window() - goal_.window) <= options_.success_distance;
}

SceneEnv::Observation SceneEnv::ResetToTask(int task, uint64_t seed) {
  if (task < 1 || task > static_cast<int>(SceneTasks().size()))
    throw std::out_of_range("SceneEnv::ResetToTask: task must be 1 to 5, got " +
                            std::to_string(task));
  const SceneTask& t = SceneTasks()[task - 1];
  std::mt19937_64 rng(Mix64(seed));
  mj_resetData(model(), data());
  goal_ = t.goal;
  SetCubeTarget(t.goal.cube, 0.0);

  // The goal observation: everything at the goal, a random arm, two random actions.
  RandomizeArm(rng);
  SetSceneState(t.goal);
  RecordGoal(*this, rng, 2, std::nan(""), &goal_observation_, &goal_image_);

  RandomizeArm(rng);
  SceneState start = t.start;
  start.cube += Eigen::Vector3d(Uniform(rng, -0.01, 0.01), Uniform(rng, -0.01, 0.01), 0);
  const double cube_yaw = Uniform(rng, 0.0, 2 * M_PI);
  start.drawer += Uniform(rng, -0.01, 0.01);
  start.window += Uniform(rng, -0.01, 0.01);
  SetSceneState(start, cube_yaw);
  episode_steps_ = 0;
  return GetObservation();
}

SceneEnv::Observation SceneEnv::ResetForCollection(uint64_t seed) {
  std::mt19937_64 rng(Mix64(seed));
  mj_resetData(model(), data());
  RandomizeArm(rng);
  SceneState s;
  s.cube = Eigen::Vector3d(Uniform(rng, options_.object_low.x(), options_.object_high.x()),
                           Uniform(rng, options_.object_low.y(), options_.object_high.y()), 0.02);
  const double yaw = Uniform(rng, 0.0, 2 * M_PI);
  for (int& b : s.buttons) b = static_cast<int>(UniformIndex(rng, 2));
  s.drawer = Uniform(rng, kDrawerOpen, 0.0);
  s.window = Uniform(rng, 0.0, kWindowOpen);
  SetSceneState(s, yaw);
  goal_ = s;
  goal_observation_.assign(kObservationSize, 0.f);
  goal_image_.clear();
  episode_steps_ = 0;
  return GetObservation();
}

void SceneEnv::SetCubeTarget(const Eigen::Vector3d& position, double yaw) {
  internal::PlaceMocap(data(), goal_mocap_, position, yaw);  // no mj_forward, as CubeEnv's
}

bool SceneEnv::CubeInDrawer() const {
  const Eigen::Vector3d c = CubePosition();
  const double hy = DrawerHandle().y();
  return c.x() >= 0.21 && c.x() <= 0.45 && c.y() >= hy - 0.27 && c.y() <= hy - 0.07 && c.z() >= 0 &&
         c.z() <= 0.15;
}

SceneEnv::Observation SceneEnv::GetObservation() const {
  const mjData* d = data();
  Observation o(kObservationSize);
  WriteProprio(o.data());
  const Eigen::Vector3d c = 10 * (CubePosition() - internal::kObservationCentre);
  for (int k = 0; k < 3; ++k) o[19 + k] = static_cast<float>(c[k]);
  const mjtNum* q = d->qpos + cube_qpos_ + 3;
  for (int k = 0; k < 4; ++k) o[22 + k] = static_cast<float>(q[k]);
  const double yaw = QuatYaw(q);
  o[26] = static_cast<float>(std::cos(yaw));
  o[27] = static_cast<float>(std::sin(yaw));
  for (int k = 0; k < 2; ++k) {
    float* b = o.data() + 28 + 4 * k;
    b[0] = states_[k] == 0 ? 1.f : 0.f;
    b[1] = states_[k] == 0 ? 0.f : 1.f;
    b[2] = static_cast<float>(120 * d->qpos[button_qpos_[k]]);
    b[3] = static_cast<float>(d->qvel[button_qvel_[k]]);
  }
  o[36] = static_cast<float>(18 * Drawer());
  o[37] = static_cast<float>(d->qvel[drawer_qvel_]);
  o[38] = static_cast<float>(15 * Window());
  o[39] = static_cast<float>(d->qvel[window_qvel_]);
  return o;
}

Eigen::Vector3d SceneEnv::CubePosition() const {
  const mjtNum* q = data()->qpos + cube_qpos_;
  return Eigen::Vector3d(q[0], q[1], q[2]);
}
const double* SceneEnv::CubeQpos() const { return data()->qpos + cube_qpos_; }
Eigen::Vector3d SceneEnv::CubeTargetPosition() const {
  const mjtNum* p = data()->mocap_pos + 3 * goal_mocap_;
  return Eigen::Vector3d(p[0], p[1], p[2]);
}
double SceneEnv::CubeTargetYaw() const { return QuatYaw(data()->mocap_quat + 4 * goal_mocap_); }
double SceneEnv::CubeYaw() const { return QuatYaw(data()->qpos + cube_qpos_ + 3); }
double SceneEnv::Drawer() const { return data()->qpos[drawer_qpos_]; }
double SceneEnv::Window() const { return data()->qpos[window_qpos_]; }

Eigen::Vector3d SceneEnv::ButtonTop(int k) const {
  const mjtNum* p = data()->site_xpos + 3 * button_site_.at(static_cast<size_t>(k));
  return Eigen::Vector3d(p[0], p[1], p[2]);
}
Eigen::Vector3d SceneEnv::DrawerHandle() const {
  const mjtNum* p = data()->site_xpos + 3 * drawer_handle_site_;
  return Eigen::Vector3d(p[0], p[1], p[2]);
}
Eigen::Vector3d SceneEnv::WindowHandle() const {
  const mjtNum* p = data()->site_xpos + 3 * window_handle_site_;
  return Eigen::Vector3d(p[0], p[1], p[2]);
}

Eigen::Vector3d SceneEnv::DrawerPosition() const {
  const mjtNum* p = data()->xpos + 3 * drawer_body_;
  return Eigen::Vector3d(p[0], p[1], p[2]);
}
Eigen::Vector3d SceneEnv::WindowPosition() const {
  const mjtNum* p = data()->xpos + 3 * window_body_;
  return Eigen::Vector3d(p[0], p[1], p[2]);
}
double SceneEnv::ButtonJoint(int k) const {
  return data()->qpos[button_qpos_.at(static_cast<size_t>(k))];
}

SceneState SceneEnv::StateFromObservation(const std::vector<float>& obs, double* cube_yaw) {
  if (obs.size() != kObservationSize)
    throw std::invalid_argument("a scene observation has 40 entries, got " +
                                std::to_string(obs.size()));
  SceneState s;
  s.cube = internal::kObservationCentre + Eigen::Vector3d(obs[19], obs[20], obs[21]) / 10.0;
  if (cube_yaw) *cube_yaw = std::atan2(obs[27], obs[26]);
  for (int k = 0; k < 2; ++k)
    s.buttons[static_cast<size_t>(k)] = ButtonStateFromOneHot(
        obs[static_cast<size_t>(28 + 4 * k)], obs[static_cast<size_t>(29 + 4 * k)], k);
  s.drawer = obs[36] / 18.0;
  s.window = obs[38] / 15.0;
  return s;
}

}  // namespace msspr::sim
