// Internal: the arm of the manipulation scenes (ArmSceneMjcf) as the envs drive it, one
// piece for cube-single and the puzzles: the URDF arm and its IK, the joint, actuator and
// site ids in a compiled scene, the 5-D action turned into servo targets (OGBench's
// manipspace controller), the random start pose and the 19 proprioceptive observation
// entries every manipulation env begins with.
#ifndef MSSPR_SIM_SRC_ARM_RIG_H_
#define MSSPR_SIM_SRC_ARM_RIG_H_

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "msspr_sim/arm_ik.h"
#include "msspr_sim/arm_model.h"

namespace msspr::sim::internal {

// m's id of object `name`; throws std::logic_error "<who>: the scene has no <what> 'name'".
int RequireId(const mjModel* m, mjtObj type, const std::string& name, const char* what,
              const char* who);

// OGBench's home joints (rad) and the centre c (m) that observations subtract.
extern const double kArmHome[6];
extern const Eigen::Vector3d kObservationCentre;

// ZYX yaw of a quaternion (w, x, y, z); independent of its sign.
double QuatYaw(double w, double x, double y, double z);
// The same of the quaternion (w, x, y, z) at q (a free joint's qpos + 3, a mocap_quat).
inline double QuatYaw(const double* q) { return QuatYaw(q[0], q[1], q[2], q[3]); }

// A free joint's body (qpos at qpos_adr, qvel at qvel_adr) at `position`, turned `yaw` about z,
// at rest; no mj_forward.
void PlaceFreeBody(mjData* d, int qpos_adr, int qvel_adr, const Eigen::Vector3d& position,
                   double yaw);
// Mocap body `mocap` at `position`, turned `yaw` about z; no mj_forward.
void PlaceMocap(mjData* d, int mocap, const Eigen::Vector3d& position, double yaw);

class ArmRig {
 public:
  static constexpr int kProprioSize = 19;
  using Action = std::array<double, 5>;
  using Joints = Eigen::Matrix<double, 6, 1>;

  // Parses the URDF (UrdfError) and sets up the IK.
  ArmRig(const std::string& urdf_path, const ArmIkOptions& ik);

  // Resolves the arm's joints, actuators, pinch site and the body of `right_pad_geom` in
  // `m` (which must outlive the rig); `who` prefixes the errors.
  void Bind(const mjModel* m, const std::string& right_pad_geom, double gripper_travel,
            const char* who);

  // Arm joints with zero velocity and servo targets equal to them; then mj_forward.
  void SetArmJoints(mjData* d, const Joints& q) const;
  // The IK from the home joints for the pinch at `position`, pointing down with `yaw`;
  // returns whether it converged.
  bool PlacePinch(mjData* d, const Eigen::Vector3d& position, double yaw) const;
  // Opening in [0, 1] (0 open) set on every finger joint and the gripper servo; mj_forward.
  void SetOpening(mjData* d, double opening) const;
  // A random start pose: pinch in [low, high], yaw U(-pi, pi), gripper open.
  void Randomize(mjData* d, std::mt19937_64& rng, const Eigen::Vector3d& low,
                 const Eigen::Vector3d& high) const;

  // The servo targets of one action (not clipped): the measured pinch pose moved by
  // action x scale, clipped to [pinch_low, pinch_high], through the IK. Returns whether
  // the IK met its tolerances.
  bool SetControls(mjData* d, const Action& action, const std::array<double, 5>& scale,
                   const Eigen::Vector3d& pinch_low, const Eigen::Vector3d& pinch_high) const;

  Eigen::Vector3d PinchPosition(const mjData* d) const;
  double PinchYaw(const mjData* d) const;
  Eigen::Matrix3d PinchRotation(const mjData* d) const;
  double Opening(const mjData* d) const;
  Joints ArmJoints(const mjData* d) const;
  // Observation entries 0-18: arm q (6), arm qdot (6), 10 (pinch - c) (3), cos / sin of the
  // pinch yaw (2), 3 x opening (1), pad contact in [0, 1] (1; needs cfrc_ext, that is
  // mj_rnePostConstraint after the step).
  void WriteProprio(const mjData* d, float* o) const;

  const ArmModel& arm() const { return *arm_; }

 private:
  std::unique_ptr<ArmModel> arm_;  // heap: ik_ keeps a reference to it
  std::unique_ptr<ArmIk> ik_;
  Eigen::Isometry3d pinch_to_flange_;
  const mjModel* m_ = nullptr;
  double gripper_travel_ = 0;
  int arm_qpos_[6] = {}, arm_qvel_[6] = {}, arm_actuator_[6] = {};
  std::vector<int> finger_qpos_;  // every finger joint (independent and mimics)
  std::vector<double> finger_multiplier_, finger_offset_;
  int gripper_qpos_ = -1;  // the independent finger joint
  int gripper_actuator_ = -1;
  int pinch_site_ = -1;
  int contact_body_ = -1;  // the body of the right pad (OGBench's right_pad)
};

}  // namespace msspr::sim::internal

#endif  // MSSPR_SIM_SRC_ARM_RIG_H_
