#include "msspr_sim_nodes/cube_goal_oracle.h"

#include <cmath>
#include <random>

#include "msspr_sim_nodes/cube_sim_node.h"

namespace msspr::ros_bridge {

CubeGoalOracle::CubeGoalOracle(const std::string& urdf_path, uint64_t seed,
                               sim::CubePlayOracleOptions options)
    : options_(options) {
  sim::CubeEnvOptions eo;
  eo.urdf_path = urdf_path;
  mirror_ = std::make_unique<sim::CubeEnv>(eo);
  Reset(seed);
}

CubeGoalOracle::~CubeGoalOracle() = default;

void CubeGoalOracle::Reset(uint64_t seed) {
  seed_ = seed;
  oracle_.reset();
}

void CubeGoalOracle::Pose(const float* obs, const float* goal) {
  Eigen::Matrix<double, 6, 1> q;
  for (int i = 0; i < 6; ++i) q[i] = obs[i];
  mirror_->SetArmJoints(q);
  mirror_->SetOpening(obs[17] / 3.0);
  mirror_->SetCube(CubePositionFromObservation(obs), CubeYawFromObservation(obs));
  if (goal != nullptr)
    mirror_->SetGoal(CubePositionFromObservation(goal), CubeYawFromObservation(goal));
}

sim::CubeEnv::Action CubeGoalOracle::ActPlay(const float* obs) {
  Pose(obs, nullptr);
  if (!oracle_) {
    std::mt19937_64 rng(seed_);
    const auto& o = mirror_->options();
    std::uniform_real_distribution<double> x(o.object_low.x(), o.object_high.x()),
        y(o.object_low.y(), o.object_high.y()), yaw(0.0, 2 * M_PI);
    const double gx = x(rng), gy = y(rng);
    mirror_->SetGoal(Eigen::Vector3d(gx, gy, 0.02), yaw(rng));
    oracle_ = std::make_unique<sim::CubePlayOracle>(seed_++, options_);
    ++plans_;
  }
  return oracle_->Act(*mirror_);
}

sim::CubeEnv::Action CubeGoalOracle::Act(const float* obs, const float* goal) {
  Pose(obs, goal);
  if (!oracle_) {
    oracle_ = std::make_unique<sim::CubePlayOracle>(seed_++, options_);
    ++plans_;
  }
  sim::CubeEnv::Action a = oracle_->Act(*mirror_);
  if (oracle_->cycles() > 1) {  // the plan was used up: plan again toward the same goal
    Pose(obs, goal);
    oracle_ = std::make_unique<sim::CubePlayOracle>(seed_++, options_);
    ++plans_;
    a = oracle_->Act(*mirror_);
  }
  return a;
}

}  // namespace msspr::ros_bridge
