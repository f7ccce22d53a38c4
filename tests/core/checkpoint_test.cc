#include "msspr_core/checkpoint.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <memory>
#include <random>
#include <utility>

#include "msspr_core/policy.h"
#include "msspr_core/trainer.h"
#include "test_util.h"
#include "torch_test_util.h"

namespace msspr {
namespace core {
namespace {

using testing_util::Flat;
using testing_util::RandomStateDataset;
using testing_util::ReadText;
using testing_util::TempDir;
using testing_util::TinyOptions;
using testing_util::WriteText;

MsprOptions ResumeOptions() {
  MsprOptions o = TinyOptions();
  o.agent.target_update_every = 3;          // target copies inside both halves
  o.representation.updates_per_step = 0.5;  // fractional credit carried over
  return o;
}

void ExpectSameState(Trainer& a, Trainer& b) {
  EXPECT_EQ(a.step(), b.step());
  EXPECT_TRUE(torch::equal(Flat(*a.repr()), Flat(*b.repr())));
  EXPECT_TRUE(torch::equal(Flat(*a.critic()), Flat(*b.critic())));
  EXPECT_TRUE(torch::equal(Flat(*a.actor()), Flat(*b.actor())));
  EXPECT_TRUE(torch::equal(Flat(*a.target_repr()), Flat(*b.target_repr())));
  EXPECT_TRUE(torch::equal(Flat(*a.target_critic()), Flat(*b.target_critic())));
  EXPECT_TRUE(torch::equal(Flat(*a.target_actor()), Flat(*b.target_actor())));
}

TEST(CheckpointTest, RoundTripRestoresEverything) {
  TempDir dir;
  auto data = RandomStateDataset();
  Trainer a(ResumeOptions(), data);
  for (int i = 0; i < 4; ++i) a.Step();
  a.SaveCheckpoint(dir.File("a.ckpt"));
  MsprOptions other = ResumeOptions();
  other.trainer.seed = 99;  // different init: everything must come from the file
  Trainer b(other, data);
  b.LoadCheckpoint(dir.File("a.ckpt"));
  ExpectSameState(a, b);
  const MsprOptions stored = ReadCheckpointOptions(dir.File("a.ckpt"));
  EXPECT_EQ(OptionsToYaml(stored), OptionsToYaml(a.options()));
  // No temporary file is left behind.
  for (const auto& e : std::filesystem::directory_iterator(dir.path()))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
}

// Trains `o` for 8 steps straight, and for 5 steps, a checkpoint in `dir`, a
// new trainer that loads it and 3 more steps: {straight, resumed}.
std::pair<std::unique_ptr<Trainer>, std::unique_ptr<Trainer>> StraightAndResumed(
    const MsprOptions& o, const TempDir& dir) {
  auto data = RandomStateDataset();
  auto straight = std::make_unique<Trainer>(o, data);
  for (int i = 0; i < 8; ++i) straight->Step();
  {
    Trainer first(o, data);
    for (int i = 0; i < 5; ++i) first.Step();
    first.SaveCheckpoint(dir.File("half.ckpt"));
  }
  auto resumed = std::make_unique<Trainer>(o, data);
  resumed->LoadCheckpoint(dir.File("half.ckpt"));
  EXPECT_EQ(resumed->step(), 5);
  for (int i = 0; i < 3; ++i) resumed->Step();
  return {std::move(straight), std::move(resumed)};
}

TEST(CheckpointTest, ResumedRunEqualsUninterruptedRun) {
  TempDir dir;
  auto [straight, resumed] = StraightAndResumed(ResumeOptions(), dir);
  ExpectSameState(*straight, *resumed);
}

// agent.critic_target "expectile": the value network and its optimiser are
// part of the checkpoint (the critic's targets depend on them).
TEST(CheckpointTest, ResumedRunWithExpectileTargetEqualsUninterruptedRun) {
  TempDir dir;
  MsprOptions o = ResumeOptions();
  o.agent.critic_target = "expectile";
  auto [straight, resumed] = StraightAndResumed(o, dir);
  ExpectSameState(*straight, *resumed);
  EXPECT_TRUE(torch::equal(Flat(*straight->value()), Flat(*resumed->value())));
}

// agent.subgoal_steps: the subgoal actor, its average, V and their optimisers
// are part of the checkpoint, and the export acts through the subgoal actor.
TEST(CheckpointTest, SubgoalPolicyResumesExactlyAndTheExportActsThroughIt) {
  TempDir dir;
  MsprOptions o = ResumeOptions();
  o.agent.subgoal_steps = 3;
  o.trainer.policy_ema = 0.9;
  auto [straight, resumed] = StraightAndResumed(o, dir);
  ExpectSameState(*straight, *resumed);
  EXPECT_TRUE(torch::equal(Flat(*straight->value()), Flat(*resumed->value())));
  EXPECT_TRUE(torch::equal(Flat(*straight->subgoal_actor()), Flat(*resumed->subgoal_actor())));
  EXPECT_TRUE(
      torch::equal(Flat(*straight->ema_subgoal_actor()), Flat(*resumed->ema_subgoal_actor())));

  resumed->ExportPolicy(dir.File("policy.pt"));
  torch::manual_seed(5);
  const torch::Tensor obs = torch::randn({6, 3}), goal = torch::randn({6, 3});
  Policy live = resumed->MakePolicy();
  Policy loaded = Policy::Load(dir.File("policy.pt"));
  EXPECT_EQ(loaded.options().agent.subgoal_steps, 3);
  const torch::Tensor a = live.Act(obs, goal);
  EXPECT_TRUE(torch::equal(loaded.Act(obs, goal), a));
  // The action depends on the subgoal actor (which the export holds).
  {
    torch::NoGradGuard no_grad;
    for (auto& p : resumed->ema_subgoal_actor()->parameters()) p.add_(0.5);
  }
  EXPECT_FALSE(torch::allclose(live.Act(obs, goal), a, 1e-4, 1e-6));
}

TEST(CheckpointTest, PolicyAverageResumesExactlyAndIsWhatTheExportsHold) {
  TempDir dir;
  MsprOptions o = ResumeOptions();
  o.trainer.policy_ema = 0.9;
  auto [straight_ptr, resumed_ptr] = StraightAndResumed(o, dir);
  Trainer& straight = *straight_ptr;
  Trainer& resumed = *resumed_ptr;
  ExpectSameState(straight, resumed);
  EXPECT_TRUE(torch::equal(Flat(*straight.ema_repr()), Flat(*resumed.ema_repr())));
  EXPECT_TRUE(torch::equal(Flat(*straight.ema_critic()), Flat(*resumed.ema_critic())));
  EXPECT_TRUE(torch::equal(Flat(*straight.ema_actor()), Flat(*resumed.ema_actor())));

  // The export, the live policy and the trainer checkpoint's policy are the
  // average; the raw export is the online networks.
  resumed.ExportPolicy(dir.File("avg.pt"));
  resumed.ExportPolicy(dir.File("raw.pt"), /*raw=*/true);
  resumed.SaveCheckpoint(dir.File("end.ckpt"));
  torch::manual_seed(3);
  const torch::Tensor obs = torch::randn({6, 3}), goal = torch::randn({6, 3});
  Policy live = resumed.MakePolicy();
  const torch::Tensor a = live.Act(obs, goal);
  EXPECT_TRUE(torch::equal(Policy::Load(dir.File("avg.pt")).Act(obs, goal), a));
  EXPECT_TRUE(torch::equal(Policy::Load(dir.File("end.ckpt")).Act(obs, goal), a));
  Policy raw = Policy::Load(dir.File("raw.pt"));
  EXPECT_FALSE(torch::allclose(raw.Act(obs, goal), a, 1e-4, 1e-6));
  Policy online(o, resumed.repr(), resumed.actor(), resumed.critic(), torch::kCPU);
  EXPECT_TRUE(torch::equal(raw.Act(obs, goal), online.Act(obs, goal)));

  // A run keeps its average or its lack of one: resuming across the switch is refused.
  Trainer without(ResumeOptions(), RandomStateDataset());
  try {
    without.LoadCheckpoint(dir.File("end.ckpt"));
    FAIL() << "an averaged run's checkpoint loaded into a trainer without the average";
  } catch (const CheckpointError& e) {
    EXPECT_NE(std::string(e.what()).find("policy_ema"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(dir.File("end.ckpt")), std::string::npos) << e.what();
  }
}

void ExpectErrorNamesFile(const std::string& path, const std::function<void()>& load) {
  try {
    load();
    FAIL() << "no exception for " << path;
  } catch (const CheckpointError& e) {
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
}

TEST(CheckpointTest, TruncatedForeignAndCorruptFilesNameTheFile) {
  TempDir dir;
  auto data = RandomStateDataset();
  Trainer t(ResumeOptions(), data);
  t.Step();
  t.SaveCheckpoint(dir.File("good.ckpt"));
  const std::string good = ReadText(dir.File("good.ckpt"));
  const std::string truncated = dir.File("truncated.ckpt");
  WriteText(truncated, good.substr(0, good.size() * 2 / 3));
  ExpectErrorNamesFile(truncated, [&] { t.LoadCheckpoint(truncated); });
  WriteText(truncated, good.substr(0, 12));
  ExpectErrorNamesFile(truncated, [&] { t.LoadCheckpoint(truncated); });
  const std::string foreign = dir.File("foreign.ckpt");
  WriteText(foreign, "PK\x03\x04 this is some other file format entirely");
  ExpectErrorNamesFile(foreign, [&] { t.LoadCheckpoint(foreign); });
  ExpectErrorNamesFile(foreign, [&] { Policy::Load(foreign); });
  std::string flipped = good;
  flipped[flipped.size() / 2] ^= 0x5a;
  const std::string corrupt = dir.File("corrupt.ckpt");
  WriteText(corrupt, flipped);
  ExpectErrorNamesFile(corrupt, [&] { t.LoadCheckpoint(corrupt); });
  const std::string missing = dir.File("missing.ckpt");
  ExpectErrorNamesFile(missing, [&] { t.LoadCheckpoint(missing); });
  // A policy export is not a trainer checkpoint.
  t.ExportPolicy(dir.File("policy.pt"));
  ExpectErrorNamesFile(dir.File("policy.pt"), [&] { t.LoadCheckpoint(dir.File("policy.pt")); });
  // A checkpoint of other network sizes does not fit.
  MsprOptions wider = ResumeOptions();
  wider.network.critic_hidden = 48;
  Trainer w(wider, data);
  ExpectErrorNamesFile(dir.File("good.ckpt"), [&] { w.LoadCheckpoint(dir.File("good.ckpt")); });
}

TEST(CheckpointTest, ContainerRejectsWrongVersionAndKind) {
  TempDir dir;
  CheckpointFile f;
  f.kind = "policy";
  f.version = kCheckpointFormatVersion;
  f.header = "step: 1\n";
  f.payload = std::string("\0\1\2\3", 4);
  WriteCheckpointFile(dir.File("c.ckpt"), f);
  const CheckpointFile back = ReadCheckpointFile(dir.File("c.ckpt"));
  EXPECT_EQ(back.kind, "policy");
  EXPECT_EQ(back.header, f.header);
  EXPECT_EQ(back.payload, f.payload);
  ExpectErrorNamesFile(dir.File("c.ckpt"),
                       [&] { ReadCheckpointFile(dir.File("c.ckpt"), "trainer"); });
  std::string bytes = ReadText(dir.File("c.ckpt"));
  bytes[8] = 99;  // format version
  WriteText(dir.File("v.ckpt"), bytes);
  ExpectErrorNamesFile(dir.File("v.ckpt"), [&] { ReadCheckpointFile(dir.File("v.ckpt")); });
}

// A trainer one step in, checkpointed at dir/checkpoint.ckpt.
struct OneStepCheckpoint {
  TempDir dir;
  std::shared_ptr<const Dataset> data = RandomStateDataset();
  Trainer t{ResumeOptions(), data};
  std::string path = dir.File("checkpoint.ckpt");
  OneStepCheckpoint() {
    t.Step();
    t.SaveCheckpoint(path);
  }
};

TEST(CheckpointTest, KeepsThePreviousAndFallsBackToItWhenTheNewestIsTruncated) {
  OneStepCheckpoint c;
  Trainer& t = c.t;
  const auto& data = c.data;
  const std::string& path = c.path;
  const std::string first = ReadText(path);
  t.Step();
  t.SaveCheckpoint(path);
  const std::string second = ReadText(path);
  EXPECT_EQ(ReadText(path + ".prev"), first);
  std::mt19937_64 rng(7);  // seeded truncation offsets
  auto truncate = [&] {
    const size_t cut = std::uniform_int_distribution<size_t>(0, second.size() - 1)(rng);
    WriteText(path, second.substr(0, cut));
    return cut;
  };
  for (int k = 0; k < 12; ++k) {
    const size_t cut = truncate();
    Trainer u(ResumeOptions(), data);
    u.LoadCheckpoint(path);  // newest fails its CRC / length: the previous one
    EXPECT_EQ(u.step(), 1) << "cut at " << cut;
    EXPECT_EQ(ReadCheckpointOptions(path).trainer.seed, ResumeOptions().trainer.seed);
  }
  // Without a previous checkpoint, a truncated one is a clear error naming it.
  std::filesystem::remove(path + ".prev");
  for (int k = 0; k < 6; ++k) {
    truncate();
    Trainer u(ResumeOptions(), data);
    ExpectErrorNamesFile(path, [&] { u.LoadCheckpoint(path); });
  }
}

TEST(CheckpointTest, NonFiniteWeightsNeverOverwriteTheLastGoodCheckpoint) {
  OneStepCheckpoint c;
  Trainer& t = c.t;
  const auto& data = c.data;
  const std::string& path = c.path;
  const std::string good = ReadText(path);
  {
    torch::NoGradGuard no_grad;
    t.actor()->parameters()[0].view(-1)[0] = std::numeric_limits<float>::quiet_NaN();
  }
  try {
    t.SaveCheckpoint(path);
    FAIL() << "NaN weights were written";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("diverged"), std::string::npos) << e.what();
  }
  EXPECT_EQ(ReadText(path), good);
  // The training loop stops at the first logged step with a non-finite loss,
  // without writing a checkpoint or an export.
  TempDir out;
  MsprOptions o = ResumeOptions();
  o.trainer.log_every = 1;
  o.trainer.checkpoint_every = 1;
  Trainer u(o, data);
  {
    torch::NoGradGuard no_grad;
    for (auto& p : u.critic()->parameters()) p.fill_(std::numeric_limits<float>::infinity());
  }
  TrainLoopOptions loop;
  loop.out_dir = out.path();
  loop.quiet = true;
  try {
    u.Train(loop, nullptr);
    FAIL() << "training went on with non-finite losses";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("non-finite loss at step 1"), std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(out.File("checkpoint.ckpt")));
  EXPECT_FALSE(std::filesystem::exists(out.File("policy.pt")));
}

// trainer.export_every writes policy_step<N>.pt beside the final export; the
// last one is the final policy, and the others load and differ from it.
TEST(CheckpointTest, ExportEveryWritesLoadableStepExports) {
  TempDir out;
  auto data = RandomStateDataset();
  MsprOptions o = ResumeOptions();
  o.trainer.steps = 6;
  o.trainer.export_every = 3;
  Trainer t(o, data);
  TrainLoopOptions loop;
  loop.out_dir = out.path();
  loop.quiet = true;
  t.Train(loop, nullptr);
  ASSERT_TRUE(std::filesystem::exists(out.File("policy_step3.pt")));
  ASSERT_TRUE(std::filesystem::exists(out.File("policy_step6.pt")));
  EXPECT_FALSE(std::filesystem::exists(out.File("policy_step0.pt")));
  Policy last = Policy::Load(out.File("policy_step6.pt"));
  const torch::Tensor obs = torch::randn({5, last.obs_dim()});
  const torch::Tensor goal = torch::randn({5, last.obs_dim()});
  Policy final_export = Policy::Load(out.File("policy.pt"));
  Policy early = Policy::Load(out.File("policy_step3.pt"));
  EXPECT_TRUE(torch::equal(last.Act(obs, goal), final_export.Act(obs, goal)));
  EXPECT_FALSE(torch::equal(early.Act(obs, goal), final_export.Act(obs, goal)));
}

TEST(CheckpointTest, RunDirLockAdmitsOneRun) {
  TempDir dir;
  {
    RunDirLock a(dir.path());
    try {
      RunDirLock b(dir.path());
      FAIL() << "a second lock was granted";
    } catch (const CheckpointError& e) {
      EXPECT_NE(std::string(e.what()).find("another training run"), std::string::npos) << e.what();
    }
  }
  RunDirLock again(dir.path());  // released with the first
}

}  // namespace
}  // namespace core
}  // namespace msspr
