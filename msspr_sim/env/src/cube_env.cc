#include "msspr_sim/cube_env.h"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "msspr_sim/random_util.h"
#include "mujoco_util.h"
#include "offscreen_renderer.h"

namespace msspr::sim {
namespace {

// OGBench's home joints (rad) and the observation's centre c (m).
const double kHome[6] = {-M_PI / 2, -M_PI / 2, M_PI / 2, -M_PI / 2, -M_PI / 2, 0};
const Eigen::Vector3d kCentre(0.425, 0, 0);

// ZYX yaw of a quaternion (w, x, y, z); independent of its sign.
double Yaw(double w, double x, double y, double z) {
  return std::atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z));
}

int RequireId(const mjModel* m, mjtObj type, const std::string& name, const char* what) {
  const int id = mj_name2id(m, type, name.c_str());
  if (id < 0)
    throw std::logic_error(std::string("CubeEnv: the scene has no ") + what + " '" + name + "'");
  return id;
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
  return kCentre + Eigen::Vector3d(obs[19], obs[20], obs[21]) / 10.0;
}
double CubeYawFromObservation(const float* obs) { return std::atan2(obs[27], obs[26]); }

Eigen::Matrix3d PinchDownRotation(double yaw) {
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

struct CubeEnv::Impl {
  internal::ModelPtr model;
  internal::DataPtr data;
  int arm_qpos[6], arm_qvel[6], arm_actuator[6];
  std::vector<int> finger_qpos;  // every finger joint (independent and mimics)
  std::vector<double> finger_multiplier, finger_offset;
  int gripper_qpos = -1;  // the independent finger joint
  int gripper_actuator = -1;
  int cube_qpos = -1, cube_qvel = -1;
  int pinch_site = -1;
  int contact_body = -1;  // the body of the right pad (OGBench's right_pad)
  int goal_mocap = -1;

  // Rendering (only with enable_rendering); it reads the physics data.
  std::unique_ptr<internal::OffscreenRenderer> renderer;
};

CubeEnv::CubeEnv(const CubeEnvOptions& options)
    : options_(options), impl_(std::make_unique<Impl>()) {
  if (options.substeps < 1) throw std::invalid_argument("CubeEnvOptions: substeps must be >= 1");
  internal::InstallMujocoHandlers();
  arm_ = std::make_unique<ArmModel>(ArmModel::FromFile(options.urdf_path));
  ik_ = std::make_unique<ArmIk>(*arm_, options.ik);
  mjcf_ = CubeSceneMjcf(*arm_, options.scene);
  impl_->model = internal::LoadInlineModel(mjcf_, "cube_single_scene");
  const mjModel* m = impl_->model.get();
  impl_->data.reset(mj_makeData(m));
  if (!impl_->data) throw std::runtime_error("MuJoCo: mj_makeData failed");

  for (int i = 0; i < 6; ++i) {
    const std::string& joint = arm_->links()[arm_->arm_joint_links()[i]].joint;
    const int j = RequireId(m, mjOBJ_JOINT, joint, "joint");
    impl_->arm_qpos[i] = m->jnt_qposadr[j];
    impl_->arm_qvel[i] = m->jnt_dofadr[j];
    impl_->arm_actuator[i] = RequireId(m, mjOBJ_ACTUATOR, joint, "actuator");
  }
  const int grip_dof = arm_->links()[arm_->gripper_link()].dof;
  for (const auto& l : arm_->links()) {
    if (l.dof != grip_dof || l.type == ArmModel::JointType::kFixed) continue;
    const int j = RequireId(m, mjOBJ_JOINT, l.joint, "joint");
    impl_->finger_qpos.push_back(m->jnt_qposadr[j]);
    impl_->finger_multiplier.push_back(l.multiplier);
    impl_->finger_offset.push_back(l.offset);
    if (!l.mimic) impl_->gripper_qpos = m->jnt_qposadr[j];
  }
  impl_->gripper_actuator = RequireId(m, mjOBJ_ACTUATOR, "gripper", "actuator");
  const int cube_joint = RequireId(m, mjOBJ_JOINT, "object_joint_0", "joint");
  impl_->cube_qpos = m->jnt_qposadr[cube_joint];
  impl_->cube_qvel = m->jnt_dofadr[cube_joint];
  impl_->pinch_site = RequireId(m, mjOBJ_SITE, arm_->links()[arm_->tip_link()].name, "site");
  impl_->contact_body =
      m->geom_bodyid[RequireId(m, mjOBJ_GEOM, options.scene.pad_geoms[1], "geom")];
  impl_->goal_mocap = m->body_mocapid[RequireId(m, mjOBJ_BODY, "object_target_0", "body")];

  // The flange target is the pinch target times this fixed transform.
  const Eigen::VectorXd q0 = Eigen::VectorXd::Zero(arm_->num_dofs());
  pinch_to_flange_ =
      arm_->LinkPose(arm_->tip_link(), q0).inverse() * arm_->LinkPose(arm_->flange_link(), q0);

  SetArmJoints(Eigen::Map<const Eigen::Matrix<double, 6, 1>>(kHome));
  SetOpening(0.0);

  if (options.enable_rendering) {
    const int size = options.image_size;
    if (size < 1 || size > 4096)
      throw std::invalid_argument("CubeEnvOptions: image_size must be in [1, 4096], got " +
                                  std::to_string(size));
    // Default visibility: geom groups 0-2 (floor, cube, robot visuals);
    // collision geoms and walls (3), sites (4) and a pixel-mode goal (5) hidden.
    const int camera = RequireId(m, mjOBJ_CAMERA, options.camera, "camera");
    impl_->renderer = std::make_unique<internal::OffscreenRenderer>(m, size, camera);
  }
}

CubeEnv::~CubeEnv() = default;

void CubeEnv::SetArmJoints(const Eigen::Matrix<double, 6, 1>& q) {
  mjData* d = impl_->data.get();
  for (int i = 0; i < 6; ++i) {
    d->qpos[impl_->arm_qpos[i]] = q[i];
    d->qvel[impl_->arm_qvel[i]] = 0;
    d->ctrl[impl_->arm_actuator[i]] = q[i];
  }
  mj_forward(impl_->model.get(), d);
}

bool CubeEnv::PlacePinch(const Eigen::Vector3d& position, double yaw) {
  Eigen::Isometry3d pinch = Eigen::Isometry3d::Identity();
  pinch.linear() = PinchDownRotation(yaw);
  pinch.translation() = position;
  Eigen::VectorXd q0 = Eigen::VectorXd::Zero(arm_->num_dofs());
  for (int i = 0; i < 6; ++i) q0[i] = kHome[i];
  const ArmIkResult r = ik_->Solve(pinch * pinch_to_flange_, arm_->flange_link(), q0);
  SetArmJoints(r.q.head<6>());
  return r.converged;
}

void CubeEnv::SetOpening(double opening) {
  opening = std::clamp(opening, 0.0, 1.0);
  mjData* d = impl_->data.get();
  const double travel = opening * options_.scene.gripper_travel;
  for (size_t f = 0; f < impl_->finger_qpos.size(); ++f)
    d->qpos[impl_->finger_qpos[f]] = impl_->finger_multiplier[f] * travel + impl_->finger_offset[f];
  d->ctrl[impl_->gripper_actuator] = 255.0 * opening;
  mj_forward(impl_->model.get(), d);
}

void CubeEnv::SetCube(const Eigen::Vector3d& position, double yaw) {
  mjData* d = impl_->data.get();
  mjtNum* q = d->qpos + impl_->cube_qpos;
  q[0] = position.x();
  q[1] = position.y();
  q[2] = position.z();
  q[3] = std::cos(yaw / 2);
  q[4] = 0;
  q[5] = 0;
  q[6] = std::sin(yaw / 2);
  for (int i = 0; i < 6; ++i) d->qvel[impl_->cube_qvel + i] = 0;
  mj_forward(impl_->model.get(), d);
}

void CubeEnv::SetGoal(const Eigen::Vector3d& position, double yaw) {
  mjData* d = impl_->data.get();
  for (int i = 0; i < 3; ++i) d->mocap_pos[3 * impl_->goal_mocap + i] = position[i];
  mjtNum* q = d->mocap_quat + 4 * impl_->goal_mocap;
  q[0] = std::cos(yaw / 2);
  q[1] = 0;
  q[2] = 0;
  q[3] = std::sin(yaw / 2);
  // No mj_forward: it would refresh the arm's poses that mj_step leaves one
  // substep old, so an oracle setting a new target mid-episode would change
  // the observations and a replay of the stored actions would not match.
  // The marker's pose updates at the next step (it never touches physics).
}

Eigen::Vector3d CubeEnv::PinchPosition() const {
  const mjtNum* p = impl_->data->site_xpos + 3 * impl_->pinch_site;
  return Eigen::Vector3d(p[0], p[1], p[2]);
}

double CubeEnv::PinchYaw() const {
  mjtNum quat[4];
  mju_mat2Quat(quat, impl_->data->site_xmat + 9 * impl_->pinch_site);
  return Yaw(quat[0], quat[1], quat[2], quat[3]);
}

Eigen::Matrix3d CubeEnv::PinchRotation() const {
  return Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(impl_->data->site_xmat +
                                                                        9 * impl_->pinch_site);
}

double CubeEnv::CubeYaw() const {
  const mjtNum* q = impl_->data->qpos + impl_->cube_qpos + 3;
  return Yaw(q[0], q[1], q[2], q[3]);
}

double CubeEnv::Opening() const {
  return std::clamp(impl_->data->qpos[impl_->gripper_qpos] / options_.scene.gripper_travel, 0.0,
                    1.0);
}

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
  return Yaw(q[0], q[1], q[2], q[3]);
}

