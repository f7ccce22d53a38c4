#include "arm_rig.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "msspr_sim/cube_env.h"  // PinchDownRotation
#include "msspr_sim/random_util.h"

namespace msspr::sim::internal {

const double kArmHome[6] = {-M_PI / 2, -M_PI / 2, M_PI / 2, -M_PI / 2, -M_PI / 2, 0};
const Eigen::Vector3d kObservationCentre(0.425, 0, 0);

double QuatYaw(double w, double x, double y, double z) {
  return std::atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z));
}

void PlaceFreeBody(mjData* d, int qpos_adr, int qvel_adr, const Eigen::Vector3d& position,
                   double yaw) {
  mjtNum* q = d->qpos + qpos_adr;
  q[0] = position.x();
  q[1] = position.y();
  q[2] = position.z();
  q[3] = std::cos(yaw / 2);
  q[4] = 0;
  q[5] = 0;
  q[6] = std::sin(yaw / 2);
  for (int k = 0; k < 6; ++k) d->qvel[qvel_adr + k] = 0;
}

void PlaceMocap(mjData* d, int mocap, const Eigen::Vector3d& position, double yaw) {
  for (int k = 0; k < 3; ++k) d->mocap_pos[3 * mocap + k] = position[k];
  mjtNum* q = d->mocap_quat + 4 * mocap;
  q[0] = std::cos(yaw / 2);
  q[1] = 0;
  q[2] = 0;
  q[3] = std::sin(yaw / 2);
}

int RequireId(const mjModel* m, mjtObj type, const std::string& name, const char* what,
              const char* who) {
  const int id = mj_name2id(m, type, name.c_str());
  if (id < 0)
    throw std::logic_error(std::string(who) + ": the scene has no " + what + " '" + name + "'");
  return id;
}

ArmRig::ArmRig(const std::string& urdf_path, const ArmIkOptions& ik)
    : arm_(std::make_unique<ArmModel>(ArmModel::FromFile(urdf_path))),
      ik_(std::make_unique<ArmIk>(*arm_, ik)) {
  // The flange target is the pinch target times this fixed transform.
  const Eigen::VectorXd q0 = Eigen::VectorXd::Zero(arm_->num_dofs());
  pinch_to_flange_ =
      arm_->LinkPose(arm_->tip_link(), q0).inverse() * arm_->LinkPose(arm_->flange_link(), q0);
}

void ArmRig::Bind(const mjModel* m, const std::string& right_pad_geom, double gripper_travel,
                  const char* who) {
  m_ = m;
  gripper_travel_ = gripper_travel;
  for (int i = 0; i < 6; ++i) {
    const std::string& joint = arm_->links()[arm_->arm_joint_links()[i]].joint;
    const int j = RequireId(m, mjOBJ_JOINT, joint, "joint", who);
    arm_qpos_[i] = m->jnt_qposadr[j];
    arm_qvel_[i] = m->jnt_dofadr[j];
    arm_actuator_[i] = RequireId(m, mjOBJ_ACTUATOR, joint, "actuator", who);
  }
  const int grip_dof = arm_->links()[arm_->gripper_link()].dof;
  finger_qpos_.clear();
  finger_multiplier_.clear();
  finger_offset_.clear();
  for (const auto& l : arm_->links()) {
    if (l.dof != grip_dof || l.type == ArmModel::JointType::kFixed) continue;
    const int j = RequireId(m, mjOBJ_JOINT, l.joint, "joint", who);
    finger_qpos_.push_back(m->jnt_qposadr[j]);
    finger_multiplier_.push_back(l.multiplier);
    finger_offset_.push_back(l.offset);
    if (!l.mimic) gripper_qpos_ = m->jnt_qposadr[j];
  }
  gripper_actuator_ = RequireId(m, mjOBJ_ACTUATOR, "gripper", "actuator", who);
  pinch_site_ = RequireId(m, mjOBJ_SITE, arm_->links()[arm_->tip_link()].name, "site", who);
  contact_body_ = m->geom_bodyid[RequireId(m, mjOBJ_GEOM, right_pad_geom, "geom", who)];
}

void ArmRig::SetArmJoints(mjData* d, const Joints& q) const {
  for (int i = 0; i < 6; ++i) {
    d->qpos[arm_qpos_[i]] = q[i];
    d->qvel[arm_qvel_[i]] = 0;
    d->ctrl[arm_actuator_[i]] = q[i];
  }
  mj_forward(m_, d);
}

bool ArmRig::PlacePinch(mjData* d, const Eigen::Vector3d& position, double yaw) const {
  Eigen::Isometry3d pinch = Eigen::Isometry3d::Identity();
  pinch.linear() = PinchDownRotation(yaw);
  pinch.translation() = position;
  Eigen::VectorXd q0 = Eigen::VectorXd::Zero(arm_->num_dofs());
  for (int i = 0; i < 6; ++i) q0[i] = kArmHome[i];
  const ArmIkResult r = ik_->Solve(pinch * pinch_to_flange_, arm_->flange_link(), q0);
  SetArmJoints(d, r.q.head<6>());
  return r.converged;
}

