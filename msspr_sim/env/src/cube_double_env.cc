#include "msspr_sim/cube_double_env.h"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "arm_rig.h"
#include "msspr_sim/random_util.h"

namespace msspr::sim {

using internal::QuatYaw;
namespace {

const char* const kColour[2] = {"0.96 0.26 0.33", "0.35 0.55 0.91"};  // red, blue

void CheckCube(int i) {
  if (i < 0 || i >= CubeDoubleEnv::kCubes)
    throw std::out_of_range("CubeDoubleEnv: cube must be 0 or 1, got " + std::to_string(i));
}

}  // namespace

const std::array<CubeDoubleTask, 5>& CubeDoubleTasks() {
  using V = Eigen::Vector3d;
  static const std::array<CubeDoubleTask, 5> tasks = {{
      {"single_pnp",
       {V(0.425, 0.0, 0.02), V(0.425, -0.10, 0.02)},
       {V(0.425, 0.0, 0.02), V(0.425, 0.10, 0.02)}},
      {"double_pnp1",
       {V(0.35, -0.10, 0.02), V(0.50, -0.10, 0.02)},
       {V(0.35, 0.10, 0.02), V(0.50, 0.10, 0.02)}},
      {"double_pnp2",
       {V(0.35, 0.0, 0.02), V(0.50, 0.0, 0.02)},
       {V(0.425, -0.20, 0.02), V(0.425, 0.20, 0.02)}},
      {"swap",
       {V(0.425, -0.10, 0.02), V(0.425, 0.10, 0.02)},
       {V(0.425, 0.10, 0.02), V(0.425, -0.10, 0.02)}},
      {"stack",
       {V(0.425, -0.20, 0.02), V(0.425, 0.20, 0.02)},
       {V(0.425, 0.0, 0.02), V(0.425, 0.0, 0.06)}},
  }};
  return tasks;
}

std::string CubeDoubleObjectsMjcf(bool pixel_style) {
  std::ostringstream x;
  for (int i = 0; i < CubeDoubleEnv::kCubes; ++i) {
    const double y = -0.05 + 0.1 * i;
    x << "    <body name=\"object_" << i << "\" pos=\"0.3 " << y << " 0.02\">\n"
      << "      <freejoint name=\"object_joint_" << i << "\"/>\n"
      << "      <geom name=\"cube_" << i
      << "\" type=\"box\" size=\"0.02 0.02 0.02\" density=\"1240\" solref=\"0.004 1\""
         " contype=\"3\" conaffinity=\"1\" group=\"1\" rgba=\""
      << kColour[i] << " 1\"/>\n"
      << "    </body>\n"
      << "    <body name=\"object_target_" << i << "\" mocap=\"true\" pos=\"0.45 " << y
      << " 0.02\">\n"
      << "      <geom name=\"goal_" << i
      << "\" type=\"box\" size=\"0.02 0.02 0.02\" contype=\"0\" conaffinity=\"0\" group=\""
      << (pixel_style ? 5 : 1) << "\" rgba=\"" << kColour[i] << " 0.2\"/>\n"
      << "    </body>\n";
  }
  return x.str();
}

CubeDoubleEnv::CubeDoubleEnv(const CubeDoubleEnvOptions& options)
    : ArmEnv(options, "cube_double", CubeDoubleObjectsMjcf(options.scene.pixel_style),
             "CubeDoubleEnv"),
      options_(options) {
  const mjModel* m = model();
  for (int i = 0; i < kCubes; ++i) {
    const std::string s = std::to_string(i);
    const int j = RequireId(mjOBJ_JOINT, "object_joint_" + s, "joint");
    cube_qpos_[i] = m->jnt_qposadr[j];
    cube_qvel_[i] = m->jnt_dofadr[j];
    goal_mocap_[i] = m->body_mocapid[RequireId(mjOBJ_BODY, "object_target_" + s, "body")];
  }
  goal_observation_.assign(kObservationSize, 0.f);
}

bool CubeDoubleEnv::Step(const Action& action) {
  StepPhysics(action);
  // cfrc_ext (the contact feature) is filled only by this call.
  mj_rnePostConstraint(model(), data());
  ++episode_steps_;
  return Success();
}

void CubeDoubleEnv::SetCube(int i, const Eigen::Vector3d& position, double yaw) {
  CheckCube(i);
  internal::PlaceFreeBody(data(), cube_qpos_[i], cube_qvel_[i], position, yaw);
  mj_forward(model(), data());
}

void CubeDoubleEnv::SetGoal(int i, const Eigen::Vector3d& position, double yaw) {
  CheckCube(i);
  internal::PlaceMocap(data(), goal_mocap_[i], position, yaw);
  // No mj_forward, as CubeEnv::SetGoal: a replay of stored actions must see the same poses.
}

Eigen::Vector3d CubeDoubleEnv::CubePosition(int i) const {
  CheckCube(i);
  const mjtNum* q = data()->qpos + cube_qpos_[i];
  return Eigen::Vector3d(q[0], q[1], q[2]);
}

double CubeDoubleEnv::CubeYaw(int i) const {
  CheckCube(i);
  return QuatYaw(data()->qpos + cube_qpos_[i] + 3);
}

Eigen::Vector3d CubeDoubleEnv::GoalPosition(int i) const {
  CheckCube(i);
  const mjtNum* p = data()->mocap_pos + 3 * goal_mocap_[i];
  return Eigen::Vector3d(p[0], p[1], p[2]);
}

double CubeDoubleEnv::GoalYaw(int i) const {
  CheckCube(i);
  return QuatYaw(data()->mocap_quat + 4 * goal_mocap_[i]);
}

bool CubeDoubleEnv::CubeAtGoal(int i) const {
  return (CubePosition(i) - GoalPosition(i)).norm() <= options_.success_distance;
}

bool CubeDoubleEnv::IsTop(int i) const {
  const Eigen::Vector3d p = CubePosition(i);
  for (int j = 0; j < kCubes; ++j) {
    if (j == i) continue;
    const Eigen::Vector3d o = CubePosition(j);
    if (o.z() > p.z() && (o - p).head<2>().norm() < 0.02) return false;
  }
  return true;
}

int CubeDoubleEnv::SetNewTarget(std::mt19937_64& rng, double p_stack) {
  std::vector<int> top;
  for (int i = 0; i < kCubes; ++i)
    if (IsTop(i)) top.push_back(i);
  const int target = top[UniformIndex(rng, top.size())];
  Eigen::Vector3d goal;
  if (top.size() >= 2 && Uniform01(rng) < p_stack) {
    const int other = top[0] == target ? top[1] : top[0];
    goal = CubePosition(other) + Eigen::Vector3d(0, 0, 0.04);
  } else {
    goal = Eigen::Vector3d(Uniform(rng, options_.object_low.x(), options_.object_high.x()),
                           Uniform(rng, options_.object_low.y(), options_.object_high.y()), 0.02);
  }
  SetGoal(target, goal, Uniform(rng, 0.0, 2 * M_PI));
  for (int i = 0; i < kCubes; ++i)
    if (i != target) SetGoal(i, Eigen::Vector3d(0, 0, -0.3));
  target_cube_ = target;
  return target;
}

CubeDoubleEnv::Observation CubeDoubleEnv::ResetToTask(int task, uint64_t seed) {
  if (task < 1 || task > static_cast<int>(CubeDoubleTasks().size()))
    throw std::out_of_range("CubeDoubleEnv::ResetToTask: task must be 1 to 5, got " +
                            std::to_string(task));
  const CubeDoubleTask& t = CubeDoubleTasks()[task - 1];
  std::mt19937_64 rng(Mix64(seed));
  mj_resetData(model(), data());
  target_cube_ = -1;
  // Row r goes to cube row_cube[r] (OGBench's permute_blocks).
  const bool swap = UniformIndex(rng, 2) == 1;
  const int row_cube[2] = {swap ? 1 : 0, swap ? 0 : 1};
  for (int r = 0; r < 2; ++r) SetGoal(row_cube[r], t.goal[r]);

  // The goal observation: a random arm, both cubes at rest at their goals, two random actions.
  RandomizeArm(rng);
  for (int r = 0; r < 2; ++r) SetCube(row_cube[r], t.goal[r], 0.0);
  RecordGoal(*this, rng, 2, std::nan(""), &goal_observation_, &goal_image_);

  RandomizeArm(rng);
  for (int r = 0; r < 2; ++r) {
    const double dx = Uniform(rng, -0.01, 0.01), dy = Uniform(rng, -0.01, 0.01);
    SetCube(row_cube[r], t.start[r] + Eigen::Vector3d(dx, dy, 0), Uniform(rng, 0.0, 2 * M_PI));
  }
  mj_forward(model(), data());  // pose the markers too
  episode_steps_ = 0;
  return GetObservation();
}

CubeDoubleEnv::Observation CubeDoubleEnv::ResetForCollection(uint64_t seed) {
  std::mt19937_64 rng(Mix64(seed));
  mj_resetData(model(), data());
  RandomizeArm(rng);
  for (int i = 0; i < kCubes; ++i) {
    const Eigen::Vector3d p(Uniform(rng, options_.object_low.x(), options_.object_high.x()),
                            Uniform(rng, options_.object_low.y(), options_.object_high.y()), 0.02);
    SetCube(i, p, Uniform(rng, 0.0, 2 * M_PI));
  }
  SetNewTarget(rng, 0.5);
  mj_forward(model(), data());  // pose the markers too
  goal_observation_.assign(kObservationSize, 0.f);
  goal_image_.clear();
  episode_steps_ = 0;
  return GetObservation();
}

CubeDoubleEnv::Observation CubeDoubleEnv::GetObservation() const {
  Observation o(kObservationSize);
  WriteProprio(o.data());
  for (int i = 0; i < kCubes; ++i) {
    float* c = o.data() + kProprioSize + 9 * i;
    const Eigen::Vector3d p = 10 * (CubePosition(i) - internal::kObservationCentre);
    for (int k = 0; k < 3; ++k) c[k] = static_cast<float>(p[k]);
    const mjtNum* q = data()->qpos + cube_qpos_[i] + 3;
    for (int k = 0; k < 4; ++k) c[3 + k] = static_cast<float>(q[k]);
    const double yaw = QuatYaw(q);
    c[7] = static_cast<float>(std::cos(yaw));
    c[8] = static_cast<float>(std::sin(yaw));
  }
  return o;
}

}  // namespace msspr::sim
