// Helpers for the msspr_core tests that use torch.
#pragma once

#include <ATen/autocast_mode.h>
#include <torch/torch.h>

#include <cstdlib>
#include <memory>
#include <random>
#include <vector>

#include "msspr_core/dataset.h"
#include "msspr_core/options.h"

namespace msspr {
namespace core {
namespace testing_util {

// CPU autocast to bfloat16 for a scope, as trainer.precision bf16 runs the update.
class CpuBf16Autocast {
 public:
  CpuBf16Autocast() {
#if TORCH_VERSION_MAJOR > 2 || (TORCH_VERSION_MAJOR == 2 && TORCH_VERSION_MINOR >= 4)
    at::autocast::set_autocast_dtype(at::kCPU, at::kBFloat16);
    at::autocast::set_autocast_enabled(at::kCPU, true);
#else
    at::autocast::set_autocast_cpu_dtype(at::kBFloat16);
    at::autocast::set_cpu_enabled(true);
#endif
  }
  ~CpuBf16Autocast() {
#if TORCH_VERSION_MAJOR > 2 || (TORCH_VERSION_MAJOR == 2 && TORCH_VERSION_MINOR >= 4)
    at::autocast::set_autocast_enabled(at::kCPU, false);
#else
    at::autocast::set_cpu_enabled(false);
#endif
    at::autocast::clear_cache();
  }
  CpuBf16Autocast(const CpuBf16Autocast&) = delete;
  CpuBf16Autocast& operator=(const CpuBf16Autocast&) = delete;
};

// Tiny network sizes so that tests run in milliseconds. The trainer's device
// is cpu, or MSSPR_TEST_DEVICE when set (e.g. cuda, on a GPU machine).
inline MsprOptions TinyOptions(const std::string& preset = "mspr") {
  MsprOptions o = MakePreset(preset, "cpu");
  NetworkOptions& n = o.network;
  n.encoder_hidden = n.zsa_hidden = n.goal_hidden = n.critic_hidden = n.actor_hidden = 32;
  n.zs_dim = n.zsa_dim = 24;
  n.za_dim = 16;
  n.goal_dim = 8;
  o.trainer.batch_size = 16;
  o.trainer.steps = 10;
  o.trainer.seed = 3;
  if (const char* d = std::getenv("MSSPR_TEST_DEVICE"); d != nullptr && *d != '\0') {
    o.trainer.device = d;
  }
  return o;
}

// Random-walk trajectories in 3-D (or 8x8x3 images when pixels is set... see
// RandomImageDataset), actions in [-1, 1]^2.
inline std::shared_ptr<const Dataset> RandomStateDataset(int episodes = 6, int length = 12,
                                                         int obs_dim = 3, uint64_t seed = 1) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<float> normal;
  DatasetBuilder b(obs_dim, 2);
  for (int e = 0; e < episodes; ++e) {
    std::vector<float> obs(length * obs_dim), act(length * 2);
    for (auto& v : obs) v = normal(rng);
    for (auto& v : act) v = std::tanh(normal(rng));
    b.AddEpisode(obs, act);
  }
  return std::make_shared<const Dataset>(b.Build());
}

// 64x64x3 uint8 image trajectories (plus 2-D states).
inline std::shared_ptr<const Dataset> RandomImageDataset(int episodes = 3, int length = 8,
                                                         uint64_t seed = 1) {
  std::mt19937_64 rng(seed);
  std::uniform_int_distribution<int> pixel(0, 255);
  std::normal_distribution<float> normal;
  const ImageShape shape{64, 64, 3};
  DatasetBuilder b(2, 2, shape);
  for (int e = 0; e < episodes; ++e) {
    std::vector<float> obs(length * 2), act(length * 2);
    std::vector<uint8_t> img(length * shape.numel());
    for (auto& v : obs) v = normal(rng);
    for (auto& v : act) v = std::tanh(normal(rng));
    for (auto& v : img) v = static_cast<uint8_t>(pixel(rng));
    b.AddEpisode(obs, act, img);
  }
  return std::make_shared<const Dataset>(b.Build());
}

// Concatenation of all parameters and buffers of a module, flattened.
inline torch::Tensor Flat(const torch::nn::Module& m) {
  std::vector<torch::Tensor> parts;
  for (const auto& p : m.parameters()) parts.push_back(p.detach().flatten().cpu());
  for (const auto& b : m.buffers()) parts.push_back(b.detach().flatten().cpu().to(torch::kFloat32));
  return torch::cat(parts);
}

}  // namespace testing_util
}  // namespace core
}  // namespace msspr
