#include "msspr_core/process_env.h"

#include <unistd.h>

#include <cstdlib>

namespace msspr {
namespace core {

void ReexecWithPassiveOpenMpWait(char** argv) {
  if (std::getenv("OMP_WAIT_POLICY") != nullptr) return;
  if (setenv("OMP_WAIT_POLICY", "PASSIVE", 0) != 0) return;
  execv("/proc/self/exe", argv);
  // exec failed: carry on with the spinning default.
}

}  // namespace core
}  // namespace msspr
