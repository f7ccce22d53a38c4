// One core's arithmetic peak for the instructions a training step's matrix
// products can use: fp32 fused multiply-adds and bfloat16 dot products. The
// ratio says whether a bfloat16 matrix product can beat an fp32 one on this
// CPU without AMX tiles (it cannot where bf16's peak is not above fp32's).
// No torch.
#pragma once

#include <string>

#include "msspr_core/cpu_info.h"

namespace msspr {
namespace core {

struct IsaPeaks {
  // fp32 FMAs (2 FLOP per lane) at the widest vectors the CPU has: "avx512f"
  // (16 lanes), "avx2" (8 lanes, with FMA), or "" with fp32_gflops -1.
  std::string fp32_isa;
  double fp32_gflops = -1;
  // AVX512-BF16's VDPBF16PS (32 bf16 pairs into 16 fp32 lanes: 64 FLOP per
  // instruction); -1 where the CPU lacks avx512_bf16.
  double bf16_dot_gflops = -1;
  // {"fp32_isa": "avx512f", "fp32_gflops": 88.7, "bf16_dot_gflops": 42.9}
  std::string ToJson() const;
};

// Runs 12 independent chains of each instruction the flags of cpu allow (the
// CPU this process runs on must have them) for about `seconds` in all, and
// reports the best of 3 repetitions. Load on the core lowers both figures
// alike, so their ratio stays meaningful on a busy machine.
IsaPeaks MeasureIsaPeaks(const CpuInfo& cpu, double seconds = 0.3);

}  // namespace core
}  // namespace msspr
