// Internal: MuJoCo plumbing shared by the environments (error handlers,
// owning pointers, loading generated MJCF from memory).
#ifndef MSSPR_SIM_SRC_MUJOCO_UTIL_H_
#define MSSPR_SIM_SRC_MUJOCO_UTIL_H_

#include <mujoco/mujoco.h>

#include <memory>
#include <string>
#include <vector>

#include "msspr_sim/point_maze.h"

namespace msspr::sim::internal {

// Makes MuJoCo errors throw std::runtime_error ("MuJoCo error: ...") instead
// of waiting for Enter on stdin, and logs warnings to stderr. Idempotent.
void InstallMujocoHandlers();

struct ModelDeleter {
  void operator()(mjModel* m) const { mj_deleteModel(m); }
};
struct DataDeleter {
  void operator()(mjData* d) const { mj_deleteData(d); }
};
using ModelPtr = std::unique_ptr<mjModel, ModelDeleter>;
using DataPtr = std::unique_ptr<mjData, DataDeleter>;

// Compiles MJCF text through a virtual file `name`.xml; throws
// std::runtime_error with MuJoCo's message naming that file if it fails.
ModelPtr LoadInlineModel(const std::string& xml, const std::string& name);

// The same, compiled once per distinct text while any model it returned is
// alive: environments built side by side (the evaluators' hundreds of episodes)
// share one read-only model and keep their own mjData. Thread-safe.
std::shared_ptr<const mjModel> SharedInlineModel(const std::string& xml, const std::string& name);

// Every joint of a model: name, type, axis and range (for the URDF checks).
std::vector<PointMaze::AgentJoint> ModelJoints(const mjModel* m);

}  // namespace msspr::sim::internal

#endif  // MSSPR_SIM_SRC_MUJOCO_UTIL_H_
