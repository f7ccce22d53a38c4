#include "mujoco_util.h"

#include <cstdio>
#include <cstring>
#include <iterator>
#include <map>
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

std::shared_ptr<const mjModel> SharedInlineModel(const std::string& xml, const std::string& name) {
  static std::mutex mutex;
  static std::map<std::string, std::weak_ptr<const mjModel>> cache;  // keyed by name + text
  const std::string key = name + '\n' + xml;
  std::lock_guard<std::mutex> lock(mutex);
  for (auto it = cache.begin(); it != cache.end();)  // forget models nobody holds
    it = it->second.expired() ? cache.erase(it) : std::next(it);
  if (auto m = cache[key].lock()) return m;
  std::shared_ptr<const mjModel> m(LoadInlineModel(xml, name).release(), ModelDeleter());
  cache[key] = m;
  return m;
}

std::vector<PointMaze::AgentJoint> ModelJoints(const mjModel* m) {
  std::vector<PointMaze::AgentJoint> out;
  for (int j = 0; j < m->njnt; ++j) {
    PointMaze::AgentJoint a;
    const char* name = mj_id2name(m, mjOBJ_JOINT, j);
    a.name = name ? name : "";
    switch (m->jnt_type[j]) {
      case mjJNT_SLIDE:
        a.type = "slide";
        break;
      case mjJNT_HINGE:
        a.type = "hinge";
        break;
      case mjJNT_BALL:
        a.type = "ball";
        break;
      default:
        a.type = "free";
        break;
    }
    a.axis = Eigen::Vector3d(m->jnt_axis[3 * j], m->jnt_axis[3 * j + 1], m->jnt_axis[3 * j + 2]);
    a.limited = m->jnt_limited[j] != 0;
    a.lower = m->jnt_range[2 * j];
    a.upper = m->jnt_range[2 * j + 1];
    out.push_back(a);
  }
  return out;
}

}  // namespace msspr::sim::internal
