#include "msspr_sim/puzzle_env.h"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

#include "msspr_sim/random_util.h"

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

int ButtonStateFromOneHot(float a, float b, int k) {
  if (a == 1.f && b == 0.f) return 0;
  if (a == 0.f && b == 1.f) return 1;
  throw std::invalid_argument("button " + std::to_string(k) +
                              "'s state entries must be (1, 0) or (0, 1)");
}

std::string PushButtonMjcf(int k, double x, double y, double top_site) {
  // The box is turned -1.57 rad about x, as OGBench's (its local -y is world +z, up to a
  // 0.0008 tilt), so local (x, -h, w) is world (x, w, h) from the box origin at z 0.048.
  std::ostringstream o;
  o.precision(17);
  o << "    <body name=\"buttonbox_" << k << "\" pos=\"" << x << ' ' << y
    << " 0.048\" euler=\"-1.57 0 0\">\n"
    // The fixed box: 9.6 x 9.6 cm, world z 0.0024-0.084, a 2.08 x 1.92 cm hole for the stem
    // (four colliding boxes, hidden), drawn as one dark box.
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
    // Up at 0, pressed toward -0.024; the spring (0.5 N/m about 0.5 m) lifts it with about
    // 0.25 N over the whole travel.
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
    << "        <site name=\"btntop_" << k << "\" pos=\"0 " << -top_site
    << " 0\" size=\"0.005\" group=\"4\"/>\n"
    << "      </body>\n"
    << "    </body>\n";
  return o.str();
}

std::string PuzzleButtonsMjcf(int side) {
  CheckedSide(side);
  std::string xml;
  for (int i = 0; i < side; ++i)
    for (int j = 0; j < side; ++j)
      xml += PushButtonMjcf(i * side + j, 0.425 - 0.05 * (side - 1) + 0.1 * i,
                            -0.05 * (side - 1) + 0.1 * j, 0.0774);
  return xml;
}

PuzzleEnv::PuzzleEnv(const PuzzleEnvOptions& options)
    : ArmEnv(options,
             "puzzle_" + std::to_string(CheckedSide(options.side)) + "x" +
                 std::to_string(options.side),
             PuzzleButtonsMjcf(options.side), "PuzzleEnv"),
      options_(options),
      board_(options.side, options.side) {
  const mjModel* m = model();
  for (int k = 0; k < num_buttons(); ++k) {
    const std::string s = std::to_string(k);
    const int j = RequireId(mjOBJ_JOINT, "buttonbox_joint_" + s, "joint");
    button_qpos_.push_back(m->jnt_qposadr[j]);
    button_qvel_.push_back(m->jnt_dofadr[j]);
    button_site_.push_back(RequireId(mjOBJ_SITE, "btntop_" + s, "site"));
    button_geom_.push_back(RequireId(mjOBJ_GEOM, "btngeom_" + s, "geom"));
  }
  states_.assign(num_buttons(), 0);
  goal_states_.assign(num_buttons(), 0);
  goal_observation_.assign(observation_size(), 0.f);
}

void PuzzleEnv::ApplyButtonColours() {
  mjModel* m = model();
  for (int k = 0; k < num_buttons(); ++k)
    std::copy(kStateColour[states_[k]], kStateColour[states_[k]] + 4,
              m->geom_rgba + 4 * button_geom_[k]);
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
  const mjModel* m = model();
  mjData* d = data();
  const int n = num_buttons();
  std::vector<double> before(n);
  for (int k = 0; k < n; ++k) before[k] = d->qpos[button_qpos_[k]];
  StepPhysics(action);
  for (int k = 0; k < n; ++k) {
    if (before[k] > options_.press_depth && d->qpos[button_qpos_[k]] <= options_.press_depth) {
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

PuzzleEnv::Observation PuzzleEnv::ResetToTask(int task, uint64_t seed) {
  const std::vector<LightsOutTask>& tasks = PuzzleTasks(options_.side);
  if (task < 1 || task > static_cast<int>(tasks.size()))
    throw std::out_of_range("PuzzleEnv::ResetToTask: task must be 1 to 5, got " +
                            std::to_string(task));
  const LightsOutTask& t = tasks[task - 1];
  mjData* d = data();
  std::mt19937_64 rng(Mix64(seed));
  mj_resetData(model(), d);
  presses_ = 0;

  // The goal observation: the goal board, a random arm, random actions closing the gripper.
  SetButtonStates(t.goal);
  RandomizeArm(rng);
  RecordGoal(*this, rng, options_.goal_random_steps, 1.0, &goal_observation_, &goal_image_);

  RandomizeArm(rng);
  SetButtonStates(t.start);
  SetGoalStates(t.goal);
  mj_forward(model(), d);
  presses_ = 0;
  episode_steps_ = 0;
  return GetObservation();
}

PuzzleEnv::Observation PuzzleEnv::ResetForCollection(uint64_t seed) {
  std::mt19937_64 rng(Mix64(seed));
  mj_resetData(model(), data());
  RandomizeArm(rng);
  LightsOutState s(num_buttons());
  for (uint8_t& x : s) x = static_cast<uint8_t>(UniformIndex(rng, 2));
  SetButtonStates(s);
  SetGoalStates(s);
  mj_forward(model(), data());
  goal_observation_.assign(observation_size(), 0.f);
  goal_image_.clear();
  presses_ = 0;
  episode_steps_ = 0;
  return GetObservation();
}

PuzzleEnv::Observation PuzzleEnv::GetObservation() const {
  const mjData* d = data();
  Observation o(observation_size());
  WriteProprio(o.data());
  for (int k = 0; k < num_buttons(); ++k) {
    float* b = o.data() + kProprioSize + 4 * k;
    b[0] = states_[k] == 0 ? 1.f : 0.f;
    b[1] = states_[k] == 0 ? 0.f : 1.f;
    b[2] = static_cast<float>(120 * d->qpos[button_qpos_[k]]);
    b[3] = static_cast<float>(d->qvel[button_qvel_[k]]);
  }
  return o;
}

Eigen::Vector3d PuzzleEnv::ButtonTop(int k) const {
  const mjtNum* p = data()->site_xpos + 3 * button_site_.at(k);
  return Eigen::Vector3d(p[0], p[1], p[2]);
}

double PuzzleEnv::ButtonJoint(int k) const { return data()->qpos[button_qpos_.at(k)]; }

}  // namespace msspr::sim
