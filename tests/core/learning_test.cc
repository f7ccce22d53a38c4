// End-to-end: a small Ms.PR agent learns to reach goals with a point in an
// open square from a noisy straight-line expert dataset.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <random>

#include "msspr_core/trainer.h"
#include "point_square.h"

namespace msspr {
namespace core {
namespace {

using point_square::ExpertDataset;
using point_square::SuccessRate;

// The small agent of these tests (widths 64, batch 128, 1000 steps, seed 7). At 1000 steps it
// reached 0.97-1.00 of the goals: fp32 with seeds 7, 1 and 2; bf16, the AWR actor and the
// expectile critic target with seeds 7 and 3.
MsprOptions SmallAgent(const std::string& precision) {
  MsprOptions o = MakePreset("mspr", "cpu");
  o.trainer.precision = precision;
  NetworkOptions& n = o.network;
  n.encoder_hidden = n.zsa_hidden = n.goal_hidden = n.critic_hidden = n.actor_hidden = 64;
  n.zs_dim = n.zsa_dim = 64;
  n.za_dim = 32;
  n.goal_dim = 32;
  o.agent.gamma = 0.95;
  o.agent.bc_weight = 0.1;
  o.trainer.batch_size = 128;
  o.trainer.steps = 1000;
  o.trainer.seed = 7;
  // Overrides for experiments (the asserted configuration uses neither).
  if (const char* s = std::getenv("MSSPR_LEARNING_STEPS")) o.trainer.steps = std::atoll(s);
  if (const char* s = std::getenv("MSSPR_LEARNING_SEED"))
    o.trainer.seed = std::strtoull(s, nullptr, 10);
  o.trainer.log_every = 500;  // before the Trainer, which copies its options
  return o;
}

// Trains `o` on the expert dataset; checks that it learned (success on 100
// seeded goals: below 0.5 untrained, at least 0.9 trained).
void ExpectLearnsPointInSquare(const MsprOptions& o, const std::string& label) {
  // One thread: on shared cores OpenMP spinning of 2 threads is ~10x slower.
  torch::set_num_threads(1);
  Trainer trainer(o, ExpertDataset(300, 40, 1));
  Policy policy = trainer.MakePolicy();
  const double untrained = SuccessRate(policy, 100, 123);
  const auto start = std::chrono::steady_clock::now();
  TrainLoopOptions loop;
  loop.quiet = std::getenv("MSSPR_LEARNING_VERBOSE") == nullptr;
  trainer.Train(loop, [](Policy& p, int64_t step) -> EvalResult {
    return {{"success", SuccessRate(p, 50, 1000 + step)}};
  });
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const double trained = SuccessRate(policy, 100, 123);
  std::printf(
      "learning test (%s): %lld steps in %.1f s (%.1f steps/s); success untrained %.2f, "
      "trained %.2f\n",
      label.c_str(), static_cast<long long>(o.trainer.steps), seconds, o.trainer.steps / seconds,
      untrained, trained);
  testing::Test::RecordProperty("untrained_success", std::to_string(untrained));
  testing::Test::RecordProperty("trained_success", std::to_string(trained));
  EXPECT_LT(untrained, 0.5);
  EXPECT_GE(trained, 0.9);
}

// The same agent learns with fp32 and with bf16 matrix products.
class LearningTest : public testing::TestWithParam<std::string> {};

TEST_P(LearningTest, PointInSquareReachesGoals) {
  ExpectLearnsPointInSquare(SmallAgent(GetParam()), GetParam());
}

// The actor trained by advantage-weighted regression (agent.actor_loss: awr) learns too.
TEST(LearningAwrActor, PointInSquareReachesGoals) {
  MsprOptions o = SmallAgent("fp32");
  o.agent.actor_loss = "awr";
  ExpectLearnsPointInSquare(o, "fp32, awr actor");
}

// The critic bootstrapped in-sample from an expectile value (agent.critic_target:
// expectile) learns too.
TEST(LearningExpectileCritic, PointInSquareReachesGoals) {
  MsprOptions o = SmallAgent("fp32");
  o.agent.critic_target = "expectile";
  ExpectLearnsPointInSquare(o, "fp32, expectile critic target");
}

// The subgoal policy (agent.subgoal_steps: the actor toward the state k steps
// ahead, a subgoal actor proposing it) learns too, more slowly (0.93-0.94 at 1000 steps, 0.99 at
// 1500, seeds 7 and 3).
TEST(LearningSubgoalPolicy, PointInSquareReachesGoals) {
  MsprOptions o = SmallAgent("fp32");
  o.agent.subgoal_steps = 5;
  if (std::getenv("MSSPR_LEARNING_STEPS") == nullptr) o.trainer.steps = 1500;
  ExpectLearnsPointInSquare(o, "fp32, subgoal policy");
}

INSTANTIATE_TEST_SUITE_P(Precision, LearningTest, testing::Values("fp32", "bf16"),
                         [](const testing::TestParamInfo<std::string>& info) {
                           return info.param;
                         });

}  // namespace
}  // namespace core
}  // namespace msspr
