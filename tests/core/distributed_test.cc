// Data-parallel training with c10d and Gloo on loopback: two ranks (here two
// threads of one process, each with its own TCPStore client and Gloo
// group) average gradients to the whole batch's and keep identical
// parameters. The two-process runs of msspr_train (checkpoint, resume,
// export, a killed rank) are in tests/ros/training/agent_ros_test.cc.
#include "msspr_core/distributed.h"

#include <gtest/gtest.h>

#include <functional>
#include <mutex>
#include <thread>

#include "msspr_core/trainer.h"
#include "point_square.h"
#include "test_util.h"

namespace msspr {
namespace core {
namespace {

// Runs body(rank, group) on two threads, one per rank; rethrows the first failure.
void RunTwoRanks(const std::function<void(int, std::shared_ptr<Distributed>)>& body) {
  const int port = testing_util::FreePort();
  std::exception_ptr errors[2];
  std::thread threads[2];
  // Each rank's process group lives until both bodies are done: a rank whose body ends
  // at once (a refused option) must not close its connections while the other is still
  // connecting ("Connection closed by peer" in the other's rendezvous).
  std::shared_ptr<Distributed> groups[2];
  for (int r = 0; r < 2; ++r) {
    threads[r] = std::thread([&, r] {
      try {
        DistributedOptions o;
        o.world_size = 2;
        o.rank = r;
        o.master_port = port;
        o.timeout_s = 60;
        groups[r] = std::make_shared<Distributed>(o, torch::kCPU);
        body(r, groups[r]);
      } catch (...) {
        errors[r] = std::current_exception();
      }
    });
  }
  for (auto& t : threads) t.join();
  for (auto& e : errors)
    if (e) std::rethrow_exception(e);
}

std::mutex construct_mutex;  // torch::manual_seed is process-wide

MsprOptions TinyMspr() {
  MsprOptions o = MakePreset("mspr", "cpu");
  NetworkOptions& n = o.network;
  n.encoder_hidden = n.zsa_hidden = n.goal_hidden = n.critic_hidden = n.actor_hidden = 32;
  n.zs_dim = n.zsa_dim = 32;
  n.za_dim = n.goal_dim = 16;
  o.trainer.batch_size = 16;
  o.trainer.seed = 5;
  o.trainer.pipeline = "off";
  return o;
}

MsprOptions TinyBaseline(const std::string& agent) {
  MsprOptions o = MakePreset(agent, "cpu");
  o.baseline.hidden = 32;
  o.baseline.layers = 2;
  o.trainer.batch_size = 16;
  o.trainer.seed = 5;
  return o;
}

std::vector<torch::Tensor> GradsOf(torch::nn::Module& m) {
  std::vector<torch::Tensor> g;
  for (const auto& p : m.parameters())
    g.push_back(p.grad().defined() ? p.grad().clone() : torch::Tensor());
  return g;
}

void ExpectSameGrads(const std::vector<torch::Tensor>& a, const std::vector<torch::Tensor>& b,
                     const std::string& what) {
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].defined(), b[i].defined()) << what << " parameter " << i;
    if (a[i].defined()) {
      EXPECT_TRUE(torch::allclose(a[i], b[i], 1e-4, 1e-6))
          << what << " parameter " << i << ": max diff "
          << (a[i] - b[i]).abs().max().item<double>();
    }
  }
}

// The first or second half of a batch's rows.
TransitionBatch Half(const TransitionBatch& b, int half) {
  const int64_t n = b.obs.size(0) / 2;
  auto h = [&](const torch::Tensor& t) {
    return t.defined() ? t.narrow(0, half * n, n).clone() : t;
  };
  TransitionBatch o;
  o.obs = h(b.obs);
  o.action = h(b.action);
  o.next_obs = h(b.next_obs);
  o.value_goal = h(b.value_goal);
  o.actor_goal = h(b.actor_goal);
  o.ret = h(b.ret);
  o.discount = h(b.discount);
  return o;
}

TEST(Distributed, AveragedGradientEqualsTheWholeBatchGradient) {
  torch::set_num_threads(1);
  auto data = point_square::ExpertDataset(10, 20, 1);
  // The whole batch in one process: GCIVL's loss and Ms.PR's critic loss (batch means).
  std::vector<torch::Tensor> gcivl_whole, critic_whole;
  TransitionBatch baseline_batch, mspr_batch;
  torch::Tensor noise;
  {
    Trainer t(TinyBaseline("gcivl"), data);
    baseline_batch = t.SampleBaselineBatch();
    t.agent()->zero_grad();
    t.agent()->Loss(baseline_batch, nullptr).backward();
    gcivl_whole = GradsOf(*t.agent());
  }
  {
    Trainer t(TinyMspr(), data);
    mspr_batch = t.SampleTransitions();
    noise = torch::randn({16, 2});
    t.critic()->zero_grad();
    t.CriticLoss(mspr_batch, noise).backward();
    critic_whole = GradsOf(*t.critic());
  }
  std::vector<torch::Tensor> gcivl_split[2], critic_split[2];
  RunTwoRanks([&](int rank, std::shared_ptr<Distributed> dist) {
    std::unique_ptr<Trainer> b, m;
    {
      std::lock_guard<std::mutex> lock(construct_mutex);
      b = std::make_unique<Trainer>(TinyBaseline("gcivl"), data);
      m = std::make_unique<Trainer>(TinyMspr(), data);
    }
    b->agent()->zero_grad();
    b->agent()->Loss(Half(baseline_batch, rank), nullptr).backward();
    dist->AverageGradients(b->agent()->parameters());
    gcivl_split[rank] = GradsOf(*b->agent());
    m->critic()->zero_grad();
    m->CriticLoss(Half(mspr_batch, rank), noise.narrow(0, rank * 8, 8)).backward();
    dist->AverageGradients(m->critic()->parameters());
    critic_split[rank] = GradsOf(*m->critic());
  });
  for (int r = 0; r < 2; ++r) {
    ExpectSameGrads(gcivl_split[r], gcivl_whole, "gcivl rank " + std::to_string(r));
    ExpectSameGrads(critic_split[r], critic_whole, "Ms.PR critic rank " + std::to_string(r));
  }
}

