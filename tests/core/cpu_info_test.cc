#include "msspr_core/cpu_info.h"

#include <gtest/gtest.h>

#include <string>

#include "msspr_core/isa_peaks.h"
#include "msspr_core/options.h"
#include "msspr_core/process_env.h"

namespace msspr {
namespace core {
namespace {

// Two processors of an Intel Xeon with AMX, as /proc/cpuinfo lists them.
const char* kXeonAmx =
    "processor\t: 0\n"
    "vendor_id\t: GenuineIntel\n"
    "cpu family\t: 6\n"
    "model\t\t: 167\n"
    "model name\t: Intel(R) Xeon(R) Processor\n"
    "flags\t\t: fpu sse sse2 avx fma avx2 avx512f avx512bw avx512_bf16 amx_bf16 amx_tile "
    "avx512_fp16\n"
    "\n"
    "processor\t: 1\n"
    "vendor_id\t: GenuineIntel\n"
    "cpu family\t: 6\n"
    "model\t\t: 167\n"
    "model name\t: Intel(R) Xeon(R) Processor\n"
    "flags\t\t: fpu sse sse2 avx fma avx2 avx512f avx512bw avx512_bf16 amx_bf16 amx_tile "
    "avx512_fp16\n";

// An AVX2-only AMD CPU: bfloat16 would be emulated.
const char* kZen2 =
    "processor\t: 0\n"
    "vendor_id\t: AuthenticAMD\n"
    "cpu family\t: 23\n"
    "model\t\t: 49\n"
    "model name\t: AMD EPYC 7B12\n"
    "flags\t\t: fpu sse sse2 avx fma avx2\n";

TEST(CpuInfoTest, ParsesModelFamilyAndTheFlagsThatMatter) {
  const CpuInfo c = ParseCpuInfo(kXeonAmx);
  EXPECT_EQ(c.model_name, "Intel(R) Xeon(R) Processor");
  EXPECT_EQ(c.vendor, "GenuineIntel");
  EXPECT_EQ(c.family, 6);
  EXPECT_EQ(c.model, 167);
  EXPECT_EQ(c.logical_cpus, 2);
  EXPECT_EQ(c.flags, (std::vector<std::string>{"avx2", "fma", "avx512f", "avx512_bf16", "amx_bf16",
                                               "amx_tile", "avx512_fp16"}));
  EXPECT_TRUE(c.NativeBf16());
  EXPECT_EQ(c.Summary(),
            "Intel(R) Xeon(R) Processor (GenuineIntel family 6 model 167; avx2 fma avx512f "
            "avx512_bf16 amx_bf16 amx_tile avx512_fp16)");
  EXPECT_EQ(c.ToJson(),
            "{\"model_name\": \"Intel(R) Xeon(R) Processor\", \"vendor\": \"GenuineIntel\", "
            "\"family\": 6, \"model\": 167, \"logical_cpus\": 2, \"flags\": [\"avx2\", \"fma\", "
            "\"avx512f\", \"avx512_bf16\", \"amx_bf16\", \"amx_tile\", \"avx512_fp16\"]}");

  const CpuInfo z = ParseCpuInfo(kZen2);
  EXPECT_EQ(z.model_name, "AMD EPYC 7B12");
  EXPECT_EQ(z.family, 23);
  EXPECT_EQ(z.flags, (std::vector<std::string>{"avx2", "fma"}));
  EXPECT_FALSE(z.NativeBf16());
}

TEST(CpuInfoTest, Bf16IsFasterThanFp32OnlyWithAmxOrOnAmdWithAvx512Bf16) {
  // Intel with AMX: bf16 products several times faster than fp32.
  EXPECT_TRUE(ParseCpuInfo(kXeonAmx).Bf16FasterThanFp32());
  // Intel with AVX512-BF16 but no AMX: OpenBLAS's AVX-512 fp32 wins.
  const CpuInfo xeon_no_amx = ParseCpuInfo(
      "vendor_id\t: GenuineIntel\ncpu family\t: 6\nmodel\t\t: 207\n"
      "flags\t\t: avx2 fma avx512f avx512bw avx512_bf16 avx512_fp16\n");
  EXPECT_TRUE(xeon_no_amx.NativeBf16());
  EXPECT_FALSE(xeon_no_amx.Bf16FasterThanFp32());
  // AMD from Zen 4: AVX512-BF16 against OpenBLAS's AVX2 fp32 kernels.
  const CpuInfo zen4 = ParseCpuInfo(
      "vendor_id\t: AuthenticAMD\ncpu family\t: 25\nmodel\t\t: 17\n"
      "flags\t\t: avx2 fma avx512f avx512_bf16\n");
  EXPECT_TRUE(zen4.Bf16FasterThanFp32());
  // No bfloat16 arithmetic at all.
  EXPECT_FALSE(ParseCpuInfo(kZen2).Bf16FasterThanFp32());
}

TEST(CpuInfoTest, UnknownFieldsStayUnknown) {
  const CpuInfo c = ParseCpuInfo("");
  EXPECT_EQ(c.family, -1);
  EXPECT_EQ(c.model, -1);
  EXPECT_EQ(c.logical_cpus, 0);
  EXPECT_FALSE(c.NativeBf16());
  EXPECT_EQ(c.Summary(), "unknown CPU (family -1 model -1; no AVX2)");
}

TEST(CpuInfoTest, OpenBlasGenericKernelsAreReplacedByTheCpusOwnOnly) {
  const CpuInfo xeon = ParseCpuInfo(kXeonAmx), zen2 = ParseCpuInfo(kZen2);
  const CpuInfo skx = ParseCpuInfo("flags\t: sse2 avx fma avx2 avx512f avx512bw\n");
  const CpuInfo old = ParseCpuInfo("flags\t: sse2 sse3 avx\n");
  // OpenBLAS's fallback for a model it does not know: the CPU's own kernels.
  EXPECT_EQ(OpenBlasCoreFor("Prescott", xeon), "SkylakeX");
  EXPECT_EQ(OpenBlasCoreFor("Prescott", skx), "SkylakeX");
  EXPECT_EQ(OpenBlasCoreFor("Prescott", zen2), "Haswell");
  // A CPU without AVX2 has nothing better; a pick OpenBLAS made itself stays.
  EXPECT_EQ(OpenBlasCoreFor("Prescott", old), "");
  EXPECT_EQ(OpenBlasCoreFor("SkylakeX", xeon), "");
  EXPECT_EQ(OpenBlasCoreFor("Zen", zen2), "");
  EXPECT_EQ(OpenBlasCoreFor("", xeon), "");
}

// The test processes themselves run the kernels msspr's tools run (tool_env_gtest_main.cc, or
// the environment scripts/run_tests.sh sets): not OpenBLAS's generic ones where the CPU has
// better, which made the learning tests 2.3x slower on an Intel Xeon OpenBLAS does not know.
TEST(CpuInfoTest, TestsRunTheOpenBlasKernelsTheToolsRun) {
  const std::string loaded = LoadedOpenBlasCore();
  if (loaded.empty()) GTEST_SKIP() << "no OpenBLAS loaded (another BLAS)";
  EXPECT_EQ(OpenBlasCoreFor(loaded, HostCpu()), "")
      << "this test runs OpenBLAS's " << loaded << " kernels on " << HostCpu().Summary();
}

TEST(CpuInfoTest, AutoPrecisionIsBf16OnlyWhereBf16ProductsBeatFp32) {
  TrainerOptions t;
  std::string why;
  t.precision = "fp32";
  EXPECT_EQ(EffectivePrecision(t, &why), "fp32");
  t.precision = "bf16";
  EXPECT_EQ(EffectivePrecision(t), "bf16");
  t.precision = "auto";
  t.device = "cuda:0";
  EXPECT_EQ(EffectivePrecision(t, &why), "fp32");
  EXPECT_EQ(why, "auto: fp32 on cuda:0");
  t.device = "cpu";
  const std::string expected = HostCpu().Bf16FasterThanFp32() ? "bf16" : "fp32";
  EXPECT_EQ(EffectivePrecision(t, &why), expected);
  // The reason, not the CPU again (msspr_train prints the CPU beside it).
  const char* reason = HostCpu().Bf16FasterThanFp32() ? "multiplies bfloat16 faster than fp32"
                       : HostCpu().NativeBf16()       ? "has AVX512-BF16 but no AMX"
                                                      : "has no bfloat16 arithmetic";
  EXPECT_NE(why.find(reason), std::string::npos) << why;
  EXPECT_EQ(why.find(HostCpu().Summary()), std::string::npos) << why;
  EXPECT_EQ(why.rfind("auto: " + expected, 0), 0u) << why;
}

TEST(CpuInfoTest, IsaPeaksRunOnlyTheInstructionsTheFlagsAllow) {
  // Without the flags nothing runs: a CPU without AVX2 must not execute FMAs.
  CpuInfo bare = HostCpu();
  bare.flags.clear();
  const IsaPeaks nothing = MeasureIsaPeaks(bare, 0.03);
  EXPECT_EQ(nothing.fp32_isa, "");
  EXPECT_EQ(nothing.fp32_gflops, -1);
  EXPECT_EQ(nothing.bf16_dot_gflops, -1);
  EXPECT_EQ(nothing.ToJson(), "{\"fp32_isa\": \"\", \"fp32_gflops\": -1, \"bf16_dot_gflops\": -1}");
  // AVX2 with FMA but no AVX-512: 8-lane FMAs and no bfloat16 dot products.
  if (HostCpu().Has("avx2") && HostCpu().Has("fma")) {
    CpuInfo avx2 = HostCpu();
    avx2.flags = {"avx2", "fma"};
    const IsaPeaks p = MeasureIsaPeaks(avx2, 0.03);
    EXPECT_EQ(p.fp32_isa, "avx2");
    EXPECT_GT(p.fp32_gflops, 0.5);
    EXPECT_EQ(p.bf16_dot_gflops, -1);
  }
}

TEST(CpuInfoTest, IsaPeaksMeasureThisCpusFmaAndBf16DotRates) {
  const CpuInfo& cpu = HostCpu();
  const IsaPeaks p = MeasureIsaPeaks(cpu, 0.06);
  if (cpu.Has("avx512f")) {
    EXPECT_EQ(p.fp32_isa, "avx512f");
  } else if (cpu.Has("avx2") && cpu.Has("fma")) {
    EXPECT_EQ(p.fp32_isa, "avx2");
  } else {
    GTEST_SKIP() << "no AVX2 with FMA on " << cpu.Summary();
  }
  // Even a core shared with other work retires more than 1 GFLOP/s of vector
  // FMAs (an idle AVX-512 core: 100-150).
  EXPECT_GT(p.fp32_gflops, 1.0) << cpu.Summary();
  EXPECT_LT(p.fp32_gflops, 1000.0) << cpu.Summary();
  if (cpu.Has("avx512_bf16")) {
    EXPECT_GT(p.bf16_dot_gflops, 1.0) << cpu.Summary();
  } else {
    EXPECT_EQ(p.bf16_dot_gflops, -1);
  }
}

}  // namespace
}  // namespace core
}  // namespace msspr
