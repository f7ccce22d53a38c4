#include "msspr_sim/ant_xy_env.h"

#include <cmath>
#include <stdexcept>

#include "ant_physics.h"
#include "msspr_sim/random_util.h"

namespace msspr::sim {

struct AntXyEnv::Impl {
  explicit Impl(double floor_half_size) : physics(AntMjcf(nullptr, floor_half_size), "ant_xy") {}
  internal::AntPhysics physics;
};

AntXyEnv::AntXyEnv(const AntXyEnvOptions& options) : options_(options) {
  if (options_.max_episode_steps < 1 || options_.direction_interval < 1) {
    throw std::invalid_argument("AntXyEnv: max_episode_steps and direction_interval must be >= 1");
  }
  if (!(options_.healthy_z_min < options_.healthy_z_max)) {
    throw std::invalid_argument("AntXyEnv: healthy_z_min must be < healthy_z_max");
  }
  impl_ = std::make_unique<Impl>(options_.floor_half_size);
}

AntXyEnv::~AntXyEnv() = default;

void AntXyEnv::DrawDirection() {
  Eigen::Vector2d d;
  do {
    d = {StandardNormal(rng_), StandardNormal(rng_)};
  } while (d.norm() < 1e-12);
  direction_ = d.normalized();
}

Eigen::VectorXd AntXyEnv::Reset(uint64_t seed) {
  rng_.seed(seed);
  impl_->physics.ResetNoisy(rng_);
  DrawDirection();
  steps_ = 0;
  return observation();
}

AntXyEnv::StepResult AntXyEnv::Step(const Eigen::VectorXd& action) {
  internal::AntPhysics& p = impl_->physics;
  const Eigen::Vector2d before = p.xy();
  p.Step(action);
  ++steps_;
  StepResult r;
  r.reward = (p.xy() - before).dot(direction_);
  r.terminated = !healthy();
  r.truncated = steps_ >= options_.max_episode_steps;
  if (steps_ % options_.direction_interval == 0) DrawDirection();
  r.observation = observation();
  return r;
}

Eigen::VectorXd AntXyEnv::observation() const {
  Eigen::VectorXd ob(kObsDim);
  ob << impl_->physics.FullObservation().tail<kBodyDim>(), direction_;
  return ob;
}

void AntXyEnv::SetDirection(const Eigen::Vector2d& direction) {
  if (!direction.allFinite() || direction.norm() < 1e-12) {
    throw std::invalid_argument("AntXyEnv::SetDirection: the direction must be finite, non-zero");
  }
  direction_ = direction.normalized();
}

Eigen::Vector2d AntXyEnv::xy() const { return impl_->physics.xy(); }
double AntXyEnv::z() const { return impl_->physics.z(); }
Eigen::VectorXd AntXyEnv::qpos() const { return impl_->physics.qpos(); }
Eigen::VectorXd AntXyEnv::qvel() const { return impl_->physics.qvel(); }

void AntXyEnv::SetState(const Eigen::VectorXd& qpos, const Eigen::VectorXd& qvel) {
  impl_->physics.SetState(qpos, qvel);
}

bool AntXyEnv::healthy() const {
  const double z = impl_->physics.z();
  return impl_->physics.FullObservation().allFinite() && z >= options_.healthy_z_min &&
         z <= options_.healthy_z_max;
}

const mjModel* AntXyEnv::model() const { return impl_->physics.model(); }
const mjData* AntXyEnv::data() const { return impl_->physics.data(); }

}  // namespace msspr::sim
