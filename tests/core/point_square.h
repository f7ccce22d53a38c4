// The open-square task of the learning tests: a point in [-1, 1]^2 moved by
// 0.2 a per step, a noisy straight-line expert dataset and a success rate.
#pragma once

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

// Success rate over `episodes` random start/goal pairs at least 0.5 apart.
inline double SuccessRate(Policy& policy, int episodes, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> pos(-0.9f, 0.9f);
  int successes = 0;
  for (int e = 0; e < episodes; ++e) {
    float s[2], g[2];
    do {
      s[0] = pos(rng), s[1] = pos(rng), g[0] = pos(rng), g[1] = pos(rng);
    } while (Distance(s, g) < 0.5f);
    for (int t = 0; t < kEpisodeSteps; ++t) {
      const std::vector<float> a = policy.Act({s[0], s[1]}, {g[0], g[1]});
      EnvStep(s, a.data());
      if (Distance(s, g) <= kGoalRadius) {
        ++successes;
        break;
      }
    }
  }
  return static_cast<double>(successes) / episodes;
}

}  // namespace point_square
}  // namespace core
}  // namespace msspr
