// Autocast's per-device switches across LibTorch versions: 2.4 replaced the
// per-device functions by ones taking the device type (the old ones warn on
// every call there). Shared by PrecisionScope (trainer_internal.h) and the
// bf16 weight cache (bf16_weights.cc).
#pragma once

#include <ATen/autocast_mode.h>
#include <torch/version.h>

namespace msspr {
namespace core {
namespace internal {

#if TORCH_VERSION_MAJOR > 2 || (TORCH_VERSION_MAJOR == 2 && TORCH_VERSION_MINOR >= 4)
inline bool AutocastEnabled(at::DeviceType t) { return at::autocast::is_autocast_enabled(t); }
inline at::ScalarType AutocastDtype(at::DeviceType t) {
  return at::autocast::get_autocast_dtype(t);
}
inline void SetAutocastEnabled(at::DeviceType t, bool on) {
  at::autocast::set_autocast_enabled(t, on);
}
inline void SetAutocastDtype(at::DeviceType t, at::ScalarType d) {
  at::autocast::set_autocast_dtype(t, d);
}
#else
inline bool AutocastEnabled(at::DeviceType t) {
  return t == at::kCUDA ? at::autocast::is_enabled() : at::autocast::is_cpu_enabled();
}
inline at::ScalarType AutocastDtype(at::DeviceType t) {
  return t == at::kCUDA ? at::autocast::get_autocast_gpu_dtype()
                        : at::autocast::get_autocast_cpu_dtype();
}
inline void SetAutocastEnabled(at::DeviceType t, bool on) {
  if (t == at::kCUDA)
    at::autocast::set_enabled(on);
  else
    at::autocast::set_cpu_enabled(on);
}
inline void SetAutocastDtype(at::DeviceType t, at::ScalarType d) {
  if (t == at::kCUDA)
    at::autocast::set_autocast_gpu_dtype(d);
  else
    at::autocast::set_autocast_cpu_dtype(d);
}
#endif

// Turns autocast off on this thread (CPU and CUDA) for a scope, and back to
// what it was at the end.
class AutocastOffScope {
 public:
  AutocastOffScope() : cpu_(AutocastEnabled(at::kCPU)), cuda_(AutocastEnabled(at::kCUDA)) {
    if (cpu_) SetAutocastEnabled(at::kCPU, false);
    if (cuda_) SetAutocastEnabled(at::kCUDA, false);
  }
  ~AutocastOffScope() {
    if (cpu_) SetAutocastEnabled(at::kCPU, true);
    if (cuda_) SetAutocastEnabled(at::kCUDA, true);
  }
  AutocastOffScope(const AutocastOffScope&) = delete;
  AutocastOffScope& operator=(const AutocastOffScope&) = delete;

 private:
  bool cpu_, cuda_;
};

// Whether autocast runs CPU products in bfloat16 on this thread.
inline bool CpuBf16Autocast() {
  return AutocastEnabled(at::kCPU) && AutocastDtype(at::kCPU) == at::kBFloat16;
}

}  // namespace internal
}  // namespace core
}  // namespace msspr
