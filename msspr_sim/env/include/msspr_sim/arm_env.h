// The base of the manipulation envs beyond cube-single (the puzzles, cube-double): the URDF
// arm in a compiled arm scene (ArmSceneMjcf), its 5-D action turned into servo targets by
// the IK (cube_env.h has the facts), the physics steps, the arm's state and setters, the
// full MuJoCo state and headless images. A derived env adds its objects, observation,
// tasks and success.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "msspr_sim/arm_ik.h"
#include "msspr_sim/arm_model.h"
#include "msspr_sim/cube_scene.h"

struct mjModel_;
struct mjData_;

namespace msspr::sim {

// What every arm env takes beside its own options.
struct ArmEnvOptions {
  std::string urdf_path;  // the arm (msspr_sim/urdf/ur5e_2f85.urdf); required
  CubeSceneOptions scene;
  ArmIkOptions ik;
  int substeps = 25;  // physics steps per action (0.05 s at 2 ms)
  // Action scale: pinch dx, dy, dz (m), dyaw (rad), dopening per unit action.
  std::array<double, 5> action_scale{0.05, 0.05, 0.05, 0.3, 1.0};
  // The pinch target is clipped to this box each step (m).
  Eigen::Vector3d pinch_low{0.25, -0.35, 0.02};
  Eigen::Vector3d pinch_high{0.60, 0.35, 0.35};
  // Random pinch poses (episode starts, the oracles' final poses): this box (m), yaw
  // U(-pi, pi).
  Eigen::Vector3d init_low{0.25, -0.35, 0.20};
  Eigen::Vector3d init_high{0.60, 0.35, 0.35};
  // Images: [S, S, 3] uint8 from `camera`.
  bool enable_rendering = false;
  int image_size = 64;
  std::string camera = "front_pixels";
};

class ArmEnv {
 public:
  static constexpr int kActionSize = 5;
  static constexpr int kProprioSize = 19;
  using Action = std::array<double, kActionSize>;
  using Observation = std::vector<float>;

  virtual ~ArmEnv();
  ArmEnv(const ArmEnv&) = delete;
  ArmEnv& operator=(const ArmEnv&) = delete;

  // Arm joints [6] (rad) with zero velocity and servo targets equal to them; the IK from the
  // home joints for the pinch at `position` pointing down with `yaw` (returns whether it
  // converged); the opening in [0, 1] (0 open). Each followed by mj_forward.
  void SetArmJoints(const Eigen::Matrix<double, 6, 1>& q);
  bool PlacePinch(const Eigen::Vector3d& position, double yaw);
  void SetOpening(double opening);
  Eigen::Vector3d PinchPosition() const;
  double PinchYaw() const;  // ZYX yaw of the pinch frame
  Eigen::Matrix3d PinchRotation() const;
  double Opening() const;  // 0 open, 1 closed
  Eigen::Matrix<double, 6, 1> ArmJoints() const;
  // The full MuJoCo state: qpos [nq] and qvel [nv].
  std::vector<double> Qpos() const;
  std::vector<double> Qvel() const;
  // Renders the current state ([S, S, 3] uint8, row 0 = top); std::logic_error unless
  // enable_rendering.
  std::vector<uint8_t> Render() const;
  // Whether the last step's IK met its tolerances.
  bool last_ik_converged() const { return last_ik_converged_; }
  const ArmModel& arm() const;
  const std::string& mjcf() const { return mjcf_; }
  const ArmEnvOptions& arm_options() const { return arm_options_; }

 protected:
  // Parses the URDF (UrdfError), generates the scene with `objects_xml` (ArmSceneMjcf),
  // compiles it (std::runtime_error with MuJoCo's message) and puts the arm at home with the
  // gripper open. `who` names the env in errors.
  ArmEnv(const ArmEnvOptions& options, const std::string& model_name,
         const std::string& objects_xml, const char* who);

  // The servo targets of `action` (not clipped; callers clip to [-1, 1]), then `substeps`
  // physics steps. The derived env finishes the step (its objects, mj_rnePostConstraint).
  void StepPhysics(const Action& action);
  // A random start pose in [init_low, init_high], gripper open.
  void RandomizeArm(std::mt19937_64& rng);
  // Writes the 19 proprio entries (CubeEnv::GetObservation's 0-18).
  void WriteProprio(float* o) const;
  // m's id of object `name` of MuJoCo type `type` (mjtObj); std::logic_error naming it.
  int RequireId(int type, const std::string& name, const char* what) const;
  // Saves / restores the physics state (qpos, qvel, ctrl, act, time).
  struct SavedState {
    std::vector<double> qpos, qvel, ctrl, act;
    double time = 0;
  };
  SavedState Save() const;
  void Restore(const SavedState& s);
  // A task reset's goal observation (and, with enable_rendering, image) from the state `env`
  // is posed in: `steps` uniformly random actions (the gripper entry then set to `grip` unless
  // NaN), the observation, then the state restored.
  template <class Env>
  static void RecordGoal(Env& env, std::mt19937_64& rng, int steps, double grip,
                         std::vector<float>* observation, std::vector<uint8_t>* image) {
    const SavedState saved = env.Save();
    for (int k = 0; k < steps; ++k) {
      Action a;
      for (double& x : a) x = UniformAction(rng);
      if (!std::isnan(grip)) a[4] = grip;
      env.Step(a);
    }
    *observation = env.GetObservation();
    *image = env.arm_options().enable_rendering ? env.Render() : std::vector<uint8_t>();
    env.Restore(saved);
  }
  // U(-1, 1) (random_util.h's Uniform).
  static double UniformAction(std::mt19937_64& rng);

  mjModel_* model() const;
  mjData_* data() const;

 private:
  struct Impl;
  ArmEnvOptions arm_options_;
  std::string mjcf_;
  std::unique_ptr<Impl> impl_;
  const char* who_;
  bool last_ik_converged_ = true;
};

}  // namespace msspr::sim
