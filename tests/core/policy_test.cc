#include "msspr_core/policy.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <vector>

#include "msspr_core/checkpoint.h"
#include "msspr_core/trainer.h"
#include "test_util.h"
#include "torch_test_util.h"

namespace msspr {
namespace core {
namespace {

using testing_util::RandomImageDataset;
using testing_util::RandomStateDataset;
using testing_util::TempDir;
using testing_util::TinyOptions;

TEST(PolicyTest, StateActSingleAndBatch) {
  Trainer t(TinyOptions(), RandomStateDataset());
  t.Step();
  Policy p = t.MakePolicy();
  EXPECT_FALSE(p.pixels());
  EXPECT_EQ(p.obs_dim(), 3);
  EXPECT_EQ(p.action_dim(), 2);
  torch::manual_seed(5);
  const torch::Tensor obs = torch::randn({7, 3}), goal = torch::randn({7, 3});
  const torch::Tensor a = p.Act(obs, goal);
  EXPECT_EQ(a.sizes(), (std::vector<int64_t>{7, 2}));
  EXPECT_LE(a.abs().max().item<float>(), 1.0f);
  EXPECT_FALSE(a.requires_grad());
  const torch::Tensor a3 = p.Act(obs[3], goal[3]);
  EXPECT_EQ(a3.sizes(), (std::vector<int64_t>{2}));
  EXPECT_TRUE(torch::equal(a3, a[3]));
  const std::vector<float> v = p.Act(
      std::vector<float>{obs[3][0].item<float>(), obs[3][1].item<float>(), obs[3][2].item<float>()},
      std::vector<float>{goal[3][0].item<float>(), goal[3][1].item<float>(),
                         goal[3][2].item<float>()});
  ASSERT_EQ(v.size(), 2u);
  EXPECT_EQ(v[0], a[3][0].item<float>());
  const torch::Tensor q = p.Q(obs, a, goal);
  EXPECT_EQ(q.sizes(), (std::vector<int64_t>{7, 2}));
  EXPECT_EQ(p.Q(obs[0], a[0], goal[0]).sizes(), (std::vector<int64_t>{2}));
  EXPECT_THROW(p.Act(torch::randn({2, 2, 3}), torch::randn({2, 2, 3})), c10::Error);
}

// Policy::Act computes each row on its own in one thread: a batch's actions
// are bitwise those of its rows one at a time, whatever the batch and the
// torch thread count. The networks have the shipped checkpoints' widths: a
// batched forward pass of them rounds most rows' last bits differently from
// a single row's.
TEST(PolicyTest, BatchActIsRowByRowBitwiseAtOneAndTwoThreads) {
  MsprOptions o = TinyOptions();
  NetworkOptions& n = o.network;
  n.encoder_hidden = n.zsa_hidden = n.goal_hidden = n.critic_hidden = n.actor_hidden = 256;
  n.zs_dim = n.zsa_dim = 256;
  n.goal_dim = 64;
  Trainer t(o, RandomStateDataset(4, 12, /*obs_dim=*/29));
  Policy p = t.MakePolicy();
  torch::manual_seed(7);
  const int64_t rows = 300;
  const torch::Tensor obs = 3 * torch::randn({rows, 29}), goal = 3 * torch::randn({rows, 29});
  const int threads_before = torch::get_num_threads();
  torch::set_num_threads(1);
  std::vector<torch::Tensor> single;
  for (int64_t b = 0; b < rows; ++b) single.push_back(p.Act(obs[b], goal[b]));
  const torch::Tensor expected = torch::stack(single);
  for (int threads : {1, 2}) {
    torch::set_num_threads(threads);
    EXPECT_TRUE(torch::equal(p.Act(obs, goal), expected)) << threads << " threads, 300 rows";
    EXPECT_TRUE(torch::equal(p.Act(obs.narrow(0, 100, 77), goal.narrow(0, 100, 77)),
                             expected.narrow(0, 100, 77)))
        << threads << " threads, rows 100 to 176";
    for (int64_t b : {0, 150, 299})
      EXPECT_TRUE(torch::equal(p.Act(obs[b], goal[b]), expected[b]))
          << threads << " threads, row " << b << " alone";
  }
  torch::set_num_threads(threads_before);
}

TEST(PolicyTest, ExportLoadsAndActsTheSame) {
  TempDir dir;
  Trainer t(TinyOptions(), RandomStateDataset());
  for (int i = 0; i < 2; ++i) t.Step();
  t.ExportPolicy(dir.File("policy.pt"));
  t.SaveCheckpoint(dir.File("trainer.ckpt"));
  Policy live = t.MakePolicy();
  Policy loaded = Policy::Load(dir.File("policy.pt"));
  Policy from_ckpt = Policy::Load(dir.File("trainer.ckpt"), torch::kCPU);
  const torch::Tensor obs = torch::randn({5, 3}), goal = torch::randn({5, 3});
  // Bit-exact on the CPU; a trainer on a GPU (MSSPR_TEST_DEVICE=cuda) against
  // the CPU export within float tolerance.
  auto same = [](const torch::Tensor& x, const torch::Tensor& y) {
    return x.device() == y.device() ? torch::equal(x, y)
                                    : torch::allclose(x.cpu(), y.cpu(), 1e-4, 1e-5);
  };
  EXPECT_TRUE(same(live.Act(obs, goal), loaded.Act(obs, goal)));
  EXPECT_TRUE(same(live.Act(obs, goal), from_ckpt.Act(obs, goal)));
  const torch::Tensor a = torch::zeros({5, 2});
  EXPECT_TRUE(same(live.Q(obs, a, goal), loaded.Q(obs, a, goal)));
  EXPECT_EQ(loaded.options().network.obs_mode, "state");
}

TEST(PolicyTest, AveragePoliciesIsTheMeanOfTheWeights) {
  TempDir dir;
  Trainer t(TinyOptions(), RandomStateDataset());
  std::vector<torch::Tensor> repr, actor, critic;
  for (int k = 1; k <= 3; ++k) {
    for (int i = 0; i < 2; ++i) t.Step();
    t.ExportPolicy(dir.File("p" + std::to_string(k) + ".pt"));
    repr.push_back(testing_util::Flat(*t.repr()));
    actor.push_back(testing_util::Flat(*t.actor()));
    critic.push_back(testing_util::Flat(*t.critic()));
  }
  AveragePolicies({dir.File("p1.pt"), dir.File("p2.pt"), dir.File("p3.pt")}, dir.File("avg.pt"));
  Policy avg = Policy::Load(dir.File("avg.pt"));
  EXPECT_TRUE(
      torch::allclose(testing_util::Flat(*avg.repr()), torch::stack(repr).mean(0), 1e-5, 1e-7));
  EXPECT_TRUE(
      torch::allclose(testing_util::Flat(*avg.actor()), torch::stack(actor).mean(0), 1e-5, 1e-7));
  EXPECT_TRUE(
      torch::allclose(testing_util::Flat(*avg.critic()), torch::stack(critic).mean(0), 1e-5, 1e-7));
  EXPECT_FALSE(torch::allclose(testing_util::Flat(*avg.actor()), actor.back(), 1e-4, 1e-6));
  const MsprOptions stored = ReadCheckpointOptions(dir.File("avg.pt"));
  EXPECT_EQ(stored.network.obs_dim, 3);
  // One input: the same weights.
  AveragePolicies({dir.File("p2.pt")}, dir.File("one.pt"));
  EXPECT_TRUE(
      torch::equal(testing_util::Flat(*Policy::Load(dir.File("one.pt")).actor()), actor[1]));

  // Another network shape, a missing file: errors naming the input.
  MsprOptions wider = TinyOptions();
  wider.network.actor_hidden = 40;
  Trainer w(wider, RandomStateDataset());
  w.ExportPolicy(dir.File("wide.pt"));
  for (const std::string& bad : {dir.File("wide.pt"), dir.File("missing.pt")}) {
    try {
      AveragePolicies({dir.File("p1.pt"), bad}, dir.File("bad.pt"));
      FAIL() << "averaged " << bad;
    } catch (const CheckpointError& e) {
      EXPECT_NE(std::string(e.what()).find(bad), std::string::npos) << e.what();
    }
  }
  EXPECT_FALSE(std::filesystem::exists(dir.File("bad.pt")));
  EXPECT_THROW(AveragePolicies({}, dir.File("bad.pt")), std::invalid_argument);
}

TEST(PolicyTest, PixelActSingleAndBatch) {
  TempDir dir;
  MsprOptions o = TinyOptions();
  o.network.obs_mode = "pixels";
  o.network.frame_stack = 3;
  o.trainer.batch_size = 2;
  Trainer t(o, RandomImageDataset());
  t.ExportPolicy(dir.File("pixels.pt"));
  Policy p = Policy::Load(dir.File("pixels.pt"));
  EXPECT_TRUE(p.pixels());
  const torch::Tensor obs = torch::randint(0, 256, {3, 64, 64, 9}, torch::kUInt8);
  const torch::Tensor goal = torch::randint(0, 256, {3, 64, 64, 9}, torch::kUInt8);
  const torch::Tensor a = p.Act(obs, goal);
  EXPECT_EQ(a.sizes(), (std::vector<int64_t>{3, 2}));
  const torch::Tensor a1 = p.Act(obs[1], goal[1]);
  EXPECT_EQ(a1.sizes(), (std::vector<int64_t>{2}));
  EXPECT_TRUE(torch::equal(a1, a[1]));
  EXPECT_EQ(p.Q(obs, a, goal).sizes(), (std::vector<int64_t>{3, 2}));
}

}  // namespace
}  // namespace core
}  // namespace msspr
