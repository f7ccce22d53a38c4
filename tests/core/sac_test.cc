#include "msspr_core/sac.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <random>

#include "msspr_core/checkpoint.h"
#include "test_util.h"

namespace msspr {
namespace core {
namespace {

using testing_util::TempDir;

// A direction to follow: the observation is a unit vector drawn at reset,
// the reward the action's projection on it, 5 steps per episode (then
// truncated). The best deterministic return is about 5 x 1.2; a random or
// untrained policy gets about 0.
class DirectionEnv : public OnlineEnv {
 public:
  int obs_dim() const override { return 2; }
  int action_dim() const override { return 2; }
  std::vector<float> Reset(uint64_t seed) override {
    std::mt19937_64 rng(seed);
    const double angle = std::uniform_real_distribution<double>(0, 2 * M_PI)(rng);
    dir_ = {static_cast<float>(std::cos(angle)), static_cast<float>(std::sin(angle))};
    t_ = 0;
    return dir_;
  }
  StepResult Step(const std::vector<float>& a) override {
    StepResult r;
    r.reward = a[0] * dir_[0] + a[1] * dir_[1];
    r.obs = dir_;
    r.truncated = ++t_ >= 5;
    return r;
  }

 private:
  std::vector<float> dir_;
  int t_ = 0;
};

std::function<std::unique_ptr<OnlineEnv>()> MakeDirectionEnv() {
  return [] { return std::make_unique<DirectionEnv>(); };
}

SacOptions Tiny() {
  SacOptions o;
  o.hidden = 32;
  o.lr = 1e-3;
  o.batch_size = 64;
  o.steps = 1500;
  o.random_steps = 200;
  o.log_every = 500;
  o.checkpoint_every = 0;
  return o;
}

TEST(SacTest, LearnsToFollowADirection) {
  torch::set_num_threads(1);
  TempDir dir;
  SacTrainer trainer(Tiny(), MakeDirectionEnv(), dir.path());
  const double before = trainer.Evaluate(20, 7);
  EXPECT_EQ(trainer.Train(), 1500);
  const double after = trainer.Evaluate(20, 7);
  EXPECT_LT(std::abs(before), 2.0);
  EXPECT_GT(after, 3.5) << "the deterministic actor should point along the direction (max ~6)";
  EXPECT_LT(trainer.agent().alpha(), 1.0);  // the temperature is learned (it starts at 1)
  // The exported actor acts as the trained one.
  SacPolicy policy(trainer.policy_path());
  const std::vector<float> obs{0.6f, 0.8f};
  EXPECT_EQ(policy.Act(obs), trainer.agent().Act(obs, /*deterministic=*/true));
  EXPECT_EQ(policy.obs_dim(), 2);
  EXPECT_DOUBLE_EQ(policy.options().target_entropy, -1.0);  // -action_dim / 2, resolved
}

TEST(SacTest, TanhGaussianLogProbIsTheChangeOfVariables) {
  torch::manual_seed(3);
  SacOptions o = Tiny();
  SacActor actor(3, 2, o);
  const torch::Tensor obs = torch::randn({64, 3});
  torch::NoGradGuard no_grad;
  auto [a, logp] = actor->Sample(obs);
  auto [mu, log_std] = actor->forward(obs);
  EXPECT_LE(a.abs().max().item<float>(), 1.0f);
  // log pi(a) = log N(atanh(a); mu, std) - sum log(1 - a^2), in float64.
  const torch::Tensor ad = a.to(torch::kFloat64).clamp(-1 + 1e-6, 1 - 1e-6);
  const torch::Tensor u = torch::atanh(ad);
  const torch::Tensor std = log_std.to(torch::kFloat64).exp();
  const torch::Tensor z = (u - mu.to(torch::kFloat64)) / std;
  const torch::Tensor expected =
      (-0.5 * z.pow(2) - std.log() - 0.5 * std::log(2 * M_PI) - (1 - ad.pow(2)).log()).sum(-1);
  const torch::Tensor keep = (a.abs() < 0.99).all(-1);  // atanh is ill-conditioned near +-1
  ASSERT_GT(keep.sum().item<int64_t>(), 32);
  EXPECT_TRUE(torch::allclose(logp.to(torch::kFloat64).masked_select(keep),
                              expected.masked_select(keep), 1e-3, 1e-3));
}

TEST(SacTest, ActorHeadsStartSmallAsOgbenchsFinalLayerScale) {
  // OGBench's actor_fc_scale 0.01: at initialisation the mean and the log-std are
  // near 0 (Xavier-scaled heads would put them near +-1).
  torch::manual_seed(0);
  SacActor actor(29, 8, SacOptions());
  torch::NoGradGuard no_grad;
  auto [mu, log_std] = actor->forward(torch::randn({256, 29}));
  EXPECT_LT(mu.abs().max().item<float>(), 0.35f);
  EXPECT_LT(log_std.abs().max().item<float>(), 0.35f);
  EXPECT_GT(mu.abs().max().item<float>(), 0.0f);
}

TEST(SacTest, ResumeAfterAStopContinuesTheRunExactly) {
  torch::set_num_threads(1);
  SacOptions o = Tiny();
  o.steps = 400;
  o.random_steps = 100;
  o.checkpoint_every = 200;
  TempDir straight, pieces;
  SacTrainer a(o, MakeDirectionEnv(), straight.path());
  a.Train();
  SacOptions first = o;
  first.steps = 200;  // an episode boundary (5 steps each): the resumed episode is the same
  {
    SacTrainer b(first, MakeDirectionEnv(), pieces.path());
    EXPECT_EQ(b.Train(), 200);
  }
  SacTrainer c(o, MakeDirectionEnv(), pieces.path());
  EXPECT_TRUE(c.resumed());
  EXPECT_EQ(c.step(), 200);
  EXPECT_EQ(c.buffer().size(), 200);
  EXPECT_EQ(c.Train(), 400);
  const auto pa = a.agent().actor->parameters(), pc = c.agent().actor->parameters();
  ASSERT_EQ(pa.size(), pc.size());
  for (size_t i = 0; i < pa.size(); ++i)
    EXPECT_TRUE(torch::equal(pa[i], pc[i])) << "actor tensor " << i;
  EXPECT_DOUBLE_EQ(a.agent().alpha(), c.agent().alpha());
}

TEST(SacTest, AStopRequestEndsTheRunWithItsCheckpoint) {
  torch::set_num_threads(1);
  SacOptions o = Tiny();
  o.steps = 300;
  o.random_steps = 50;
  TempDir dir;
  std::atomic<bool> stop{true};  // already requested: the run stops after its first step
  {
    SacTrainer t(o, MakeDirectionEnv(), dir.path());
    EXPECT_EQ(t.Train(&stop), 1);
    EXPECT_TRUE(t.stopped());
  }
  SacTrainer again(o, MakeDirectionEnv(), dir.path());
  EXPECT_TRUE(again.resumed());
  EXPECT_EQ(again.step(), 1);
  EXPECT_EQ(again.Train(), 300);
  EXPECT_FALSE(again.stopped());
}

TEST(SacTest, CorruptCheckpointIsReportedWithItsPath) {
  TempDir dir;
  testing_util::WriteText(dir.File("sac_checkpoint.pt"), "MSSPRCKP not really a checkpoint");
  try {
    SacTrainer t(Tiny(), MakeDirectionEnv(), dir.path());
    FAIL() << "a corrupt checkpoint was accepted";
  } catch (const CheckpointError& e) {
    EXPECT_NE(std::string(e.what()).find(dir.File("sac_checkpoint.pt")), std::string::npos)
        << e.what();
  }
  EXPECT_THROW(SacPolicy(dir.File("missing.pt")), CheckpointError);
}

TEST(SacTest, ReplayBufferWrapsAndRoundTripsThroughAnArchive) {
  ReplayBuffer buf(5, 2, 1);
  for (int i = 0; i < 7; ++i)
    buf.Add({float(i), float(-i)}, {0.5f * i}, i, {float(i + 1), 0}, i == 6);
  EXPECT_EQ(buf.size(), 5);
  std::mt19937_64 rng(1);
  const SacBatch b = buf.Sample(200, rng);
  // Entries 0 and 1 were overwritten by 5 and 6.
  EXPECT_GE(b.obs.select(1, 0).min().item<float>(), 2.0f);
  EXPECT_TRUE(torch::equal(b.reward, b.obs.select(1, 0)));
  EXPECT_TRUE(torch::equal(b.done, (b.reward == 6).to(torch::kFloat32)));
  torch::serialize::OutputArchive out;
  buf.Save(out);
  std::ostringstream bytes;
  out.save_to(bytes);
  torch::serialize::InputArchive in;
  std::istringstream read(bytes.str());
  in.load_from(read);
  ReplayBuffer copy(5, 2, 1);
  copy.Load(in);
  std::mt19937_64 r1(9), r2(9);
  const SacBatch x = buf.Sample(50, r1), y = copy.Sample(50, r2);
  EXPECT_TRUE(torch::equal(x.obs, y.obs));
  EXPECT_TRUE(torch::equal(x.next_obs, y.next_obs));
  EXPECT_TRUE(torch::equal(x.action, y.action));
  // Into a larger buffer: the five newest, oldest first, and the next write after them.
  std::istringstream again(bytes.str());
  torch::serialize::InputArchive in2;
  in2.load_from(again);
  ReplayBuffer larger(8, 2, 1);
  larger.Load(in2);
  EXPECT_EQ(larger.size(), 5);
  larger.Add({7, -7}, {3.5f}, 7, {8, 0}, false);
  std::mt19937_64 r3(2);
  const SacBatch z = larger.Sample(400, r3);
  EXPECT_EQ(std::get<0>(torch::_unique(z.reward)).sizes()[0], 6);  // 2..7, none lost
  EXPECT_EQ(z.reward.min().item<float>(), 2.0f);
}

TEST(SacTest, OptionsYamlRejectsUnknownKeysAndRoundTrips) {
  SacOptions o =
      ApplySacYaml("sac:\n  hidden: 64\n  lr: 0.0003\n  steps: 1000\n", SacOptions(), "x.yaml");
  EXPECT_EQ(o.hidden, 64);
  EXPECT_DOUBLE_EQ(o.lr, 3e-4);
  EXPECT_EQ(o.steps, 1000);
  o.target_entropy = -4;
  const SacOptions back = ApplySacYaml(SacOptionsToYaml(o), SacOptions());
  EXPECT_EQ(back.hidden, 64);
  EXPECT_DOUBLE_EQ(back.target_entropy, -4);
  try {
    ApplySacYaml("sac:\n  hiden: 64\n", SacOptions(), "x.yaml");
    FAIL() << "an unknown key was accepted";
  } catch (const OptionsError& e) {
    EXPECT_NE(std::string(e.what()).find("x.yaml"), std::string::npos);
    EXPECT_NE(std::string(e.what()).find("hiden"), std::string::npos);
  }
  SacOptions bad;
  bad.tau = 0;
  EXPECT_THROW(ValidateSacOptions(bad), OptionsError);
}

}  // namespace
}  // namespace core
}  // namespace msspr
