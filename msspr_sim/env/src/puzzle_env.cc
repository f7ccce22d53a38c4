#include "msspr_sim/puzzle_env.h"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "arm_rig.h"
#include "msspr_sim/random_util.h"
#include "mujoco_util.h"
#include "offscreen_renderer.h"

namespace msspr::sim {
namespace {

// Cap colours: red in state 0, blue in state 1 (OGBench's puzzle).
const float kStateColour[2][4] = {{0.96f, 0.26f, 0.33f, 1.f}, {0.35f, 0.55f, 0.91f, 1.f}};

int CheckedSide(int side) {
  if (side != 3 && side != 4)
    throw std::invalid_argument("PuzzleEnvOptions: side must be 3 or 4, got " +
                                std::to_string(side));
  return side;
}

}  // namespace

std::string PuzzleButtonsMjcf(int side) {
  CheckedSide(side);
  // Each box is turned -1.57 rad about x, as OGBench's (its local -y is world +z, up to a
  // 0.0008 tilt), so local (x, -h, w) is world (x, w, h) from the box origin at z 0.048.
  std::ostringstream x;
  x.precision(17);
  for (int i = 0; i < side; ++i) {
    for (int j = 0; j < side; ++j) {
      const int k = i * side + j;
      const double bx = 0.425 - 0.05 * (side - 1) + 0.1 * i, by = -0.05 * (side - 1) + 0.1 * j;
      x << "    <body name=\"buttonbox_" << k << "\" pos=\"" << bx << ' ' << by
        << " 0.048\" euler=\"-1.57 0 0\">\n"
        // The fixed box: 9.6 x 9.6 cm, world z 0.0024-0.084, a 2.08 x 1.92 cm hole for the
        // stem (four colliding boxes, hidden), drawn as one dark box.
        << "      <geom type=\"box\" pos=\"0 0.0048 0\" size=\"0.048 0.0408 0.048\""
           " contype=\"0\" conaffinity=\"0\" group=\"1\" rgba=\"0.15 0.15 0.15 1\"/>\n"
        << "      <geom type=\"box\" pos=\"0 0.0048 0.0288\" size=\"0.048 0.0408 0.0192\""
           " group=\"4\"/>\n"
        << "      <geom type=\"box\" pos=\"0 0.0048 -0.0288\" size=\"0.048 0.0408 0.0192\""
           " group=\"4\"/>\n"
        << "      <geom type=\"box\" pos=\"0.0292 0.0048 0\" size=\"0.0188 0.0408 0.0096\""
           " group=\"4\"/>\n"
        << "      <geom type=\"box\" pos=\"-0.0292 0.0048 0\" size=\"0.0188 0.0408 0.0096\""
           " group=\"4\"/>\n"
        << "      <body name=\"button_" << k
        << "\">\n"
        // Up at 0, pressed toward -0.024; the spring (0.5 N/m about 0.5 m) lifts it with
        // about 0.25 N over the whole travel.
        << "        <joint name=\"buttonbox_joint_" << k
        << "\" type=\"slide\" axis=\"0 -1 0\" range=\"-0.024 0\" stiffness=\"0.5\""
           " springref=\"0.5\" damping=\"1\" armature=\"0.001\"/>\n"
        << "        <inertial pos=\"0 -0.06 0\" mass=\"0.01\" diaginertia=\"0.001 0.001 0.001\"/>\n"
        << "        <geom name=\"btngeom_" << k
        << "\" type=\"cylinder\" fromto=\"0 -0.0688 0 0 -0.0776 0\" size=\"0.0172\""
           " contype=\"1\" conaffinity=\"1\" group=\"1\" rgba=\"0.96 0.26 0.33 1\"/>\n"
        << "        <geom type=\"cylinder\" fromto=\"0 -0.0624 0 0 -0.0688 0\" size=\"0.0172\""
           " contype=\"1\" conaffinity=\"1\" group=\"1\" rgba=\"0.9 0.9 0.9 1\"/>\n"
        << "        <geom type=\"cylinder\" fromto=\"0 -0.0312 0 0 -0.0624 0\" size=\"0.0084\""
           " contype=\"1\" conaffinity=\"1\" group=\"1\" rgba=\"0.8 0.8 0.8 1\"/>\n"
        << "        <site name=\"btntop_" << k
        << "\" pos=\"0 -0.0774 0\" size=\"0.005\""
           " group=\"4\"/>\n"
        << "      </body>\n"
        << "    </body>\n";
    }
  }
  return x.str();
}

struct PuzzleEnv::Impl {
  Impl(const std::string& urdf_path, const ArmIkOptions& ik) : rig(urdf_path, ik) {}
  internal::ArmRig rig;
  internal::ModelPtr model;
  internal::DataPtr data;
  std::vector<int> button_qpos, button_qvel, button_site, button_geom;
  std::unique_ptr<internal::OffscreenRenderer> renderer;
};

PuzzleEnv::PuzzleEnv(const PuzzleEnvOptions& options)
    : options_(options), board_(CheckedSide(options.side), options.side) {
  if (options.substeps < 1) throw std::invalid_argument("PuzzleEnvOptions: substeps must be >= 1");
  internal::InstallMujocoHandlers();
  impl_ = std::make_unique<Impl>(options.urdf_path, options.ik);
  const std::string name =
      "puzzle_" + std::to_string(options.side) + "x" + std::to_string(options.side);
  mjcf_ = ArmSceneMjcf(impl_->rig.arm(), options.scene, name + "_" + impl_->rig.arm().name(),
                       PuzzleButtonsMjcf(options.side));
  impl_->model = internal::LoadInlineModel(mjcf_, name + "_scene");
  const mjModel* m = impl_->model.get();
  impl_->data.reset(mj_makeData(m));
  if (!impl_->data) throw std::runtime_error("MuJoCo: mj_makeData failed");
  impl_->rig.Bind(m, options.scene.pad_geoms[1], options.scene.gripper_travel, "PuzzleEnv");
  for (int k = 0; k < num_buttons(); ++k) {
    const std::string s = std::to_string(k);
    const int j = internal::RequireId(m, mjOBJ_JOINT, "buttonbox_joint_" + s, "joint", "PuzzleEnv");
    impl_->button_qpos.push_back(m->jnt_qposadr[j]);
    impl_->button_qvel.push_back(m->jnt_dofadr[j]);
    impl_->button_site.push_back(
        internal::RequireId(m, mjOBJ_SITE, "btntop_" + s, "site", "PuzzleEnv"));
    impl_->button_geom.push_back(
        internal::RequireId(m, mjOBJ_GEOM, "btngeom_" + s, "geom", "PuzzleEnv"));
  }
  states_.assign(num_buttons(), 0);
  goal_states_.assign(num_buttons(), 0);
  goal_observation_.assign(observation_size(), 0.f);
  SetArmJoints(Eigen::Map<const Eigen::Matrix<double, 6, 1>>(internal::kArmHome));
  SetOpening(0.0);
  if (options.enable_rendering) {
    const int size = options.image_size;
    if (size < 1 || size > 4096)
      throw std::invalid_argument("PuzzleEnvOptions: image_size must be in [1, 4096], got " +
                                  std::to_string(size));
    const int camera = internal::RequireId(m, mjOBJ_CAMERA, options.camera, "camera", "PuzzleEnv");
    impl_->renderer = std::make_unique<internal::OffscreenRenderer>(m, size, camera);
  }
}

PuzzleEnv::~PuzzleEnv() = default;

const ArmModel& PuzzleEnv::arm() const { return impl_->rig.arm(); }

void PuzzleEnv::ApplyButtonColours() {
  mjModel* m = impl_->model.get();
  for (int k = 0; k < num_buttons(); ++k)
    std::copy(kStateColour[states_[k]], kStateColour[states_[k]] + 4,
              m->geom_rgba + 4 * impl_->button_geom[k]);
}

void PuzzleEnv::SetButtonStates(const LightsOutState& states) {
  board_.Format(states);  // throws for a bad size or value
  states_ = states;
  ApplyButtonColours();
}

void PuzzleEnv::SetGoalStates(const LightsOutState& states) {
  board_.Format(states);
  goal_states_ = states;
}

bool PuzzleEnv::Step(const Action& action) {
  const mjModel* m = impl_->model.get();
  mjData* d = impl_->data.get();
  last_ik_converged_ = impl_->rig.SetControls(d, action, options_.action_scale, options_.pinch_low,
                                              options_.pinch_high);
  const int n = num_buttons();
  std::vector<double> before(n);
  for (int k = 0; k < n; ++k) before[k] = d->qpos[impl_->button_qpos[k]];
  for (int s = 0; s < options_.substeps; ++s) mj_step(m, d);
  for (int k = 0; k < n; ++k) {
    if (before[k] > options_.press_depth &&
        d->qpos[impl_->button_qpos[k]] <= options_.press_depth) {
      board_.Press(k, &states_);
      ++presses_;
    }
  }
  ApplyButtonColours();
  // OGBench's puzzle ends each step with mj_forward: observations read the final state.
  mj_forward(m, d);
  mj_rnePostConstraint(m, d);  // the pad contact feature
  ++episode_steps_;
  return Success();
}

void PuzzleEnv::RandomizeArm(std::mt19937_64& rng) {
  impl_->rig.Randomize(impl_->data.get(), rng, options_.init_low, options_.init_high);
}

PuzzleEnv::Observation PuzzleEnv::ResetToTask(int task, uint64_t seed) {
  const std::vector<LightsOutTask>& tasks = PuzzleTasks(options_.side);
  if (task < 1 || task > static_cast<int>(tasks.size()))
    throw std::out_of_range("PuzzleEnv::ResetToTask: task must be 1 to 5, got " +
                            std::to_string(task));
  const LightsOutTask& t = tasks[task - 1];
  const mjModel* m = impl_->model.get();
  mjData* d = impl_->data.get();
  std::mt19937_64 rng(Mix64(seed));
  mj_resetData(m, d);
  presses_ = 0;

  // The goal observation: the goal board, a random arm, random actions closing the gripper.
  SetButtonStates(t.goal);
  RandomizeArm(rng);
  const std::vector<mjtNum> qpos(d->qpos, d->qpos + m->nq), qvel(d->qvel, d->qvel + m->nv),
      ctrl(d->ctrl, d->ctrl + m->nu), act(d->act, d->act + m->na);
  const mjtNum time = d->time;
  for (int k = 0; k < options_.goal_random_steps; ++k) {
    Action a;
    for (double& x : a) x = Uniform(rng, -1.0, 1.0);
    a[4] = 1.0;
    Step(a);
  }
  goal_observation_ = GetObservation();
  goal_image_ = impl_->renderer ? Render() : std::vector<uint8_t>();
  std::copy(qpos.begin(), qpos.end(), d->qpos);
  std::copy(qvel.begin(), qvel.end(), d->qvel);
  std::copy(ctrl.begin(), ctrl.end(), d->ctrl);
  std::copy(act.begin(), act.end(), d->act);
  d->time = time;

  RandomizeArm(rng);
  SetButtonStates(t.start);
  SetGoalStates(t.goal);
  mj_forward(m, d);
  presses_ = 0;
  episode_steps_ = 0;
  return GetObservation();
}

PuzzleEnv::Observation PuzzleEnv::ResetForCollection(uint64_t seed) {
  std::mt19937_64 rng(Mix64(seed));
  mj_resetData(impl_->model.get(), impl_->data.get());
  RandomizeArm(rng);
  LightsOutState s(num_buttons());
  for (uint8_t& x : s) x = static_cast<uint8_t>(UniformIndex(rng, 2));
  SetButtonStates(s);
  SetGoalStates(s);
  mj_forward(impl_->model.get(), impl_->data.get());
  goal_observation_.assign(observation_size(), 0.f);
  goal_image_.clear();
  presses_ = 0;
  episode_steps_ = 0;
  return GetObservation();
}

PuzzleEnv::Observation PuzzleEnv::GetObservation() const {
  const mjData* d = impl_->data.get();
  Observation o(observation_size());
  impl_->rig.WriteProprio(d, o.data());
  for (int k = 0; k < num_buttons(); ++k) {
    float* b = o.data() + kProprioSize + 4 * k;
    b[0] = states_[k] == 0 ? 1.f : 0.f;
    b[1] = states_[k] == 0 ? 0.f : 1.f;
    b[2] = static_cast<float>(120 * d->qpos[impl_->button_qpos[k]]);
    b[3] = static_cast<float>(d->qvel[impl_->button_qvel[k]]);
  }
  return o;
}

Eigen::Vector3d PuzzleEnv::ButtonTop(int k) const {
  const mjtNum* p = impl_->data->site_xpos + 3 * impl_->button_site.at(k);
  return Eigen::Vector3d(p[0], p[1], p[2]);
}

double PuzzleEnv::ButtonJoint(int k) const { return impl_->data->qpos[impl_->button_qpos.at(k)]; }

void PuzzleEnv::SetArmJoints(const Eigen::Matrix<double, 6, 1>& q) {
  impl_->rig.SetArmJoints(impl_->data.get(), q);
}
bool PuzzleEnv::PlacePinch(const Eigen::Vector3d& position, double yaw) {
  return impl_->rig.PlacePinch(impl_->data.get(), position, yaw);
}
void PuzzleEnv::SetOpening(double opening) { impl_->rig.SetOpening(impl_->data.get(), opening); }
Eigen::Vector3d PuzzleEnv::PinchPosition() const {
  return impl_->rig.PinchPosition(impl_->data.get());
}
double PuzzleEnv::PinchYaw() const { return impl_->rig.PinchYaw(impl_->data.get()); }
Eigen::Matrix3d PuzzleEnv::PinchRotation() const {
  return impl_->rig.PinchRotation(impl_->data.get());
}
double PuzzleEnv::Opening() const { return impl_->rig.Opening(impl_->data.get()); }
Eigen::Matrix<double, 6, 1> PuzzleEnv::ArmJoints() const {
  return impl_->rig.ArmJoints(impl_->data.get());
}
std::vector<double> PuzzleEnv::Qpos() const {
  return std::vector<double>(impl_->data->qpos, impl_->data->qpos + impl_->model->nq);
}
std::vector<double> PuzzleEnv::Qvel() const {
  return std::vector<double>(impl_->data->qvel, impl_->data->qvel + impl_->model->nv);
}

std::vector<uint8_t> PuzzleEnv::Render() const {
  if (!impl_->renderer)
    throw std::logic_error("PuzzleEnv::Render: construct with enable_rendering = true");
  std::vector<uint8_t> rgb(static_cast<size_t>(options_.image_size) * options_.image_size * 3);
  impl_->renderer->Render(impl_->model.get(), impl_->data.get(), rgb.data());
  return rgb;
}

}  // namespace msspr::sim
