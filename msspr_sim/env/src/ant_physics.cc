#include "ant_physics.h"

#include <algorithm>
#include <cstring>
#include <stdexcept>

#include "msspr_sim/ant_model.h"
#include "msspr_sim/random_util.h"

namespace msspr::sim::internal {
namespace {

// OGBench's reset_noise_scale.
constexpr double kResetNoise = 0.1;

}  // namespace

AntPhysics::AntPhysics(const std::string& xml, const std::string& name) {
  InstallMujocoHandlers();
  model_ = SharedInlineModel(xml, name);
  const mjModel* m = model_.get();
  if (m->nq != kAntQposDim || m->nv != kAntQvelDim || m->nu != kAntActionDim) {
    throw std::logic_error("AntPhysics: the model must have nq 15, nv 14, nu 8");
  }
  for (int k = 0; k < kAntActionDim; ++k) {
    const int hinge = mj_name2id(m, mjOBJ_JOINT, kAntHingeJoints[k]);
    if (hinge < 0 || m->jnt_qposadr[hinge] != 7 + k || m->jnt_dofadr[hinge] != 6 + k) {
      throw std::logic_error(std::string("AntPhysics: joint ") + kAntHingeJoints[k] +
                             " is not at qpos " + std::to_string(7 + k));
    }
    const int driven = mj_name2id(m, mjOBJ_JOINT, kAntActuatorJoints[k]);
    if (m->actuator_trntype[k] != mjTRN_JOINT || m->actuator_trnid[2 * k] != driven) {
      throw std::logic_error("AntPhysics: actuator " + std::to_string(k) + " must drive " +
                             kAntActuatorJoints[k]);
    }
  }
  data_.reset(mj_makeData(m));
  if (!data_) throw std::runtime_error("MuJoCo: mj_makeData failed");
  mj_forward(m, data_.get());
}

void AntPhysics::ResetNoisy(std::mt19937_64& rng) {
  const mjModel* m = model_.get();
  mjData* d = data_.get();
  mj_resetData(m, d);
  const auto qpos0 = AntQpos0();
  for (int k = 0; k < kAntQposDim; ++k) {
    d->qpos[k] = qpos0[k] + Uniform(rng, -kResetNoise, kResetNoise);
  }
  for (int k = 0; k < kAntQvelDim; ++k) d->qvel[k] = kResetNoise * StandardNormal(rng);
  mj_forward(m, d);
}

void AntPhysics::Step(const Eigen::VectorXd& action) {
  if (action.size() != kAntActionDim) {
    throw std::invalid_argument("Ant: the action must have 8 values, got " +
                                std::to_string(action.size()));
  }
  if (!action.allFinite()) throw std::invalid_argument("Ant: the action must be finite");
  const mjModel* m = model_.get();
  mjData* d = data_.get();
  for (int k = 0; k < kAntActionDim; ++k) d->ctrl[k] = std::clamp(action[k], -1.0, 1.0);
  for (int s = 0; s < kAntFrameSkip; ++s) mj_step(m, d);
}

void AntPhysics::SetXY(const Eigen::Vector2d& xy) {
  if (!xy.allFinite()) throw std::invalid_argument("Ant: xy must be finite");
  data_->qpos[0] = xy.x();
  data_->qpos[1] = xy.y();
  mj_forward(model_.get(), data_.get());
}

void AntPhysics::SetState(const Eigen::VectorXd& qpos, const Eigen::VectorXd& qvel) {
  if (qpos.size() != kAntQposDim || qvel.size() != kAntQvelDim) {
    throw std::invalid_argument("Ant: SetState needs qpos of 15 and qvel of 14 values");
  }
  if (!qpos.allFinite() || !qvel.allFinite()) {
    throw std::invalid_argument("Ant: SetState needs finite values");
  }
  std::memcpy(data_->qpos, qpos.data(), sizeof(double) * kAntQposDim);
  std::memcpy(data_->qvel, qvel.data(), sizeof(double) * kAntQvelDim);
  mj_forward(model_.get(), data_.get());
}

Eigen::VectorXd AntPhysics::qpos() const {
  return Eigen::Map<const Eigen::VectorXd>(data_->qpos, kAntQposDim);
}

Eigen::VectorXd AntPhysics::qvel() const {
  return Eigen::Map<const Eigen::VectorXd>(data_->qvel, kAntQvelDim);
}

Eigen::VectorXd AntPhysics::FullObservation() const {
  Eigen::VectorXd ob(kAntQposDim + kAntQvelDim);
  ob << qpos(), qvel();
  return ob;
}

std::vector<PointMaze::AgentJoint> AntPhysics::Joints() const {
  return internal::ModelJoints(model_.get());
}

}  // namespace msspr::sim::internal
