// Internal: the ant's MuJoCo model and data, OGBench's noisy reset and its
// frame-skipped step, shared by AntMaze and AntXyEnv.
#ifndef MSSPR_SIM_SRC_ANT_PHYSICS_H_
#define MSSPR_SIM_SRC_ANT_PHYSICS_H_

#include <mujoco/mujoco.h>

#include <Eigen/Core>
#include <random>
#include <string>
#include <vector>

#include "msspr_sim/point_maze.h"
#include "mujoco_util.h"

namespace msspr::sim::internal {

class AntPhysics {
 public:
  // Compiles `xml` (AntMjcf) and checks the ant's layout (nq 15, nv 14, nu 8,
  // the hinges and actuators in the order of ant_model.h); throws
  // std::runtime_error / std::logic_error otherwise.
  AntPhysics(const std::string& xml, const std::string& name);

  // OGBench's reset (gymnasium's MujocoEnv.reset + the ant's reset_model):
  // mj_resetData, qpos = qpos0 + U[-0.1, 0.1] on all 15, qvel = 0.1 N(0, 1)
  // on all 14, mj_forward.
  void ResetNoisy(std::mt19937_64& rng);
  // ctrl = clip(action, -1, 1), then kAntFrameSkip mj_step. Throws
  // std::invalid_argument on a non-finite action or a wrong size.
  void Step(const Eigen::VectorXd& action);
  // qpos[0:2] = xy, mj_forward (OGBench's set_xy).
  void SetXY(const Eigen::Vector2d& xy);
  // Sets qpos (15) and qvel (14), mj_forward; throws std::invalid_argument on
  // wrong sizes or non-finite values.
  void SetState(const Eigen::VectorXd& qpos, const Eigen::VectorXd& qvel);

  Eigen::VectorXd qpos() const;
  Eigen::VectorXd qvel() const;
  // qpos (15) then qvel (14).
  Eigen::VectorXd FullObservation() const;
  Eigen::Vector2d xy() const { return {data_->qpos[0], data_->qpos[1]}; }
  double z() const { return data_->qpos[2]; }

  // The model's joints in model order (root free joint first, then the hinges).
  std::vector<PointMaze::AgentJoint> Joints() const;

  const mjModel* model() const { return model_.get(); }
  const mjData* data() const { return data_.get(); }

 private:
  std::shared_ptr<const mjModel> model_;  // shared by every AntPhysics of the same MJCF
  DataPtr data_;
};

}  // namespace msspr::sim::internal

#endif  // MSSPR_SIM_SRC_ANT_PHYSICS_H_
