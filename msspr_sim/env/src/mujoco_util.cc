#include "mujoco_util.h"

#include <cstdio>
#include <cstring>
#include <mutex>
#include <stdexcept>

namespace msspr::sim::internal {
namespace {

[[noreturn]] void ThrowMujocoError(const char* msg) {
  throw std::runtime_error(std::string("MuJoCo error: ") + msg);
}
void LogMujocoWarning(const char* msg) { std::fprintf(stderr, "MuJoCo warning: %s\n", msg); }

struct VfsDeleter {
  void operator()(mjVFS* v) const {
    mj_deleteVFS(v);
    delete v;
  }
};

}  // namespace

// MuJoCo's default error handler waits for Enter on stdin; ours throws.
void InstallMujocoHandlers() {
  static std::once_flag once;
  std::call_once(once, [] {
    mju_user_error = ThrowMujocoError;
    mju_user_warning = LogMujocoWarning;
  });
}

ModelPtr LoadInlineModel(const std::string& xml, const std::string& name) {
  // mjVFS is ~2 MB: heap only.
  std::unique_ptr<mjVFS, VfsDeleter> vfs(new mjVFS);
  mj_defaultVFS(vfs.get());
  const std::string file = name + ".xml";
  if (mj_makeEmptyFileVFS(vfs.get(), file.c_str(), static_cast<int>(xml.size())) != 0) {
    throw std::runtime_error("MuJoCo: cannot create VFS file " + file);
  }
  const int index = mj_findFileVFS(vfs.get(), file.c_str());
  std::memcpy(vfs->filedata[index], xml.data(), xml.size());
  char error[1024] = {0};
  mjModel* m = mj_loadXML(file.c_str(), vfs.get(), error, sizeof(error));
  if (m == nullptr) {
    throw std::runtime_error("MuJoCo: cannot load the generated MJCF " + file + ": " + error);
  }
  return ModelPtr(m);
}

}  // namespace msspr::sim::internal
