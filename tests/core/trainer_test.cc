#include "msspr_core/trainer.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <memory>
#include <set>
#include <sstream>
#include <utility>

#include "msspr_core/foreach_adamw.h"
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

void ClearGradsForTest(torch::nn::Module& m) {
  for (auto& p : m.parameters()) p.mutable_grad() = torch::Tensor();
}

double HuberValue(double d) { return std::abs(d) <= 1.0 ? 0.5 * d * d : std::abs(d) - 0.5; }

// On `device` (MSSPR_TEST_DEVICE=cuda runs these on a GPU).
TransitionBatch ToDevice(TransitionBatch b, const torch::Device& device) {
  for (torch::Tensor* t :
       {&b.obs, &b.next_obs, &b.value_goal, &b.actor_goal, &b.action, &b.ret, &b.discount}) {
    *t = t->to(device);
  }
  return b;
}

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
  const TransitionBatch b = ToDevice(FixedBatch(3), t.device());
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
  EXPECT_NEAR(t.CriticLoss(ToDevice(b, t.device()), torch::zeros({4, 2})).item<double>(), 3.0,
              1e-5);
}

// agent.critic_target "expectile": y = R + discount * V(s', g) (V, not the target
// critic at the target actor's action), and V's loss is the expectile loss
// against the target critic at the dataset's action.
TEST(TrainerTest, ExpectileTargetBootstrapsFromValueAndFitsAnUpperExpectile) {
  MsprOptions o = TinyOptions();
  o.agent.critic_target = "expectile";
  o.agent.expectile = 0.9;
  Trainer t(o, RandomStateDataset());
  ASSERT_TRUE(t.value());
  SetConstant(t.critic()->q1, -2.0f);
  SetConstant(t.critic()->q2, -3.0f);
  SetConstant(t.target_critic()->q1, -4.0f);
  SetConstant(t.target_critic()->q2, -5.0f);
  SetConstant(t.value()->v, -1.5f);
  const TransitionBatch b = ToDevice(FixedBatch(3), t.device());
  // y = R + discount * V = {0, -2.35, -3.8035, -2.5}
  const double y[4] = {0.0, -1.0 + 0.9 * -1.5, -2.71 + 0.729 * -1.5, -2.5};
  double expected = 0.0;
  for (double q : {-2.0, -3.0})
    for (double yi : y) expected += HuberValue(q - yi) / 4.0;
  EXPECT_NEAR(t.CriticLoss(b, torch::randn({4, 2})).item<double>(), expected, 1e-5);

  // V's loss: d = min(-4, -5) - (-1.5) = -3.5 < 0, weight 1 - 0.9.
  const mspr::ExpectileTarget e =
      mspr::ExpectileCriticTarget(o.agent, t.mspr().target(), *t.value(), b);
  EXPECT_NEAR(e.value_loss.item<double>(), 0.1 * 3.5 * 3.5, 1e-5);
  SetConstant(t.value()->v, -6.0f);  // d = 1 > 0, weight 0.9
  EXPECT_NEAR(mspr::ExpectileCriticTarget(o.agent, t.mspr().target(), *t.value(), b)
                  .value_loss.item<double>(),
              0.9, 1e-5);
  // The gradient reaches V only.
  ClearGradsForTest(*t.value());
  ClearGradsForTest(*t.target_critic());
  mspr::ExpectileCriticTarget(o.agent, t.mspr().target(), *t.value(), b).value_loss.backward();
  EXPECT_TRUE(LastLinear(t.value()->v)->bias.grad().defined());
  for (const auto& p : t.target_critic()->parameters()) EXPECT_FALSE(p.grad().defined());
}

