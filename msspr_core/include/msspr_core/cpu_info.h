// The CPU this process runs on, so that every timing and every precision
// decision can say where it came from. No torch.
#pragma once

#include <string>
#include <vector>

namespace msspr {
namespace core {

struct CpuInfo {
  std::string model_name;  // as lscpu's "Model name" ("/proc/cpuinfo" model name)
  std::string vendor;      // "GenuineIntel", "AuthenticAMD", ...
  int family = -1;         // cpu family (-1: unknown)
  int model = -1;          // model number within the family (-1: unknown)
  int logical_cpus = 0;    // processors listed in /proc/cpuinfo (0: unknown)
  // The flags that decide the trainer's speed, among: avx2 fma avx512f
  // avx512_bf16 amx_bf16 amx_tile avx512_fp16 (in that order, those present).
  std::vector<std::string> flags;

  bool Has(const std::string& flag) const;
  // bfloat16 matrix products in hardware (AVX512-BF16 or AMX-BF16). Without
  // them bf16 is emulated and slower than fp32.
  bool NativeBf16() const { return Has("avx512_bf16") || Has("amx_bf16"); }
  // Whether LibTorch's bfloat16 matrix products (oneDNN) beat its fp32 ones
  // (OpenBLAS) on this CPU, by kind, as measured on 256-wide layers:
  // - Intel with AMX: 630-1,000 GFLOP/s in bf16 against 135-160 in fp32;
  // - AMD with AVX512-BF16 (Zen 4 on): OpenBLAS runs AVX2 kernels there, and
  //   a training step took 82 ms in bf16 against 128 in fp32;
  // - Intel with AVX512-BF16 but no AMX (AMX absent or not exposed to a
  //   virtual machine): oneDNN's AVX512-BF16 kernels ran at 68 GFLOP/s against
  //   OpenBLAS's AVX-512 fp32 at 97, and a step took 171 ms against 129; the
  //   core retires AVX512-BF16 dot products at half its fp32 FMA rate
  //   (MeasureIsaPeaks, isa_peaks.h: 86 against 174 GFLOP/s, family 6 model 207).
  bool Bf16FasterThanFp32() const {
    return Has("amx_bf16") || (Has("avx512_bf16") && vendor == "AuthenticAMD");
  }
  // "Intel(R) Xeon(R) Processor (GenuineIntel family 6 model 167; avx2 fma ...)"
  std::string Summary() const;
  // {"model_name": ..., "vendor": ..., "family": 6, "model": 167,
  //  "logical_cpus": 2, "flags": ["avx2", ...]}
  std::string ToJson() const;
  // The same as YAML lines, each prefixed with indent.
  std::string ToYaml(const std::string& indent = "") const;
};

// Parses the text of /proc/cpuinfo (the first processor's entries).
CpuInfo ParseCpuInfo(const std::string& proc_cpuinfo);

// This machine's CPU, read once (empty fields where /proc/cpuinfo is absent).
const CpuInfo& HostCpu();

}  // namespace core
}  // namespace msspr