void ArmRig::SetOpening(mjData* d, double opening) const {
  opening = std::clamp(opening, 0.0, 1.0);
  const double travel = opening * gripper_travel_;
  for (size_t f = 0; f < finger_qpos_.size(); ++f)
    d->qpos[finger_qpos_[f]] = finger_multiplier_[f] * travel + finger_offset_[f];
  d->ctrl[gripper_actuator_] = 255.0 * opening;
  mj_forward(m_, d);
}

void ArmRig::Randomize(mjData* d, std::mt19937_64& rng, const Eigen::Vector3d& low,
                       const Eigen::Vector3d& high) const {
  Eigen::Vector3d p;
  for (int i = 0; i < 3; ++i) p[i] = Uniform(rng, low[i], high[i]);
  const double yaw = Uniform(rng, -M_PI, M_PI);
  // Failing to converge in 20 iterations from home leaves a pose close to the
  // target; OGBench goes on with it too.
  PlacePinch(d, p, yaw);
  SetOpening(d, 0.0);
}

bool ArmRig::SetControls(mjData* d, const Action& action, const std::array<double, 5>& s,
                         const Eigen::Vector3d& pinch_low,
                         const Eigen::Vector3d& pinch_high) const {
  // Deltas apply to the measured pose, not to the previous target (OGBench).
  const Eigen::Vector3d target =
      (PinchPosition(d) + Eigen::Vector3d(action[0] * s[0], action[1] * s[1], action[2] * s[2]))
          .cwiseMax(pinch_low)
          .cwiseMin(pinch_high);
  const double yaw = std::remainder(PinchYaw(d) + action[3] * s[3], 2 * M_PI);
  const double opening = std::clamp(Opening(d) + action[4] * s[4], 0.0, 1.0);

  Eigen::Isometry3d pinch = Eigen::Isometry3d::Identity();
  pinch.linear() = PinchDownRotation(yaw);
  pinch.translation() = target;
  Eigen::VectorXd q0 = Eigen::VectorXd::Zero(arm_->num_dofs());
  q0.head<6>() = ArmJoints(d);
  const ArmIkResult r = ik_->Solve(pinch * pinch_to_flange_, arm_->flange_link(), q0);
  for (int i = 0; i < 6; ++i) d->ctrl[arm_actuator_[i]] = r.q[i];
  d->ctrl[gripper_actuator_] = 255.0 * opening;
  return r.converged;
}

Eigen::Vector3d ArmRig::PinchPosition(const mjData* d) const {
  const mjtNum* p = d->site_xpos + 3 * pinch_site_;
  return Eigen::Vector3d(p[0], p[1], p[2]);
}

double ArmRig::PinchYaw(const mjData* d) const {
  mjtNum quat[4];
  mju_mat2Quat(quat, d->site_xmat + 9 * pinch_site_);
  return QuatYaw(quat[0], quat[1], quat[2], quat[3]);
}

Eigen::Matrix3d ArmRig::PinchRotation(const mjData* d) const {
  return Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(d->site_xmat +
                                                                        9 * pinch_site_);
}

double ArmRig::Opening(const mjData* d) const {
  return std::clamp(d->qpos[gripper_qpos_] / gripper_travel_, 0.0, 1.0);
}

ArmRig::Joints ArmRig::ArmJoints(const mjData* d) const {
  Joints q;
  for (int i = 0; i < 6; ++i) q[i] = d->qpos[arm_qpos_[i]];
  return q;
}

void ArmRig::WriteProprio(const mjData* d, float* o) const {
  for (int i = 0; i < 6; ++i) {
    o[i] = static_cast<float>(d->qpos[arm_qpos_[i]]);
    o[6 + i] = static_cast<float>(d->qvel[arm_qvel_[i]]);
  }
  const Eigen::Vector3d pinch = 10 * (PinchPosition(d) - kObservationCentre);
  const double yaw = PinchYaw(d);
  for (int i = 0; i < 3; ++i) o[12 + i] = static_cast<float>(pinch[i]);
  o[15] = static_cast<float>(std::cos(yaw));
  o[16] = static_cast<float>(std::sin(yaw));
  o[17] = static_cast<float>(3 * Opening(d));
  // OGBench: the norm of the pad body's 6-D external (contact) wrench / 50.
  // Our pad is a geom of the finger body, so the whole finger's contacts count.
  const double force =
      Eigen::Map<const Eigen::Matrix<double, 6, 1>>(d->cfrc_ext + 6 * contact_body_).norm();
  o[18] = static_cast<float>(std::clamp(force / 50, 0.0, 1.0));
}

}  // namespace msspr::sim::internal