// Fit to fixed targets, the value network's output settles at their upper
// expectile: with tau = 0.9 over {0, -1} the solution of
// 0.9 (0 - v) = 0.1 (v + 1) is v = -0.1.
TEST(TrainerTest, ExpectileValueConvergesToTheUpperExpectileOfTheTargets) {
  MsprOptions o = TinyOptions();
  o.agent.critic_target = "expectile";
  o.agent.expectile = 0.9;
  Trainer t(o, RandomStateDataset());
  SetConstant(t.target_critic()->q1, 0.0f);
  SetConstant(t.target_critic()->q2, 0.0f);
  TransitionBatch b = ToDevice(FixedBatch(3), t.device());
  // min(Q') alternates between 0 and -1 from one step to the next; V is its
  // output bias alone.
  auto v_bias = LastLinear(t.value()->v);
  {
    torch::NoGradGuard no_grad;
    LastLinear(t.value()->v)->weight.zero_();
  }
  torch::optim::SGD sgd({v_bias->bias}, torch::optim::SGDOptions(0.5));
  for (int i = 0; i < 400; ++i) {
    SetConstant(t.target_critic()->q2, i % 2 == 0 ? 0.0f : -1.0f);
    sgd.zero_grad();
    mspr::ExpectileCriticTarget(o.agent, t.mspr().target(), *t.value(), b).value_loss.backward();
    sgd.step();
  }
  EXPECT_NEAR(v_bias->bias.item<double>(), -0.1, 0.02);
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
  const TransitionBatch b = ToDevice(FixedBatch(3), t.device());
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
    EXPECT_NEAR(info.repr,
                1.0 * info.dyn + 0.3 * info.rew + 0.1 * info.inv + 0.1 * info.goal_dyn +
                    0.1 * info.goal_act,
                1e-4 * std::abs(info.repr) + 1e-6);
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

// Images whose pixel (y, x) holds (4y, 4x, id): the centre pixel of a
// shifted image gives back the shift, and channel 2 which image it is.
std::shared_ptr<const Dataset> PatternImageDataset(int episodes, int length) {
  const ImageShape shape{64, 64, 3};
  DatasetBuilder b(2, 2, shape);
  int id = 0;
  for (int e = 0; e < episodes; ++e) {
    std::vector<float> obs(length * 2, 0.f), act(length * 2, 0.f);
    std::vector<uint8_t> img(length * shape.numel());
    for (int t = 0; t < length; ++t, ++id) {
      uint8_t* im = img.data() + int64_t{t} * shape.numel();
      for (int y = 0; y < 64; ++y) {
        for (int x = 0; x < 64; ++x) {
          im[(y * 64 + x) * 3 + 0] = static_cast<uint8_t>(4 * y);
          im[(y * 64 + x) * 3 + 1] = static_cast<uint8_t>(4 * x);
          im[(y * 64 + x) * 3 + 2] = static_cast<uint8_t>(id % 251);
        }
      }
    }
    b.AddEpisode(obs, act, img);
  }
  return std::make_shared<const Dataset>(b.Build());
}

// (dy, dx) of a pattern image, from its centre pixel.
std::pair<int, int> ShiftOf(const torch::Tensor& image) {
  const torch::Tensor c = image.index({32, 32}).to(torch::kInt32);
  return {c[0].item<int>() / 4 - 32, c[1].item<int>() / 4 - 32};
}

MsprOptions PixelOptions(double augment_prob) {
  MsprOptions o = TinyOptions();
  o.network.obs_mode = "pixels";
  o.network.cnn = "light";
  o.network.image_downsample = 2;
  o.representation.augment_prob = augment_prob;
  o.representation.augment_pad = 3;
  o.trainer.batch_size = 24;
  return o;
}

TEST(TrainerTest, AugmentationSharesOneShiftPerSampleAcrossItsImages) {
  Trainer t(PixelOptions(1.0), PatternImageDataset(4, 30));
  std::set<std::pair<int, int>> seen;
  for (int rep = 0; rep < 3; ++rep) {
    const TransitionBatch tb = t.SampleTransitions();
    for (int64_t k = 0; k < tb.obs.size(0); ++k) {
      const auto s = ShiftOf(tb.obs[k]);
      EXPECT_LE(std::abs(s.first), 3);
      EXPECT_LE(std::abs(s.second), 3);
      EXPECT_EQ(ShiftOf(tb.next_obs[k]), s) << "sample " << k;
      EXPECT_EQ(ShiftOf(tb.value_goal[k]), s) << "sample " << k;
      EXPECT_EQ(ShiftOf(tb.actor_goal[k]), s) << "sample " << k;
      seen.insert(s);
    }
    const ChunkBatch cb = t.SampleChunks();
    for (int64_t k = 0; k < cb.states.size(0); ++k) {
      const auto s = ShiftOf(cb.goal[k]);
      for (int64_t j = 0; j < cb.states.size(1); ++j) {
        EXPECT_EQ(ShiftOf(cb.states[k][j]), s) << "sample " << k << " state " << j;
      }
      seen.insert(s);
    }
  }
  // Shifts differ between samples (49 possible, 144 samples drawn).
  EXPECT_GE(seen.size(), 20u);
  // The images themselves are the dataset's (channel 2 names the image).
  const TransitionBatch tb = t.SampleTransitions();
  EXPECT_EQ(tb.obs.index({0, 32, 32, 2}).item<int>(), tb.obs.index({0, 10, 50, 2}).item<int>());
}

TEST(TrainerTest, AugmentationIsDrawnOncePerBatch) {
  Trainer t(PixelOptions(0.5), PatternImageDataset(4, 30));
  int augmented = 0;
  const int batches = 40;
  for (int rep = 0; rep < batches; ++rep) {
    const TransitionBatch tb = t.SampleTransitions();
    int shifted = 0;
    for (int64_t k = 0; k < tb.obs.size(0); ++k)
      shifted += ShiftOf(tb.obs[k]) != std::make_pair(0, 0);
    // All or nothing: a batch drawn for augmentation has most samples shifted
    // (a sample's shift is (0, 0) with probability 1/49).
    EXPECT_TRUE(shifted == 0 || shifted >= tb.obs.size(0) / 2) << shifted;
    augmented += shifted > 0;
  }
  EXPECT_GT(augmented, batches / 5);
  EXPECT_LT(augmented, batches - batches / 5);
  // augment_prob 0, and validation batches: never shifted.
  Trainer none(PixelOptions(0.0), PatternImageDataset(4, 30));
  for (int rep = 0; rep < 5; ++rep) {
    const TransitionBatch tb = none.SampleTransitions();
    for (int64_t k = 0; k < tb.obs.size(0); ++k)
      EXPECT_EQ(ShiftOf(tb.obs[k]), std::make_pair(0, 0));
  }
}

// Eq. 1 written step by step, as the trainer computed it before the terms
// were batched over the horizon: the batched loss must equal it.
double StepByStepRepresentationLoss(Trainer& t, const ChunkBatch& batch) {
  torch::NoGradGuard no_grad;
  const MsprOptions& o = t.options();
  const RepresentationOptions& r = o.representation;
  const int64_t k = o.network.goal_horizon, b = batch.states.size(0), l = batch.states.size(1);
  const int64_t horizon = batch.mc_return.size(1);
  auto& repr = t.repr();
  auto& pred = repr->predictors;
  auto masked_mean = [](const torch::Tensor& v, const torch::Tensor& m) {
    return (v * m).sum() / m.sum().clamp_min(1.0);
  };
  const torch::Tensor targets =
      t.target_repr()->state_encoder->forward(batch.states.flatten(0, 1)).view({b, l, -1});
  const torch::Tensor zg = repr->state_encoder->forward(batch.goal);
  torch::Tensor z = repr->state_encoder->forward(batch.states.select(1, 0));
  const torch::Tensor bins = ReturnBins(o.network.num_bins, o.agent.gamma);
  double total = 0;
  for (int64_t h = 0; h < horizon; ++h) {
    const torch::Tensor a_h = batch.actions.select(1, h), m_h = batch.action_mask.select(1, h);
    const torch::Tensor grep = repr->goal_head->forward(z, zg);
    const torch::Tensor zsa = repr->Zsa(z, a_h);
    const torch::Tensor z_next = pred->Dynamics(zsa);
    const torch::Tensor tn = targets.select(1, h + 1);
    const double dyn = masked_mean((z_next - tn).pow(2).mean(-1), m_h).item<double>();
    const double inv =
        masked_mean((pred->Inverse(z, tn) - a_h).pow(2).mean(-1), m_h).item<double>();
    const torch::Tensor two_hot = TwoHotEncode(batch.mc_return.select(1, h), bins);
    const double rew =
        masked_mean(-(two_hot * torch::log_softmax(pred->Reward(zsa, grep), -1)).sum(-1), m_h)
            .item<double>();
    const double gdyn =
        masked_mean((pred->GoalDynamics(z, grep) - targets.select(1, h + k)).pow(2).mean(-1),
                    batch.state_mask.select(1, h + k))
            .item<double>();
    const torch::Tensor ga_mask = batch.action_mask.narrow(1, h, k);
    const double gact =
        ((pred->GoalActions(z, grep) - batch.actions.narrow(1, h, k)).pow(2).mean(-1) * ga_mask)
            .sum()
            .item<double>() /
        std::max(1.0, ga_mask.sum().item<double>());
    total += r.weight_dyn * dyn + r.weight_rew * rew + r.weight_inv * inv +
             r.weight_goal_dyn * gdyn + r.weight_goal_act * gact;
    z = z_next;
  }
  return total;
}

TEST(TrainerTest, BatchedRepresentationLossEqualsStepByStepEq1) {
  for (const std::string preset : {"mspr", "D", "DI", "DIR"}) {
    Trainer t(TinyOptions(preset), RandomStateDataset(5, 9));
    for (int i = 0; i < 3; ++i) t.Step();  // online and target encoders differ from here on
    const ChunkBatch c = t.SampleChunks();
    torch::NoGradGuard no_grad;
    const double batched = t.RepresentationLoss(c).item<double>();
    const double reference = StepByStepRepresentationLoss(t, c);
    EXPECT_NEAR(batched, reference, 1e-5 * std::abs(reference) + 1e-6) << preset;
  }
}

// representation.reward_goals "trajectory": f_rew is trained only on goals
// ahead in the chunk's own trajectory. The reward term then ignores the
// returns given to every other goal, and equals the term of "all" on a
// batch where every goal is ahead.
TEST(TrainerTest, RewardGoalsTrajectoryMasksGoalsOutsideTheTrajectory) {
  MsprOptions o = TinyOptions();
  o.representation.reward_goals = "trajectory";
  Trainer t(o, RandomStateDataset(5, 9));
  MsprOptions all_o = TinyOptions();
  Trainer all(all_o, RandomStateDataset(5, 9));
  ChunkBatch c = t.SampleChunks();
  const float ahead = c.goal_ahead.sum().item<float>();
  ASSERT_GT(ahead, 0.0f);
  ASSERT_LT(ahead, static_cast<float>(c.goal_ahead.numel()))
      << "the batch needs goals of both kinds";
  torch::NoGradGuard no_grad;
  LossInfo before, after, all_info;
  t.RepresentationLoss(c, &before);
  // Change the returns of the goals that are not ahead: no effect.
  ChunkBatch changed = c;
  changed.mc_return = torch::where(c.goal_ahead > 0, c.mc_return, torch::zeros_like(c.mc_return));
  t.RepresentationLoss(changed, &after);
  EXPECT_DOUBLE_EQ(before.rew, after.rew);
  // "all" (the same initial weights: same seed) sees the change.
  LossInfo all_before, all_after;
  all.RepresentationLoss(c, &all_before);
  all.RepresentationLoss(changed, &all_after);
  EXPECT_GT(std::abs(all_before.rew - all_after.rew), 1e-3);
  // With every goal ahead, the two settings give the same term.
  ChunkBatch every = c;
  every.goal_ahead = torch::ones_like(c.goal_ahead);
  t.RepresentationLoss(every, &after);
  all.RepresentationLoss(every, &all_info);
  EXPECT_NEAR(after.rew, all_info.rew, 1e-6 * std::abs(all_info.rew));
  EXPECT_THROW(
      {
        MsprOptions bad = TinyOptions();
        bad.representation.reward_goals = "some";
        ValidateOptions(bad);
      },
      OptionsError);
}

TEST(TrainerTest, ZeroWeightTermsAreNotComputed) {
  Trainer d(TinyOptions("D"), RandomStateDataset());
  LossInfo info;
  d.RepresentationLoss(d.SampleChunks(), &info);
  EXPECT_GT(info.dyn, 0.0);
  EXPECT_EQ(info.rew, 0.0);
  EXPECT_EQ(info.inv, 0.0);
  EXPECT_EQ(info.goal_dyn, 0.0);
  EXPECT_EQ(info.goal_act, 0.0);
  // In D nothing reaches the goal head or the goal-level predictors.
  ClearGradsForTest(*d.repr());
  d.RepresentationLoss(d.SampleChunks()).backward();
  for (const auto& p : d.repr()->goal_head->parameters()) EXPECT_FALSE(p.grad().defined());
  EXPECT_FALSE(d.repr()->predictors->goal_dynamics->weight.grad().defined());
  EXPECT_TRUE(d.repr()->predictors->dynamics->weight.grad().defined());
}

TEST(TrainerTest, Bf16LossesAreCloseToFp32) {
  MsprOptions o = TinyOptions();
  Trainer f32(o, RandomStateDataset());
  o.trainer.precision = "bf16";
  Trainer b16(o, RandomStateDataset());
  // Same seed: same initial weights and the same batches.
  EXPECT_TRUE(torch::equal(Flat(*f32.repr()), Flat(*b16.repr())));
  const LossInfo a = f32.Step(), b = b16.Step();
  for (const auto& [x, y] : {std::make_pair(a.repr, b.repr), std::make_pair(a.critic, b.critic),
                             std::make_pair(a.actor, b.actor), std::make_pair(a.dyn, b.dyn)}) {
    EXPECT_TRUE(std::isfinite(y));
    EXPECT_NEAR(x, y, 0.05 * std::abs(x) + 1e-3);
  }
  // Master weights stay fp32.
  for (const auto& p : b16.repr()->parameters()) EXPECT_EQ(p.scalar_type(), torch::kFloat32);
  EXPECT_FALSE(torch::equal(Flat(*f32.repr()), Flat(*b16.repr())));
}

TEST(TrainerTest, LightCnnPixelStepWithDownsampling) {
  MsprOptions o = PixelOptions(0.5);
  o.trainer.precision = "bf16";
  Trainer t(o, testing_util::RandomImageDataset());
  for (int i = 0; i < 2; ++i) {
    const LossInfo info = t.Step();
    EXPECT_TRUE(std::isfinite(info.repr));
    EXPECT_TRUE(std::isfinite(info.critic));
    EXPECT_TRUE(std::isfinite(info.actor));
  }
}

// Restores torch's thread count at the end of a test.
struct ThreadCountGuard {
  int saved = torch::get_num_threads();
  ~ThreadCountGuard() { torch::set_num_threads(saved); }
};

// All weights of a trainer, online and target, in one vector.
torch::Tensor AllWeights(Trainer& t) {
  return torch::cat({Flat(*t.repr()), Flat(*t.critic()), Flat(*t.actor()), Flat(*t.target_repr()),
                     Flat(*t.target_critic()), Flat(*t.target_actor())});
}

// The pipelined schedule (actor-critic update of step i on a worker thread,
// beside the representation update of step i + 1; with the critic's gradient
// into the encoders, the actor update of step i and the TD target of step
// i + 1) gives the sequential schedule's weights bit for bit: each of its two
// threads runs with one torch thread, as the sequential trainer does here.
TEST(TrainerTest, PipelinedStepsEqualSequentialSteps) {
  if (!torch::Device(TinyOptions().trainer.device).is_cpu()) GTEST_SKIP() << "CPU only";
  ThreadCountGuard guard;
  for (bool through : {false, true})
    for (const char* precision : {"fp32", "bf16"}) {
      for (double updates : {1.0, 0.5, 2.0}) {
        for (bool pixels : {false, true}) {
          for (const char* critic_target : {"td3", "expectile"}) {
            if (updates == 2.0 && (pixels || !through)) continue;
            // The in-sample target (a value update inside the critic's) in both schedules.
            if (std::string(critic_target) == "expectile" && (updates != 1.0 || pixels)) continue;
            MsprOptions o = pixels ? PixelOptions(0.5) : TinyOptions();
            o.trainer.precision = precision;
            o.representation.updates_per_step = updates;
            o.agent.critic_grad_to_encoder = through;
            o.agent.critic_target = critic_target;
            o.trainer.policy_ema = through ? 0.9 : 0.0;
            o.agent.target_update_every = 4;  // target copies inside the run
            auto data = pixels ? testing_util::RandomImageDataset() : RandomStateDataset();
            // 10 steps, losses read back on every third; the trainer and those losses.
            auto run = [&](const char* pipeline, int threads, std::vector<LossInfo>* info) {
              o.trainer.pipeline = pipeline;
              torch::set_num_threads(threads);
              auto t = std::make_unique<Trainer>(o, data);
              EXPECT_EQ(t->pipelined(), threads > 1);
              for (int i = 0; i < 10; ++i) info->push_back(t->Step(i % 3 == 2));
              return t;
            };
            std::vector<LossInfo> seq_info, pipe_info;
            const auto seq_trainer = run("off", 1, &seq_info);
            const auto pipe_trainer = run("auto", 2, &pipe_info);
            Trainer& sequential = *seq_trainer;
            Trainer& pipelined = *pipe_trainer;
            const std::string what = std::string(precision) + " updates_per_step " +
                                     std::to_string(updates) + (pixels ? " pixels" : " state") +
                                     (through ? " critic_grad_to_encoder" : "") + " " +
                                     critic_target;
            EXPECT_TRUE(torch::equal(AllWeights(sequential), AllWeights(pipelined))) << what;
            if (std::string(critic_target) == "expectile") {
              EXPECT_TRUE(torch::equal(Flat(*sequential.value()), Flat(*pipelined.value())))
                  << what;
            }
            if (through) {
              // The moving average took in the same weights at the same points.
              EXPECT_TRUE(torch::equal(Flat(*sequential.ema_actor()), Flat(*pipelined.ema_actor())))
                  << what;
            }
            for (int i = 2; i < 10; i += 3) {
              EXPECT_TRUE(std::isfinite(pipe_info[i].critic)) << what;
              EXPECT_EQ(seq_info[i].critic, pipe_info[i].critic) << what << " step " << i;
              EXPECT_EQ(seq_info[i].actor, pipe_info[i].actor) << what << " step " << i;
            }
            // Steps without losses return before their actor-critic update is done;
            // the accessors wait for it (and it ran: the critic moved).
            const torch::Tensor before = Flat(*pipelined.critic()).clone();
            const torch::Tensor actor_before = Flat(*pipelined.actor()).clone();
            pipelined.Step(false);
            EXPECT_FALSE(torch::equal(before, Flat(*pipelined.critic()))) << what;
            // A deferred actor update (critic_grad_to_encoder) is run by the accessor.
            EXPECT_FALSE(torch::equal(actor_before, Flat(*pipelined.actor()))) << what;
            // Threads as the user set them, after the step.
            EXPECT_EQ(torch::get_num_threads(), 2);
          }
        }
      }
    }
}

// With the subgoal policy (agent.subgoal_steps: V's update in the critic's,
// the subgoal actor's after the actor's) the pipelined schedule still gives
// the sequential schedule's weights bit for bit, with and without the
// critic's gradient into the encoders.
TEST(TrainerTest, PipelinedStepsEqualSequentialStepsWithTheSubgoalPolicy) {
  if (!torch::Device(TinyOptions().trainer.device).is_cpu()) GTEST_SKIP() << "CPU only";
  ThreadCountGuard guard;
  for (bool through : {false, true}) {
    MsprOptions o = TinyOptions();
    o.agent.subgoal_steps = 3;
    o.agent.critic_grad_to_encoder = through;
    o.agent.target_update_every = 4;
    o.trainer.policy_ema = 0.9;
    auto data = RandomStateDataset();
    auto run = [&](const char* pipeline, int threads) {
      o.trainer.pipeline = pipeline;
      torch::set_num_threads(threads);
      auto t = std::make_unique<Trainer>(o, data);
      for (int i = 0; i < 10; ++i) t->Step(i % 3 == 2);
      return t;
    };
    const auto sequential = run("off", 1);
    const auto pipelined = run("auto", 2);
    const std::string what = through ? "critic_grad_to_encoder" : "encoders detached";
    EXPECT_TRUE(pipelined->pipelined()) << what;
    EXPECT_TRUE(torch::equal(AllWeights(*sequential), AllWeights(*pipelined))) << what;
    EXPECT_TRUE(torch::equal(Flat(*sequential->value()), Flat(*pipelined->value()))) << what;
    EXPECT_TRUE(torch::equal(Flat(*sequential->subgoal_actor()), Flat(*pipelined->subgoal_actor())))
        << what;
    EXPECT_TRUE(
        torch::equal(Flat(*sequential->ema_subgoal_actor()), Flat(*pipelined->ema_subgoal_actor())))
        << what;
    // The subgoal actor and V trained (they left their initial weights).
    MsprOptions fresh = o;
    Trainer untrained(fresh, data);
    EXPECT_FALSE(torch::equal(Flat(*untrained.subgoal_actor()), Flat(*sequential->subgoal_actor())))
        << what;
    EXPECT_FALSE(torch::equal(Flat(*untrained.value()), Flat(*sequential->value()))) << what;
  }
}

// trainer.pipeline: "auto" pipelines on a CPU with 2 or more threads (with
// or without the critic's gradient into the encoders, both bit-equal to
// the sequential schedule: PipelinedStepsEqualSequentialSteps), "on" at any
// thread count, "off" never; baseline agents are never pipelined.
TEST(TrainerTest, PipelineFollowsTheOptionAndTheThreadCount) {
  if (!torch::Device(TinyOptions().trainer.device).is_cpu()) GTEST_SKIP() << "CPU only";
  ThreadCountGuard guard;
  torch::set_num_threads(2);
  MsprOptions o = TinyOptions();
  o.trainer.pipeline = "off";
  EXPECT_FALSE(Trainer(o, RandomStateDataset()).pipelined());
  o.trainer.pipeline = "auto";
  EXPECT_TRUE(Trainer(o, RandomStateDataset()).pipelined());
  o.agent.critic_grad_to_encoder = true;
  EXPECT_TRUE(Trainer(o, RandomStateDataset()).pipelined());
  torch::set_num_threads(1);
  o.agent.critic_grad_to_encoder = false;
  EXPECT_FALSE(Trainer(o, RandomStateDataset()).pipelined());
  o.trainer.pipeline = "on";
  EXPECT_TRUE(Trainer(o, RandomStateDataset()).pipelined());
  MsprOptions gcbc = o;
  gcbc.baseline.agent = "gcbc";
  EXPECT_FALSE(Trainer(gcbc, RandomStateDataset()).pipelined());
  o.trainer.pipeline = "sometimes";
  EXPECT_THROW(ValidateOptions(o), OptionsError);
}

TEST(TrainerTest, ForeachAdamWEqualsAdamW) {
  torch::manual_seed(5);
  std::vector<torch::Tensor> a, b;
  for (auto shape : {std::vector<int64_t>{7, 3}, {3}, {2, 2, 2}, {5}}) {
    a.push_back(torch::randn(shape).requires_grad_());
    b.push_back(a.back().detach().clone().requires_grad_());
  }
  const auto opts = torch::optim::AdamWOptions(3e-3).weight_decay(1e-2);
  torch::optim::AdamW reference(a, opts);
  ForeachAdamW multi(b, opts);
  for (int step = 0; step < 6; ++step) {
    for (size_t i = 0; i < a.size(); ++i) {
      // Parameter 3 misses a gradient on some steps (its step count lags).
      const bool skip = i == 3 && step % 2 == 1;
      const torch::Tensor g = torch::randn(a[i].sizes());
      a[i].mutable_grad() = skip ? torch::Tensor() : g;
      b[i].mutable_grad() = skip ? torch::Tensor() : g.clone();
    }
    reference.step();
    multi.step();
    for (size_t i = 0; i < a.size(); ++i) {
      EXPECT_TRUE(torch::allclose(a[i], b[i], 1e-6, 1e-7)) << "param " << i << " step " << step;
    }
  }
  // The state is AdamW's: a checkpoint of one loads into the other.
  std::stringstream buffer;
  torch::save(multi, buffer);
  torch::optim::AdamW restored(a, opts);
  torch::load(restored, buffer);
  EXPECT_EQ(restored.state().size(), multi.state().size());
  // The flat moments (views into one buffer on the CPU) are written once: the
  // checkpoint is no larger than AdamW's own.
  std::stringstream reference_buffer;
  torch::save(reference, reference_buffer);
  EXPECT_LE(buffer.str().size(), reference_buffer.str().size() + 1024);
  // After a load replaced its state, the flat update goes on from the loaded moments.
  buffer.seekg(0);
  torch::load(multi, buffer);
  for (int step = 0; step < 3; ++step) {
    for (size_t i = 0; i < a.size(); ++i) {
      const torch::Tensor g = torch::randn(a[i].sizes());
      a[i].mutable_grad() = g;
      b[i].mutable_grad() = g.clone();
    }
    reference.step();
    multi.step();
    for (size_t i = 0; i < a.size(); ++i) {
      EXPECT_TRUE(torch::allclose(a[i], b[i], 1e-6, 1e-7)) << "after load, param " << i;
    }
  }
}

TEST(TrainerTest, PolicyAverageIsTheRunningMeanThenAnEma) {
  MsprOptions o = TinyOptions();
  o.trainer.policy_ema = 0.8;  // t / (t + 1) < 0.8 up to step 3: a plain mean, then the EMA
  Trainer t(o, RandomStateDataset());
  ASSERT_TRUE(t.ema_actor());
  const torch::Tensor a0 = Flat(*t.actor()).clone();
  EXPECT_TRUE(torch::equal(Flat(*t.ema_actor()), a0));  // starts at the initial weights
  // The average at step s takes in the actor of step s - 1 (the one before the step's update).
  std::vector<torch::Tensor> seen{a0};
  torch::Tensor expected = a0.to(torch::kFloat64);
  for (int s = 1; s <= 7; ++s) {
    const torch::Tensor raw = Flat(*t.actor()).clone();
    seen.push_back(raw);
    t.Step();
    EXPECT_FALSE(torch::equal(Flat(*t.actor()), raw)) << "step " << s << " did not train the actor";
    const double d = std::min(0.8, s / (s + 1.0));
    expected = d * expected + (1 - d) * raw.to(torch::kFloat64);
    EXPECT_TRUE(torch::allclose(Flat(*t.ema_actor()).to(torch::kFloat64), expected, 1e-5, 1e-7))
        << "step " << s;
    if (s == 3) {
      // The plain mean of the initial copy and the actors of steps 0, 1, 2.
      const torch::Tensor mean = torch::stack(seen).mean(0);
      EXPECT_TRUE(torch::allclose(Flat(*t.ema_actor()), mean, 1e-5, 1e-7));
    }
  }
  EXPECT_FALSE(torch::allclose(Flat(*t.ema_actor()), Flat(*t.actor()), 1e-4, 1e-6));
  EXPECT_FALSE(torch::allclose(Flat(*t.ema_critic()), Flat(*t.critic()), 1e-4, 1e-6));
  EXPECT_FALSE(torch::allclose(Flat(*t.ema_repr()), Flat(*t.repr()), 1e-4, 1e-6));
  // No average without the option.
  Trainer plain(TinyOptions(), RandomStateDataset());
  EXPECT_FALSE(plain.ema_actor());
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