class TwoRanks : public testing::TestWithParam<std::string> {};

TEST_P(TwoRanks, TrainWithIdenticalParametersOnDifferentBatches) {
  torch::set_num_threads(1);
  auto data = point_square::ExpertDataset(10, 20, 1);
  const MsprOptions o = GetParam() == "mspr" ? TinyMspr() : TinyBaseline(GetParam());
  std::vector<torch::Tensor> params[2];
  std::vector<int64_t> first_obs[2];
  RunTwoRanks([&](int rank, std::shared_ptr<Distributed> dist) {
    std::unique_ptr<Trainer> t;
    {
      std::lock_guard<std::mutex> lock(construct_mutex);
      t = std::make_unique<Trainer>(o, data);
    }
    t->SetDistributed(dist);
    EXPECT_EQ(t->local_batch(), 8);
    for (int i = 0; i < 6; ++i) t->Step(i == 5);
    for (const auto& [name, m] : std::vector<std::pair<std::string, torch::nn::Module*>>{
             {"agent", t->baseline() ? t->agent().get() : nullptr},
             {"repr", t->baseline() ? nullptr : t->repr().get()},
             {"critic", t->baseline() ? nullptr : t->critic().get()},
             {"actor", t->baseline() ? nullptr : t->actor().get()}}) {
      if (!m) continue;
      for (const auto& p : m->parameters()) params[rank].push_back(p.detach().clone());
    }
    // Each rank draws its own part of the batch.
    const TransitionBatch b = t->baseline() ? t->SampleBaselineBatch() : t->SampleTransitions();
    for (int64_t i = 0; i < b.obs.size(0); ++i)
      first_obs[rank].push_back(static_cast<int64_t>(1e6 * b.obs[i][0].item<float>()));
  });
  ASSERT_EQ(params[0].size(), params[1].size());
  ASSERT_FALSE(params[0].empty());
  for (size_t i = 0; i < params[0].size(); ++i)
    EXPECT_TRUE(torch::equal(params[0][i], params[1][i])) << "parameter " << i;
  EXPECT_NE(first_obs[0], first_obs[1]) << "both ranks sampled the same batch";
}

INSTANTIATE_TEST_SUITE_P(Agents, TwoRanks, testing::Values("mspr", "gcivl", "hiql"),
                         [](const testing::TestParamInfo<std::string>& info) {
                           return info.param;
                         });

TEST(Distributed, RejectsBadOptionsAndABatchThatDoesNotSplit) {
  DistributedOptions o;
  o.world_size = 2;
  o.rank = 2;
  EXPECT_THROW(o.Validate(), DistributedError);
  o.rank = 1;
  o.master_port = 70000;
  EXPECT_THROW(o.Validate(), DistributedError);
  setenv("WORLD_SIZE", "x2", 1);
  EXPECT_THROW(DistributedOptions::FromEnvironment(), DistributedError);
  setenv("WORLD_SIZE", "3", 1);
  setenv("RANK", "1", 1);
  setenv("MASTER_ADDR", "10.0.0.7", 1);
  setenv("MASTER_PORT", "29511", 1);
  const DistributedOptions e = DistributedOptions::FromEnvironment();
  EXPECT_EQ(e.world_size, 3);
  EXPECT_EQ(e.rank, 1);
  EXPECT_EQ(e.master_addr, "10.0.0.7");
  EXPECT_EQ(e.master_port, 29511);
  for (const char* v : {"WORLD_SIZE", "RANK", "MASTER_ADDR", "MASTER_PORT"}) unsetenv(v);
  // A batch of 15 does not split over 2 ranks.
  auto data = point_square::ExpertDataset(4, 20, 1);
  MsprOptions odd = TinyBaseline("gcbc");
  odd.trainer.batch_size = 15;
  std::string error;
  RunTwoRanks([&](int rank, std::shared_ptr<Distributed> dist) {
    std::unique_ptr<Trainer> t;
    {
      std::lock_guard<std::mutex> lock(construct_mutex);
      t = std::make_unique<Trainer>(odd, data);
    }
    try {
      t->SetDistributed(dist);
    } catch (const OptionsError& e) {
      if (rank == 0) error = e.what();
    }
  });
  EXPECT_NE(error.find("not a multiple of the world size 2"), std::string::npos) << error;
}

}  // namespace
}  // namespace core
}  // namespace msspr
