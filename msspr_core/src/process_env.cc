#include "msspr_core/process_env.h"

#include <dlfcn.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>

namespace msspr {
namespace core {

std::string OpenBlasCoreFor(const std::string& picked, const CpuInfo& cpu) {
  // OpenBLAS's fallback for a CPU it does not know (dynamic.c: Prescott).
  if (picked != "Prescott") return "";
  // OpenBLAS 0.3.21 accepts "SkylakeX" by name (not "Cooperlake", whose fp32
  // kernels are SkylakeX's anyway).
  if (cpu.Has("avx512f")) return "SkylakeX";
  if (cpu.Has("avx2") && cpu.Has("fma")) return "Haswell";
  return "";
}

std::string LoadedOpenBlasCore() {
  using CoreName = char* (*)();
  auto* fn = reinterpret_cast<CoreName>(dlsym(RTLD_DEFAULT, "openblas_get_corename"));
  if (fn == nullptr) return "";
  const char* name = fn();
  return name != nullptr ? name : "";
}

void ReexecWithToolEnvironment(char** argv) {
  for (char** arg = argv + 1; *arg != nullptr; ++arg)
    if (std::strcmp(*arg, "--print-options") == 0) return;  // prints, computes nothing
  bool changed = false;
  if (std::getenv("OMP_WAIT_POLICY") == nullptr && setenv("OMP_WAIT_POLICY", "PASSIVE", 0) == 0)
    changed = true;
  if (std::getenv("OPENBLAS_CORETYPE") == nullptr) {
    const std::string picked = LoadedOpenBlasCore();
    const std::string core = OpenBlasCoreFor(picked, HostCpu());
    if (!core.empty() && setenv("OPENBLAS_CORETYPE", core.c_str(), 0) == 0) {
      std::fprintf(stderr,
                   "[msspr] OpenBLAS picked its generic %s kernels on this CPU (%s); running with "
                   "OPENBLAS_CORETYPE=%s (set OPENBLAS_CORETYPE to choose)\n",
                   picked.c_str(), HostCpu().Summary().c_str(), core.c_str());
      changed = true;
    }
  }
  if (changed) execv("/proc/self/exe", argv);
  // exec failed, or nothing to change: carry on as the environment is.
}

}  // namespace core
}  // namespace msspr
