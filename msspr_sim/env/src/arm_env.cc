#include "msspr_sim/arm_env.h"

#include <mujoco/mujoco.h>

#include <algorithm>
#include <stdexcept>

#include "arm_rig.h"
#include "msspr_sim/random_util.h"
#include "mujoco_util.h"
#include "offscreen_renderer.h"

namespace msspr::sim {

struct ArmEnv::Impl {
  Impl(const std::string& urdf_path, const ArmIkOptions& ik) : rig(urdf_path, ik) {}
  internal::ArmRig rig;
  internal::ModelPtr model;
  internal::DataPtr data;
  std::unique_ptr<internal::OffscreenRenderer> renderer;
};

ArmEnv::ArmEnv(const ArmEnvOptions& options, const std::string& model_name,
               const std::string& objects_xml, const char* who)
    : arm_options_(options), who_(who) {
  if (options.substeps < 1)
    throw std::invalid_argument(std::string(who) + ": substeps must be >= 1");
  internal::InstallMujocoHandlers();
  impl_ = std::make_unique<Impl>(options.urdf_path, options.ik);
  mjcf_ = ArmSceneMjcf(impl_->rig.arm(), options.scene, model_name + "_" + impl_->rig.arm().name(),
                       objects_xml);
  impl_->model = internal::LoadInlineModel(mjcf_, model_name + "_scene");
  const mjModel* m = impl_->model.get();
  impl_->data.reset(mj_makeData(m));
  if (!impl_->data) throw std::runtime_error("MuJoCo: mj_makeData failed");
  impl_->rig.Bind(m, options.scene.pad_geoms[1], options.scene.gripper_travel, who);
  SetArmJoints(Eigen::Map<const Eigen::Matrix<double, 6, 1>>(internal::kArmHome));
  SetOpening(0.0);
  if (options.enable_rendering) {
    const int size = options.image_size;
    if (size < 1 || size > 4096)
      throw std::invalid_argument(std::string(who) + ": image_size must be in [1, 4096], got " +
                                  std::to_string(size));
    const int camera = RequireId(mjOBJ_CAMERA, options.camera, "camera");
    impl_->renderer = std::make_unique<internal::OffscreenRenderer>(m, size, camera);
  }
}

ArmEnv::~ArmEnv() = default;

double ArmEnv::UniformAction(std::mt19937_64& rng) { return Uniform(rng, -1.0, 1.0); }

const ArmModel& ArmEnv::arm() const { return impl_->rig.arm(); }
mjModel_* ArmEnv::model() const { return impl_->model.get(); }
mjData_* ArmEnv::data() const { return impl_->data.get(); }

int ArmEnv::RequireId(int type, const std::string& name, const char* what) const {
  return internal::RequireId(impl_->model.get(), static_cast<mjtObj>(type), name, what, who_);
}

void ArmEnv::StepPhysics(const Action& action) {
  const mjModel* m = impl_->model.get();
  mjData* d = impl_->data.get();
  last_ik_converged_ = impl_->rig.SetControls(d, action, arm_options_.action_scale,
                                              arm_options_.pinch_low, arm_options_.pinch_high);
  for (int k = 0; k < arm_options_.substeps; ++k) mj_step(m, d);
}

void ArmEnv::RandomizeArm(std::mt19937_64& rng) {
  impl_->rig.Randomize(impl_->data.get(), rng, arm_options_.init_low, arm_options_.init_high);
}

void ArmEnv::WriteProprio(float* o) const { impl_->rig.WriteProprio(impl_->data.get(), o); }

ArmEnv::SavedState ArmEnv::Save() const {
  const mjModel* m = impl_->model.get();
  const mjData* d = impl_->data.get();
  SavedState s;
  s.qpos.assign(d->qpos, d->qpos + m->nq);
  s.qvel.assign(d->qvel, d->qvel + m->nv);
  s.ctrl.assign(d->ctrl, d->ctrl + m->nu);
  s.act.assign(d->act, d->act + m->na);
  s.time = d->time;
  return s;
}

void ArmEnv::Restore(const SavedState& s) {
  mjData* d = impl_->data.get();
  std::copy(s.qpos.begin(), s.qpos.end(), d->qpos);
  std::copy(s.qvel.begin(), s.qvel.end(), d->qvel);
  std::copy(s.ctrl.begin(), s.ctrl.end(), d->ctrl);
  std::copy(s.act.begin(), s.act.end(), d->act);
  d->time = s.time;
}

void ArmEnv::SetArmJoints(const Eigen::Matrix<double, 6, 1>& q) {
  impl_->rig.SetArmJoints(impl_->data.get(), q);
}
bool ArmEnv::PlacePinch(const Eigen::Vector3d& position, double yaw) {
  return impl_->rig.PlacePinch(impl_->data.get(), position, yaw);
}
void ArmEnv::SetOpening(double opening) { impl_->rig.SetOpening(impl_->data.get(), opening); }
Eigen::Vector3d ArmEnv::PinchPosition() const {
  return impl_->rig.PinchPosition(impl_->data.get());
}
double ArmEnv::PinchYaw() const { return impl_->rig.PinchYaw(impl_->data.get()); }
Eigen::Matrix3d ArmEnv::PinchRotation() const {
  return impl_->rig.PinchRotation(impl_->data.get());
}
double ArmEnv::Opening() const { return impl_->rig.Opening(impl_->data.get()); }
Eigen::Matrix<double, 6, 1> ArmEnv::ArmJoints() const {
  return impl_->rig.ArmJoints(impl_->data.get());
}
std::vector<double> ArmEnv::Qpos() const {
  return std::vector<double>(impl_->data->qpos, impl_->data->qpos + impl_->model->nq);
}
std::vector<double> ArmEnv::Qvel() const {
  return std::vector<double>(impl_->data->qvel, impl_->data->qvel + impl_->model->nv);
}

std::vector<uint8_t> ArmEnv::Render() const {
  if (!impl_->renderer)
    throw std::logic_error(std::string(who_) + "::Render: construct with enable_rendering = true");
  std::vector<uint8_t> rgb(static_cast<size_t>(arm_options_.image_size) * arm_options_.image_size *
                           3);
  impl_->renderer->Render(impl_->model.get(), impl_->data.get(), rgb.data());
  return rgb;
}

}  // namespace msspr::sim
