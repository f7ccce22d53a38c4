// End-to-end: each of OGBench's baseline agents, small, learns to reach
// goals with a point in an open square from a noisy straight-line expert
// dataset (the task of learning_test.cc), through the shared Trainer; GCIVL
// also with bf16 products and acting with a moving average of its actor.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ostream>

#include "msspr_core/trainer.h"
#include "point_square.h"

namespace msspr {
namespace core {
namespace {

struct Case {
  std::string agent;
  int64_t steps;
  double min_success;  // untrained: 0
  std::string precision = "fp32";
  double policy_ema = 0;
  bool images = false;  // from 16 x 16 images of the point and the goal (the light CNN)
};

void PrintTo(const Case& c, std::ostream* os) {
  *os << c.agent << " (" << c.steps << " steps, " << c.precision << ", policy_ema " << c.policy_ema
      << (c.images ? ", images" : "") << ")";
}

class BaselineLearningTest : public testing::TestWithParam<Case> {};

TEST_P(BaselineLearningTest, PointInSquareReachesGoals) {
  torch::set_num_threads(1);
  const Case c = GetParam();
  MsprOptions o = MakePreset(c.agent, "cpu");
  o.baseline.hidden = 64;
  o.baseline.layers = 2;
  o.baseline.latent_dim = 64;
  o.baseline.subgoal_steps = 5;
  o.agent.gamma = 0.95;
  o.trainer.batch_size = 128;
  o.trainer.steps = c.steps;
  o.trainer.seed = 7;
  o.trainer.log_every = 500;
  o.trainer.precision = c.precision;
  o.trainer.policy_ema = c.policy_ema;
  if (c.images) {
    o.network.obs_mode = "pixels";
    o.network.cnn = "light";
    o.baseline.low_actor_rep_grad = true;  // HIQL: OGBench's setting for pixels
  }
  if (const char* s = std::getenv("MSSPR_LEARNING_STEPS")) o.trainer.steps = std::atoll(s);
  if (const char* s = std::getenv("MSSPR_LEARNING_SEED"))
    o.trainer.seed = std::strtoull(s, nullptr, 10);
  Trainer trainer(o, c.images ? point_square::ExpertImageDataset(300, 40, 1)
                              : point_square::ExpertDataset(300, 40, 1));
  Policy policy = trainer.MakePolicy();
  auto success = [&](int episodes, uint64_t seed) {
    return c.images ? point_square::ImageSuccessRate(policy, episodes, seed)
                    : point_square::SuccessRate(policy, episodes, seed);
  };
  const double untrained = success(100, 123);
  const auto start = std::chrono::steady_clock::now();
  TrainLoopOptions loop;
  loop.quiet = std::getenv("MSSPR_LEARNING_VERBOSE") == nullptr;
  trainer.Train(loop);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double trained = success(100, 123);
  std::printf(
      "baseline learning test (%s, %s, policy_ema %g%s): %lld steps in %.1f s; success untrained "
      "%.2f, trained %.2f\n",
      c.agent.c_str(), c.precision.c_str(), c.policy_ema, c.images ? ", images" : "",
      static_cast<long long>(o.trainer.steps), seconds, untrained, trained);
  RecordProperty("untrained_success", std::to_string(untrained));
  RecordProperty("trained_success", std::to_string(trained));
  EXPECT_LT(untrained, 0.5);
  EXPECT_GE(trained, c.min_success);
}

INSTANTIATE_TEST_SUITE_P(
    Agents, BaselineLearningTest,
    // The DDPG+BC agents (small BC weights) learn through their critics: slower.
    // At the steps given QRL, HIQL and the two bf16 GCIVL cases reached 0.98-1.00 (seed 7);
    // GCIQL reached 0.33 at 2000 steps and CRL 0.59 at 4000.
    testing::Values(Case{"gcbc", 2000, 0.9}, Case{"gcivl", 2000, 0.9}, Case{"gciql", 4000, 0.9},
                    Case{"qrl", 1000, 0.9}, Case{"crl", 8000, 0.7}, Case{"hiql", 1000, 0.9},
                    // The policy (MakePolicy) acts with the average of the actor.
                    Case{"gcivl", 1000, 0.9, "bf16", 0.99},
                    // From images of the point and the goal.
                    Case{"gcivl", 1000, 0.9, "bf16", 0, true},
                    // HIQL's five CNNs from images, in fp32 (bf16 convolutions are slow on a
                    // CPU without AMX): 0.88-0.90 at 1000 steps, 0.95-0.97 at 2000 (Intel
                    // Xeon); 0.7 shows it learned (untrained: 0).
                    Case{"hiql", 1000, 0.7, "fp32", 0, true}),
    [](const testing::TestParamInfo<Case>& info) {
      std::string name = info.param.agent;
      if (info.param.precision != "fp32") name += "_" + info.param.precision;
      if (info.param.policy_ema > 0) name += "_ema";
      if (info.param.images) name += "_images";
      return name;
    });

}  // namespace
}  // namespace core
}  // namespace msspr
