#include "msspr_core/isa_peaks.h"

#include <algorithm>
#include <chrono>
#include <sstream>

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define MSSPR_ISA_PEAKS_X86 1
#endif

namespace msspr {
namespace core {
namespace {

using Clock = std::chrono::steady_clock;

// A kernel runs `iters` rounds of 12 instructions and returns a value that
// depends on every accumulator, so that none is optimised away.
using Kernel = float (*)(long iters);

#if MSSPR_ISA_PEAKS_X86
// A kernel NAME compiled for TARGET: twelve named accumulators of type VEC set
// by SET1 (an array would be kept in memory at -O2), each updated once a round
// by STEP(a, b, c) with b and c of type OPERAND, then stored by STORE into
// LANES floats and summed (not _mm512_reduce_add_ps: GCC 12 warns inside it).
// VEC, SET1, STEP and STORE are defined before each use.
#define MSSPR_TWELVE(X) X(0) X(1) X(2) X(3) X(4) X(5) X(6) X(7) X(8) X(9) X(10) X(11)
#define MSSPR_DECL(i) VEC a##i = SET1(static_cast<float>(i));
#define MSSPR_STEP(i) a##i = STEP(a##i, b, c);
#define MSSPR_SUM(i)  \
  STORE(lanes, a##i); \
  for (float v : lanes) s += v;
#define MSSPR_PEAK_KERNEL(NAME, TARGET, OPERAND, B, C, LANES)        \
  __attribute__((target(TARGET), noinline)) float NAME(long iters) { \
    const OPERAND b = B, c = C;                                      \
    MSSPR_TWELVE(MSSPR_DECL)                                         \
    for (long k = 0; k < iters; ++k) {                               \
      MSSPR_TWELVE(MSSPR_STEP)                                       \
    }                                                                \
    alignas(64) float lanes[LANES];                                  \
    float s = 0;                                                     \
    MSSPR_TWELVE(MSSPR_SUM)                                          \
    return s;                                                        \
  }

#define VEC __m512
#define SET1 _mm512_set1_ps
#define STORE _mm512_store_ps
#define STEP _mm512_fmadd_ps
MSSPR_PEAK_KERNEL(Fp32Avx512, "avx512f", __m512, SET1(0.9999999f), SET1(1e-7f), 16)
#undef STEP
// VDPBF16PS: a += the pairwise products of bf16 1.0 (0x3f80) and about 1.5e-8 (0x3280).
#define STEP _mm512_dpbf16_ps
MSSPR_PEAK_KERNEL(Bf16Dot, "avx512f,avx512bf16", __m512bh,
                  reinterpret_cast<__m512bh>(_mm512_set1_epi16(0x3f80)),
                  reinterpret_cast<__m512bh>(_mm512_set1_epi16(0x3280)), 16)
#undef STEP
#undef STORE
#undef SET1
#undef VEC

#define VEC __m256
#define SET1 _mm256_set1_ps
#define STORE _mm256_store_ps
#define STEP _mm256_fmadd_ps
MSSPR_PEAK_KERNEL(Fp32Avx2, "avx2,fma", __m256, SET1(0.9999999f), SET1(1e-7f), 8)
#undef STEP
#undef STORE
#undef SET1
#undef VEC

#undef MSSPR_PEAK_KERNEL
#undef MSSPR_SUM
#undef MSSPR_STEP
#undef MSSPR_DECL
#undef MSSPR_TWELVE

// GFLOP/s of a kernel doing flop_per_round per round: the best of 3 timed runs
// of about seconds / 3 each, after sizing a run on a short one.
double Peak(Kernel kernel, double flop_per_round, double seconds) {
  volatile float sink = 0;
  long iters = 1 << 16;
  for (;;) {  // size a run to about a tenth of a repetition
    const auto t0 = Clock::now();
    sink = sink + kernel(iters);
    const double s = std::chrono::duration<double>(Clock::now() - t0).count();
    if (s > seconds / 30 || iters > (1L << 40)) {
      iters = std::max(1L, static_cast<long>(iters * (seconds / 3) / std::max(s, 1e-9)));
      break;
    }
    iters *= 4;
  }
  double best = 0;
  for (int rep = 0; rep < 3; ++rep) {
    const auto t0 = Clock::now();
    sink = sink + kernel(iters);
    const double s = std::chrono::duration<double>(Clock::now() - t0).count();
    best = std::max(best, flop_per_round * static_cast<double>(iters) / s / 1e9);
  }
  return best;
}
#endif  // MSSPR_ISA_PEAKS_X86

}  // namespace

std::string IsaPeaks::ToJson() const {
  std::ostringstream s;
  s.precision(4);
  s << "{\"fp32_isa\": \"" << fp32_isa << "\", \"fp32_gflops\": " << fp32_gflops
    << ", \"bf16_dot_gflops\": " << bf16_dot_gflops << "}";
  return s.str();
}

IsaPeaks MeasureIsaPeaks(const CpuInfo& cpu, double seconds) {
  IsaPeaks p;
#if MSSPR_ISA_PEAKS_X86
  const bool bf16 = cpu.Has("avx512_bf16");
  const double each = bf16 ? seconds / 2 : seconds;
  // 12 instructions a round; an FMA lane is 2 FLOP, a VDPBF16PS lane 4.
  if (cpu.Has("avx512f")) {
    p.fp32_isa = "avx512f";
    p.fp32_gflops = Peak(&Fp32Avx512, 12.0 * 16 * 2, each);
  } else if (cpu.Has("avx2") && cpu.Has("fma")) {
    p.fp32_isa = "avx2";
    p.fp32_gflops = Peak(&Fp32Avx2, 12.0 * 8 * 2, each);
  }
  if (bf16) p.bf16_dot_gflops = Peak(&Bf16Dot, 12.0 * 16 * 4, each);
#else
  (void)cpu;
  (void)seconds;
#endif
  return p;
}

}  // namespace core
}  // namespace msspr
