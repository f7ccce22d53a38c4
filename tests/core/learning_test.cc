// End-to-end: a small Ms.PR agent learns to reach goals with a point in an
// open square from a noisy straight-line expert dataset.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <random>

#include "msspr_core/trainer.h"

namespace msspr {
namespace core {
namespace {

constexpr float kStepSize = 0.2f;  // action a moves the point by 0.2 a
constexpr float kGoalRadius = 0.15f;
constexpr int kEpisodeSteps = 30;

float Clip(float v, float lo, float hi) { return std::min(hi, std::max(lo, v)); }

// s' = clip(s + 0.2 clip(a, -1, 1), -1, 1) in the square [-1, 1]^2.
void EnvStep(float* s, const float* a) {
  for (int d = 0; d < 2; ++d) s[d] = Clip(s[d] + kStepSize * Clip(a[d], -1.f, 1.f), -1.f, 1.f);
}

float Distance(const float* a, const float* b) { return std::hypot(a[0] - b[0], a[1] - b[1]); }

// Expert: straight toward its own goal, Gaussian noise (std 0.3), a new goal
// whenever the current one is reached.
std::shared_ptr<const Dataset> ExpertDataset(int episodes, int length, uint64_t seed) {
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
      float a[2] = {Clip(dx * scale + noise(rng), -1.f, 1.f), Clip(dy * scale + noise(rng), -1.f, 1.f)};
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
double SuccessRate(Policy& policy, int episodes, uint64_t seed) {
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

// The same agent learns with fp32 and with bf16 matrix products.
class LearningTest : public testing::TestWithParam<std::string> {};

TEST_P(LearningTest, PointInSquareReachesGoals) {
  // One thread: on shared cores OpenMP spinning of 2 threads is ~10x slower.
  torch::set_num_threads(1);
  MsprOptions o = MakePreset("mspr", "cpu");
  o.trainer.precision = GetParam();
  NetworkOptions& n = o.network;
  n.encoder_hidden = n.zsa_hidden = n.goal_hidden = n.critic_hidden = n.actor_hidden = 64;
  n.zs_dim = n.zsa_dim = 64;
  n.za_dim = 32;
  n.goal_dim = 32;
  o.agent.gamma = 0.95;
  o.agent.bc_weight = 0.1;
  o.trainer.batch_size = 128;
  o.trainer.steps = 2000;
  o.trainer.seed = 7;
  // Overrides for experiments (the asserted configuration uses neither).
  if (const char* s = std::getenv("MSSPR_LEARNING_STEPS")) o.trainer.steps = std::atoll(s);
  if (const char* s = std::getenv("MSSPR_LEARNING_SEED")) o.trainer.seed = std::strtoull(s, nullptr, 10);
  Trainer trainer(o, ExpertDataset(300, 40, 1));
  Policy policy = trainer.MakePolicy();
  const double untrained = SuccessRate(policy, 100, 123);
  const auto start = std::chrono::steady_clock::now();
  TrainLoopOptions loop;
  loop.quiet = std::getenv("MSSPR_LEARNING_VERBOSE") == nullptr;
  o.trainer.log_every = 500;
  trainer.Train(loop, [](Policy& p, int64_t step) -> EvalResult {
    return {{"success", SuccessRate(p, 50, 1000 + step)}};
  });
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double trained = SuccessRate(policy, 100, 123);
  std::printf("learning test (%s): %lld steps in %.1f s (%.1f steps/s); success untrained %.2f, "
              "trained %.2f\n",
              o.trainer.precision.c_str(), static_cast<long long>(o.trainer.steps), seconds, o.trainer.steps / seconds,
              untrained, trained);
  RecordProperty("untrained_success", std::to_string(untrained));
  RecordProperty("trained_success", std::to_string(trained));
  EXPECT_LT(untrained, 0.5);
  EXPECT_GE(trained, 0.9);
}

INSTANTIATE_TEST_SUITE_P(Precision, LearningTest, testing::Values("fp32", "bf16"),
                         [](const testing::TestParamInfo<std::string>& info) { return info.param; });

}  // namespace
}  // namespace core
}  // namespace msspr
