// Process environment for the tools: settings that LibTorch's libraries read
// once, when they load, so they must be in the environment before the
// program starts. No torch.
#pragma once

#include <string>

#include "msspr_core/cpu_info.h"

namespace msspr {
namespace core {

// OpenBLAS (LibTorch's fp32 matrix products on Debian) picks its kernels
// from the CPU's family and model when it loads. OpenBLAS 0.3.21 does not
// know newer Intel models (an Intel Xeon of family 6, model 207, for one)
// and falls back to its generic SSE3 kernels, "Prescott": a 256 x 256 fp32
// product then ran 4-5x slower than with the AVX-512 kernels the CPU can
// run. Returns the OPENBLAS_CORETYPE that gives this CPU's kernels when
// OpenBLAS picked `picked` ("SkylakeX" with AVX-512, "Haswell" with AVX2 and
// FMA), or "" to keep OpenBLAS's pick: it is overridden only when it is the
// generic fallback on a CPU with AVX2.
std::string OpenBlasCoreFor(const std::string& picked, const CpuInfo& cpu);

// The name of the kernels of the OpenBLAS loaded in this process, as
// OpenBLAS calls them ("SkylakeX", "Zen", "Prescott", ...), or "" when no
// OpenBLAS is loaded (another BLAS, or a static build without the symbol).
std::string LoadedOpenBlasCore();

// What every tool sets before its work starts:
// - OMP_WAIT_POLICY=PASSIVE when unset. LibTorch's OpenMP threads spin while
//   they wait by default; on cores shared with other processes a spinning
//   thread waits for a descheduled one, and a training step took 7.8 s
//   instead of 0.19 s (2 threads, 2 busy cores).
// - OPENBLAS_CORETYPE when unset and OpenBLAS picked its generic kernels on
//   a CPU that runs better ones (OpenBlasCoreFor); says so on stderr.
// libgomp and OpenBLAS read these once at load time, so when either is set
// here the program re-executes itself (/proc/self/exe) with the same
// arguments. Returns only when nothing was re-executed (both variables
// already set or nothing to change, or exec failed). A run asked only to
// print its resolved options (--print-options: msspr_train, called by
// msspr_compare for every run of a grid) computes nothing and is not
// re-executed, which halves its time.
void ReexecWithToolEnvironment(char** argv);

}  // namespace core
}  // namespace msspr
