#include "msspr_core/cpu_info.h"

#include <gtest/gtest.h>

#include <string>

#include "msspr_core/options.h"

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

TEST(CpuInfoTest, UnknownFieldsStayUnknown) {
  const CpuInfo c = ParseCpuInfo("");
  EXPECT_EQ(c.family, -1);
  EXPECT_EQ(c.model, -1);
  EXPECT_EQ(c.logical_cpus, 0);
  EXPECT_FALSE(c.NativeBf16());
  EXPECT_EQ(c.Summary(), "unknown CPU (family -1 model -1; no AVX2)");
}

TEST(CpuInfoTest, AutoPrecisionIsBf16OnlyOnACpuWithBf16Arithmetic) {
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
  const std::string expected = HostCpu().NativeBf16() ? "bf16" : "fp32";
  EXPECT_EQ(EffectivePrecision(t, &why), expected);
  // The reason, not the CPU again (msspr_train prints the CPU beside it).
  EXPECT_NE(why.find(HostCpu().NativeBf16() ? "multiplies bfloat16 in hardware"
                                            : "has no bfloat16 arithmetic"),
            std::string::npos)
      << why;
  EXPECT_EQ(why.find(HostCpu().Summary()), std::string::npos) << why;
  EXPECT_EQ(why.rfind("auto: " + expected, 0), 0u) << why;
}

}  // namespace
}  // namespace core
}  // namespace msspr
