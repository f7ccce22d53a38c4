// OGBench's online-ant-xy (online_locomotion/ant.py with its XY wrapper):
// the ant of ant_model.h on an open floor, asked to walk along a random unit
// direction. The environment the low-level locomotion expert is trained in.
//
// Threading: an AntXyEnv is not thread-safe; use one per thread.
#ifndef MSSPR_SIM_ANT_XY_ENV_H_
#define MSSPR_SIM_ANT_XY_ENV_H_

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <random>

#include "msspr_sim/ant_model.h"

namespace msspr::sim {

struct AntXyEnvOptions {
  int max_episode_steps = 1000;   // truncation
  int direction_interval = 100;   // steps between direction redraws
  double healthy_z_min = 0.2;     // the episode terminates when the torso's z
  double healthy_z_max = 1.0;     // leaves [min, max] (or the state is not finite)
  double floor_half_size = 40.0;  // metres
};

class AntXyEnv {
 public:
  // Observation: the 27 body values of the ant (qpos[2:15], qvel: the
  // AntMaze observation without x, y) then the 2-D unit direction.
  static constexpr int kBodyDim = kAntQposDim - 2 + kAntQvelDim;
  static constexpr int kObsDim = kBodyDim + 2, kActionDim = kAntActionDim;

  explicit AntXyEnv(const AntXyEnvOptions& options = {});
  ~AntXyEnv();
  AntXyEnv(const AntXyEnv&) = delete;
  AntXyEnv& operator=(const AntXyEnv&) = delete;

  // Noisy reset of the ant at the origin (qpos0 + U[-0.1, 0.1], qvel
  // 0.1 N(0, 1)) and a random unit direction (a normalised N(0, I) draw);
  // all later draws come from the same seeded stream, so an episode is a
  // function of the seed and the actions. Returns the observation.
  Eigen::VectorXd Reset(uint64_t seed);

  struct StepResult {
    Eigen::VectorXd observation;  // with the direction for the next step
    double reward = 0.0;          // (xy after - xy before) . direction, metres
    bool terminated = false;      // z outside [healthy_z_min, healthy_z_max]
    bool truncated = false;       // steps() >= max_episode_steps
  };
  // ctrl = clip(action, -1, 1), 5 physics steps; the reward uses the
  // direction in force during the step; every direction_interval steps a new
  // direction is drawn (it is in the returned observation). Throws
  // std::invalid_argument on a non-finite action or a size other than 8.
  StepResult Step(const Eigen::VectorXd& action);

  Eigen::VectorXd observation() const;
  // The current unit direction.
  Eigen::Vector2d direction() const { return direction_; }
  // Sets the direction (normalised); throws std::invalid_argument on a zero
  // or non-finite vector.
  void SetDirection(const Eigen::Vector2d& direction);
  Eigen::Vector2d xy() const;
  double z() const;
  Eigen::VectorXd qpos() const;
  Eigen::VectorXd qvel() const;
  // Sets qpos (15) and qvel (14); throws std::invalid_argument on wrong sizes.
  void SetState(const Eigen::VectorXd& qpos, const Eigen::VectorXd& qvel);
  // z within [healthy_z_min, healthy_z_max] and the state finite.
  bool healthy() const;
  int steps() const { return steps_; }
  const AntXyEnvOptions& options() const { return options_; }

  const mjModel* model() const;
  const mjData* data() const;

 private:
  void DrawDirection();

  struct Impl;
  AntXyEnvOptions options_;
  std::unique_ptr<Impl> impl_;
  std::mt19937_64 rng_;
  Eigen::Vector2d direction_ = Eigen::Vector2d::UnitX();
  int steps_ = 0;
};

}  // namespace msspr::sim

#endif  // MSSPR_SIM_ANT_XY_ENV_H_