bool CubeEnv::Success() const {
  return (CubePosition() - GoalPosition()).norm() <= options_.success_distance;
}

Eigen::Matrix<double, 6, 1> CubeEnv::ArmJoints() const {
  Eigen::Matrix<double, 6, 1> q;
  for (int i = 0; i < 6; ++i) q[i] = impl_->data->qpos[impl_->arm_qpos[i]];
  return q;
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
  const auto& s = options_.action_scale;
  // Deltas apply to the measured pose, not to the previous target (OGBench).
  const Eigen::Vector3d target =
      (PinchPosition() + Eigen::Vector3d(action[0] * s[0], action[1] * s[1], action[2] * s[2]))
          .cwiseMax(options_.pinch_low)
          .cwiseMin(options_.pinch_high);
  const double yaw = std::remainder(PinchYaw() + action[3] * s[3], 2 * M_PI);
  const double opening = std::clamp(Opening() + action[4] * s[4], 0.0, 1.0);

  Eigen::Isometry3d pinch = Eigen::Isometry3d::Identity();
  pinch.linear() = PinchDownRotation(yaw);
  pinch.translation() = target;
  Eigen::VectorXd q0 = Eigen::VectorXd::Zero(arm_->num_dofs());
  q0.head<6>() = ArmJoints();
  const ArmIkResult r = ik_->Solve(pinch * pinch_to_flange_, arm_->flange_link(), q0);
  last_ik_converged_ = r.converged;
  for (int i = 0; i < 6; ++i) d->ctrl[impl_->arm_actuator[i]] = r.q[i];
  d->ctrl[impl_->gripper_actuator] = 255.0 * opening;

  for (int k = 0; k < options_.substeps; ++k) mj_step(m, d);
  // cfrc_ext (the contact feature) is filled only by this call.
  mj_rnePostConstraint(m, d);
  ++episode_steps_;
  return Success();
}

