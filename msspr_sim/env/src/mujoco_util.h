// Internal: MuJoCo plumbing shared by the environments (error handlers,
// owning pointers, loading generated MJCF from memory).
#ifndef MSSPR_SIM_SRC_MUJOCO_UTIL_H_
#define MSSPR_SIM_SRC_MUJOCO_UTIL_H_

#include <mujoco/mujoco.h>

#include <memory>
#include <string>

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

}  // namespace msspr::sim::internal

#endif  // MSSPR_SIM_SRC_MUJOCO_UTIL_H_
