#include "msspr_core/trainer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "torch_test_util.h"

namespace msspr {
namespace core {
namespace {

using testing_util::Flat;
using testing_util::RandomStateDataset;
using testing_util::TinyOptions;

std::shared_ptr<torch::nn::LinearImpl> LastLinear(Mlp& mlp) {
  auto last = std::dynamic_pointer_cast<torch::nn::LinearImpl>(mlp->net->ptr(mlp->net->size() - 1));
  TORCH_CHECK(last, "last layer is not Linear");
  return last;
}

// Makes an MLP output the constant c for every input.
void SetConstant(Mlp& mlp, float c) {
  torch::NoGradGuard no_grad;
  auto last = LastLinear(mlp);
  last->weight.zero_();
  last->bias.fill_(c);
}

double HuberValue(double d) { return std::abs(d) <= 1.0 ? 0.5 * d * d : std::abs(d) - 0.5; }

TransitionBatch FixedBatch(int obs_dim) {
  torch::manual_seed(11);
  TransitionBatch b;
  const int64_t B = 4;
  b.obs = torch::randn({B, obs_dim});
  b.next_obs = torch::randn({B, obs_dim});
  b.value_goal = torch::randn({B, obs_dim});
  b.actor_goal = torch::randn({B, obs_dim});
  b.action = torch::tensor({0.1f, -0.2f, 0.5f, 0.5f, -1.0f, 1.0f, 0.0f, 0.3f}).view({B, 2});
  b.ret = torch::tensor({0.0f, -1.0f, -2.71f, -2.5f});
  b.discount = torch::tensor({0.0f, 0.9f, 0.729f, 0.0f});
  return b;
}

TEST(TrainerTest, CriticLossEqualsHandComputedValue) {
  Trainer t(TinyOptions(), RandomStateDataset());
  SetConstant(t.critic()->q1, -2.0f);
  SetConstant(t.critic()->q2, -3.0f);
  SetConstant(t.target_critic()->q1, -4.0f);
  SetConstant(t.target_critic()->q2, -5.0f);
  const TransitionBatch b = FixedBatch(3);
  const torch::Tensor noise = torch::randn({4, 2});
  // y = R + discount * min(-4, -5) = {0, -5.5, -6.355, -2.5}
  const double y[4] = {0.0, -1.0 + 0.9 * -5.0, -2.71 + 0.729 * -5.0, -2.5};
  double expected = 0.0;
  for (double q : {-2.0, -3.0}) {
    double mean = 0.0;
    for (double yi : y) mean += HuberValue(q - yi) / 4.0;
    expected += mean;
  }
  LossInfo info;
  const double loss = t.CriticLoss(b, noise, &info).item<double>();
  EXPECT_NEAR(loss, expected, 1e-5);
  EXPECT_NEAR(loss, (1.5 + 3.0 + 3.855 + 0.125) / 4 + (2.5 + 2.0 + 2.855 + 0.125) / 4, 1e-5);
  EXPECT_NEAR(info.q_mean, -2.5, 1e-6);
}

TEST(TrainerTest, CriticTargetIsClippedToReturnRange) {
  MsprOptions o = TinyOptions();
  o.agent.gamma = 0.5;  // returns in [-2, 0]
  Trainer t(o, RandomStateDataset());
  SetConstant(t.critic()->q1, 0.0f);
  SetConstant(t.critic()->q2, 0.0f);
  SetConstant(t.target_critic()->q1, -10.0f);
  SetConstant(t.target_critic()->q2, -10.0f);
  TransitionBatch b = FixedBatch(3);
  b.ret = torch::tensor({-1.0f, -1.0f, -1.0f, -1.0f});
  b.discount = torch::tensor({0.5f, 0.5f, 0.5f, 0.5f});
  // y = -1 - 5 = -6, clipped to -2: Huber(2) = 1.5 per head.
  EXPECT_NEAR(t.CriticLoss(b, torch::zeros({4, 2})).item<double>(), 3.0, 1e-5);
}

TEST(TrainerTest, ActorLossEqualsHandComputedValue) {
  MsprOptions o = TinyOptions();
  o.agent.bc_weight = 0.7;
  Trainer t(o, RandomStateDataset());
  SetConstant(t.critic()->q1, -2.0f);
  SetConstant(t.critic()->q2, -3.0f);
  {
    torch::NoGradGuard no_grad;
    t.actor()->head->weight.zero_();
    t.actor()->head->bias.copy_(torch::tensor({0.5f, -0.25f}));
  }
  const TransitionBatch b = FixedBatch(3);
  // -min(Q) / mean|min(Q)| = 1; pi = tanh(bias) for every sample.
  const double p0 = std::tanh(0.5), p1 = std::tanh(-0.25);
  const double a[4][2] = {{0.1, -0.2}, {0.5, 0.5}, {-1.0, 1.0}, {0.0, 0.3}};
  double bc = 0.0;
  for (auto& ai : a) bc += ((p0 - ai[0]) * (p0 - ai[0]) + (p1 - ai[1]) * (p1 - ai[1])) / 4.0;
  LossInfo info;
  EXPECT_NEAR(t.ActorLoss(b, &info).item<double>(), 1.0 + 0.7 * bc, 1e-5);
  EXPECT_NEAR(info.bc, bc, 1e-5);
}

TEST(TrainerTest, TargetsGetNoGradientsAndEqualOnlineAfterHardUpdate) {
  MsprOptions o = TinyOptions();
  o.agent.target_update_every = 4;
  Trainer t(o, RandomStateDataset());
  for (auto* m : std::vector<torch::nn::Module*>{t.target_repr().get(), t.target_critic().get(),
                                                  t.target_actor().get()}) {
    for (const auto& p : m->parameters()) EXPECT_FALSE(p.requires_grad());
  }
  EXPECT_TRUE(torch::equal(Flat(*t.repr()), Flat(*t.target_repr())));
  for (int i = 0; i < 3; ++i) t.Step();
  // Online nets moved, targets did not.
  EXPECT_FALSE(torch::equal(Flat(*t.critic()), Flat(*t.target_critic())));
  EXPECT_FALSE(torch::equal(Flat(*t.repr()), Flat(*t.target_repr())));
  const torch::Tensor target_before = Flat(*t.target_actor());
  for (auto* m : std::vector<torch::nn::Module*>{t.target_repr().get(), t.target_critic().get(),
                                                  t.target_actor().get()}) {
    for (const auto& p : m->parameters()) EXPECT_FALSE(p.grad().defined());
  }
  // Step 4: hard copy before the updates of that step.
  const torch::Tensor actor_before = Flat(*t.actor());
  t.Step();
  EXPECT_TRUE(torch::equal(Flat(*t.target_actor()), actor_before));
  EXPECT_FALSE(torch::equal(Flat(*t.target_actor()), target_before));
  t.UpdateTargets();
  EXPECT_TRUE(torch::equal(Flat(*t.repr()), Flat(*t.target_repr())));
  EXPECT_TRUE(torch::equal(Flat(*t.critic()), Flat(*t.target_critic())));
  EXPECT_TRUE(torch::equal(Flat(*t.actor()), Flat(*t.target_actor())));
}

TEST(TrainerTest, EncodersLearnOnlyFromRepresentationLossByDefault) {
  Trainer t(TinyOptions(), RandomStateDataset());
  const TransitionBatch b = t.SampleTransitions();
  const torch::Tensor repr_before = Flat(*t.repr());
  const torch::Tensor critic_before = Flat(*t.critic());
  const torch::Tensor actor_before = Flat(*t.actor());
  t.UpdateCritic(b, torch::randn({b.action.size(0), 2}));
  t.UpdateActor(b);
  EXPECT_TRUE(torch::equal(Flat(*t.repr()), repr_before));
  EXPECT_FALSE(torch::equal(Flat(*t.critic()), critic_before));
  EXPECT_FALSE(torch::equal(Flat(*t.actor()), actor_before));
  // The critic loss reaches no encoder parameter.
  for (auto& p : t.repr()->parameters()) p.mutable_grad() = torch::Tensor();
  t.CriticLoss(b, torch::zeros({b.action.size(0), 2})).backward();
  for (const auto& p : t.repr()->parameters()) EXPECT_FALSE(p.grad().defined());
  // The representation loss trains them.
  t.UpdateRepresentation(t.SampleChunks());
  EXPECT_FALSE(torch::equal(Flat(*t.repr()), repr_before));

  // With the option, the critic's gradient reaches the encoders.
  MsprOptions o = TinyOptions();
  o.agent.critic_grad_to_encoder = true;
  Trainer through(o, RandomStateDataset());
  const torch::Tensor enc_before = Flat(*through.repr()->state_encoder);
  const TransitionBatch b2 = through.SampleTransitions();
  through.UpdateCritic(b2, torch::zeros({b2.action.size(0), 2}));
  EXPECT_FALSE(torch::equal(Flat(*through.repr()->state_encoder), enc_before));
}

TEST(TrainerTest, RepresentationLossTermsAndMasks) {
  for (int k : {5, 1}) {
    MsprOptions o = TinyOptions();
    o.network.goal_horizon = k;
    Trainer t(o, RandomStateDataset(4, 7));
    ChunkBatch c = t.SampleChunks();
    EXPECT_EQ(c.states.size(1), std::max(5, 4 + k) + 1);
    LossInfo info;
    const torch::Tensor loss = t.RepresentationLoss(c, &info);
    EXPECT_TRUE(std::isfinite(loss.item<double>()));
    for (double v : {info.dyn, info.rew, info.inv, info.goal_dyn, info.goal_act}) {
      EXPECT_TRUE(std::isfinite(v));
      EXPECT_GT(v, 0.0);
    }
    EXPECT_NEAR(info.repr, 1.0 * info.dyn + 0.3 * info.rew + 0.1 * info.inv + 0.1 * info.goal_dyn +
                               0.1 * info.goal_act, 1e-4 * std::abs(info.repr) + 1e-6);
    // Fully masked chunks contribute nothing.
    c.state_mask.zero_();
    c.action_mask.zero_();
    EXPECT_NEAR(t.RepresentationLoss(c).item<double>(), 0.0, 1e-9);
  }
  // The D ablation trains the dynamics term only.
  Trainer d(TinyOptions("D"), RandomStateDataset());
  LossInfo info;
  d.RepresentationLoss(d.SampleChunks(), &info);
  EXPECT_NEAR(info.repr, info.dyn, 1e-5 * std::abs(info.repr) + 1e-6);
}

TEST(TrainerTest, RepresentationUpdatesPerStep) {
  MsprOptions o = TinyOptions();
  o.representation.updates_per_step = 0.5;
  Trainer t(o, RandomStateDataset());
  EXPECT_TRUE(std::isnan(t.Step().repr));
  EXPECT_FALSE(std::isnan(t.Step().repr));
  EXPECT_TRUE(std::isnan(t.Step().repr));
  EXPECT_EQ(t.step(), 3);
  o.representation.updates_per_step = 2.0;
  Trainer t2(o, RandomStateDataset());
  const torch::Tensor before = Flat(*t2.repr());
  EXPECT_FALSE(std::isnan(t2.Step().repr));
}

TEST(TrainerTest, SameSeedSameTraining) {
  Trainer a(TinyOptions(), RandomStateDataset());
  Trainer b(TinyOptions(), RandomStateDataset());
  for (int i = 0; i < 3; ++i) {
    a.Step();
    b.Step();
  }
  EXPECT_TRUE(torch::equal(Flat(*a.actor()), Flat(*b.actor())));
  EXPECT_TRUE(torch::equal(Flat(*a.repr()), Flat(*b.repr())));
}

TEST(TrainerTest, PixelTrainingStepWithFrameStackAndAugmentation) {
  MsprOptions o = TinyOptions();
  o.network.obs_mode = "pixels";
  o.network.frame_stack = 3;
  o.representation.augment_prob = 0.5;
  o.trainer.batch_size = 4;
  Trainer t(o, testing_util::RandomImageDataset());
  const ChunkBatch c = t.SampleChunks();
  // L = max(H, H - 1 + k) + 1 = 10 states per chunk.
  EXPECT_EQ(c.states.sizes(), (std::vector<int64_t>{4, 10, 64, 64, 9}));
  EXPECT_EQ(c.states.scalar_type(), torch::kUInt8);
  const LossInfo info = t.Step();
  EXPECT_TRUE(std::isfinite(info.repr));
  EXPECT_TRUE(std::isfinite(info.critic));
  EXPECT_TRUE(std::isfinite(info.actor));
}

TEST(TrainerTest, TrainLoopWritesCsvAndCallsEvaluator) {
  MsprOptions o = TinyOptions();
  o.trainer.steps = 6;
  o.trainer.eval_every = 3;
  o.trainer.log_every = 2;
  Trainer t(o, RandomStateDataset());
  char tmpl[] = "/tmp/msspr_trainer_test_XXXXXX";
  const std::string dir = mkdtemp(tmpl);
  std::vector<int64_t> eval_steps;
  TrainLoopOptions loop;
  loop.out_dir = dir;
  loop.quiet = true;
  t.Train(loop, [&](Policy& policy, int64_t step) -> EvalResult {
    eval_steps.push_back(step);
    const torch::Tensor a = policy.Act(torch::zeros({3}), torch::ones({3}));
    EXPECT_EQ(a.sizes(), (std::vector<int64_t>{2}));
    return {{"task1", 0.5}, {"task2", 1.0}};
  });
  EXPECT_EQ(t.step(), 6);
  EXPECT_EQ(eval_steps, (std::vector<int64_t>{3, 6}));
  std::ifstream metrics(dir + "/metrics.csv"), eval(dir + "/eval.csv");
  std::string line;
  int lines = 0;
  while (std::getline(metrics, line)) ++lines;
  EXPECT_EQ(lines, 1 + 3);
  lines = 0;
  while (std::getline(eval, line)) ++lines;
  EXPECT_EQ(lines, 1 + 4);
  EXPECT_TRUE(std::ifstream(dir + "/checkpoint.ckpt").good());
  EXPECT_TRUE(std::ifstream(dir + "/policy.pt").good());
  EXPECT_EQ(std::system(("rm -rf '" + dir + "'").c_str()), 0);
}

}  // namespace
}  // namespace core
}  // namespace msspr
