// The open-square task of the learning tests: a point in [-1, 1]^2 moved by
// 0.2 a per step, a noisy straight-line expert dataset and a success rate;
// also seen as 16 x 16 images.
#pragma once

#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "msspr_core/dataset.h"
#include "msspr_core/policy.h"

namespace msspr {
namespace core {
namespace point_square {

constexpr float kStepSize = 0.2f;  // action a moves the point by 0.2 a
constexpr float kGoalRadius = 0.15f;
constexpr int kEpisodeSteps = 30;

inline float Clip(float v, float lo, float hi) { return std::min(hi, std::max(lo, v)); }

// s' = clip(s + 0.2 clip(a, -1, 1), -1, 1) in the square [-1, 1]^2.
inline void EnvStep(float* s, const float* a) {
  for (int d = 0; d < 2; ++d) s[d] = Clip(s[d] + kStepSize * Clip(a[d], -1.f, 1.f), -1.f, 1.f);
}

inline float Distance(const float* a, const float* b) {
  return std::hypot(a[0] - b[0], a[1] - b[1]);
}

// Expert: straight toward its own goal, Gaussian noise (std 0.3), a new goal
// whenever the current one is reached.
inline std::shared_ptr<const Dataset> ExpertDataset(int episodes, int length, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> pos(-1.f, 1.f);
  std::normal_distribution<float> noise(0.f, 0.3f);
  DatasetBuilder b(2, 2);
  for (int e = 0; e < episodes; ++e) {
    std::vector<float> obs(length * 2), act(length * 2);
    float s[2] = {pos(rng), pos(rng)}, g[2] = {pos(rng), pos(rng)};
    for (int t = 0; t < length; ++t) {
      if (Distance(s, g) < kGoalRadius) {
        g[0] = pos(rng);
        g[1] = pos(rng);
      }
      const float dx = g[0] - s[0], dy = g[1] - s[1];
      const float dist = std::hypot(dx, dy);
      const float scale = dist > kStepSize ? 1.f / dist : 1.f / kStepSize;
      float a[2] = {Clip(dx * scale + noise(rng), -1.f, 1.f),
                    Clip(dy * scale + noise(rng), -1.f, 1.f)};
      obs[2 * t] = s[0];
      obs[2 * t + 1] = s[1];
      act[2 * t] = a[0];
      act[2 * t + 1] = a[1];
      EnvStep(s, a);
    }
    b.AddEpisode(obs, act);
  }
  return std::make_shared<const Dataset>(b.Build());
}

// Success rate over `episodes` random start/goal pairs at least 0.5 apart,
// acting with act(s, g, a): the action for point s and goal g into a[2].
template <typename Act>
double SuccessRateOf(int episodes, uint64_t seed, Act act) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> pos(-0.9f, 0.9f);
  int successes = 0;
  for (int e = 0; e < episodes; ++e) {
    float s[2], g[2];
    do {
      s[0] = pos(rng), s[1] = pos(rng), g[0] = pos(rng), g[1] = pos(rng);
    } while (Distance(s, g) < 0.5f);
    for (int t = 0; t < kEpisodeSteps; ++t) {
      float a[2];
      act(s, g, a);
      EnvStep(s, a);
      if (Distance(s, g) <= kGoalRadius) {
        ++successes;
        break;
      }
    }
  }
  return static_cast<double>(successes) / episodes;
}

// SuccessRateOf a state policy.
inline double SuccessRate(Policy& policy, int episodes, uint64_t seed) {
  return SuccessRateOf(episodes, seed, [&](const float* s, const float* g, float* a) {
    const std::vector<float> out = policy.Act({s[0], s[1]}, {g[0], g[1]});
    std::copy(out.begin(), out.end(), a);
  });
}

// --- From images: the same task seen by a camera ---------------------------------

constexpr int kImageSide = 16;

// A kImageSide x kImageSide x 3 image of the point: a Gaussian blob (std
// 1.5 pixels) at its position in the red channel; the other two stay black.
inline std::vector<uint8_t> Render(const float* s) {
  std::vector<uint8_t> img(kImageSide * kImageSide * 3, 0);
  const float px = (s[0] + 1.f) * 0.5f * (kImageSide - 1);
  const float py = (s[1] + 1.f) * 0.5f * (kImageSide - 1);
  for (int y = 0; y < kImageSide; ++y) {
    for (int x = 0; x < kImageSide; ++x) {
      const float d2 = (x - px) * (x - px) + (y - py) * (y - py);
      img[(y * kImageSide + x) * 3] = static_cast<uint8_t>(255.f * std::exp(-d2 / (2 * 2.25f)));
    }
  }
  return img;
}

// ExpertDataset's episodes with an image per step (states kept too).
inline std::shared_ptr<const Dataset> ExpertImageDataset(int episodes, int length, uint64_t seed) {
  const Dataset states = *ExpertDataset(episodes, length, seed);
  DatasetBuilder b(2, 2, ImageShape{kImageSide, kImageSide, 3});
  const float* obs = states.state(0);
  const float* act = states.action(0);
  for (int e = 0; e < episodes; ++e) {
    const int64_t first = int64_t{e} * length;
    std::vector<uint8_t> images;
    for (int t = 0; t < length; ++t) {
      const std::vector<uint8_t> img = Render(obs + 2 * (first + t));
      images.insert(images.end(), img.begin(), img.end());
    }
    b.AddEpisode(obs + 2 * first, act + 2 * first, length, images.data());
  }
  return std::make_shared<const Dataset>(b.Build());
}

// SuccessRateOf a policy that sees the images of the point and of the goal.
inline double ImageSuccessRate(Policy& policy, int episodes, uint64_t seed) {
  auto image = [](const float* p) {
    return torch::from_blob(Render(p).data(), {kImageSide, kImageSide, 3}, torch::kUInt8).clone();
  };
  return SuccessRateOf(episodes, seed, [&](const float* s, const float* g, float* a) {
    const torch::Tensor out = policy.Act(image(s), image(g)).to(torch::kCPU).contiguous();
    std::copy(out.data_ptr<float>(), out.data_ptr<float>() + 2, a);
  });
}

}  // namespace point_square
}  // namespace core
}  // namespace msspr