void CubeEnv::RandomizeArm(std::mt19937_64& rng) {
  Eigen::Vector3d p;
  for (int i = 0; i < 3; ++i) p[i] = Uniform(rng, options_.init_low[i], options_.init_high[i]);
  const double yaw = Uniform(rng, -M_PI, M_PI);
  // Failing to converge in 20 iterations from home leaves a pose close to the
  // target; OGBench goes on with it too.
  PlacePinch(p, yaw);
  SetOpening(0.0);
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
  for (int i = 0; i < 6; ++i) {
    o[i] = static_cast<float>(d->qpos[impl_->arm_qpos[i]]);
    o[6 + i] = static_cast<float>(d->qvel[impl_->arm_qvel[i]]);
  }
  const Eigen::Vector3d pinch = 10 * (PinchPosition() - kCentre);
  const double yaw = PinchYaw();
  for (int i = 0; i < 3; ++i) o[12 + i] = static_cast<float>(pinch[i]);
  o[15] = static_cast<float>(std::cos(yaw));
  o[16] = static_cast<float>(std::sin(yaw));
  o[17] = static_cast<float>(3 * Opening());
  // OGBench: the norm of the pad body's 6-D external (contact) wrench / 50.
  // Our pad is a geom of the finger body, so the whole finger's contacts count.
  const double force =
      Eigen::Map<const Eigen::Matrix<double, 6, 1>>(d->cfrc_ext + 6 * impl_->contact_body).norm();
  o[18] = static_cast<float>(std::clamp(force / 50, 0.0, 1.0));
  const Eigen::Vector3d cube = 10 * (CubePosition() - kCentre);
  for (int i = 0; i < 3; ++i) o[19 + i] = static_cast<float>(cube[i]);
  const mjtNum* q = d->qpos + impl_->cube_qpos + 3;
  for (int i = 0; i < 4; ++i) o[22 + i] = static_cast<float>(q[i]);
  const double cube_yaw = Yaw(q[0], q[1], q[2], q[3]);
  o[26] = static_cast<float>(std::cos(cube_yaw));
  o[27] = static_cast<float>(std::sin(cube_yaw));
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
