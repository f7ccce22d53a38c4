// The agent's ROS layer without a master: bags into the core dataset, the
// in-process evaluator, and msspr_train killed mid-run and resumed.
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <rosbag/bag.h>

#include "bag_dataset.h"
#include "dataset_bag.h"
#include "maze_evaluator.h"
#include "msspr/Action.h"
#include "msspr/EpisodeInfo.h"
#include "msspr/Observation.h"
#include "msspr_core/policy.h"

namespace msspr::agent {
namespace {

std::string Tmp(const std::string& name) { return "/tmp/msspr_agent_test_" + std::to_string(getpid()) + "_" + name; }

bool Exists(const std::string& p) {
  struct stat st;
  return stat(p.c_str(), &st) == 0;
}

// Writes one episode with the given steps missing from the observations.
void WriteEpisode(rosbag::Bag& bag, uint32_t id, const std::string& split, int n, const std::vector<int>& missing,
                  int obs_dim = 2) {
  msspr::EpisodeInfo info;
  info.episode_id = id;
  info.env = "pointmaze-medium";
  info.split = split;
  bag.write(ros_bridge::kEpisodeTopic, ros::Time(1.0 + id * 1000), info);
  for (int t = 0; t < n; ++t) {
    const ros::Time stamp(1.0 + id * 1000 + t + 1);
    msspr::Observation o;
    o.header.stamp = stamp;
    o.episode_id = id;
    o.step = static_cast<uint32_t>(t);
    o.state.assign(static_cast<size_t>(obs_dim), static_cast<float>(100 * id + t));
    if (std::find(missing.begin(), missing.end(), t) == missing.end()) bag.write(ros_bridge::kObservationTopic, stamp, o);
    msspr::Action a;
    a.episode_id = id;
    a.step = static_cast<uint32_t>(t);
    a.action = {0.1f * t, -0.1f * t};
    bag.write(ros_bridge::kActionTopic, stamp, a);
  }
}

TEST(BagDataset, SplitsAtGapsAndFiltersSplit) {
  ros::Time::init();
  const std::string path = Tmp("gaps.bag");
  {
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    WriteEpisode(bag, 0, "train", 10, {});
    WriteEpisode(bag, 1, "train", 12, {5});     // -> runs [0,5) and [6,12)
    WriteEpisode(bag, 2, "val", 8, {});
    WriteEpisode(bag, 3, "train", 6, {1});      // -> [0,1) is too short, [2,6)
  }
  BagLoadReport report;
  BagLoadOptions opt;
  const core::Dataset train = LoadBagDataset({path}, opt, &report);
  EXPECT_EQ(report.episodes, 4u);
  EXPECT_EQ(report.episodes_other_split, 1u);
  EXPECT_EQ(report.incomplete_episodes, 2u);
  EXPECT_EQ(report.missing_observations, 2u);
  EXPECT_EQ(report.short_segments, 1u);
  EXPECT_EQ(report.trajectories, 4u);  // 10 | 5 + 6 | 4
  EXPECT_EQ(train.num_trajectories(), 4);
  EXPECT_EQ(train.size(), 10 + 5 + 6 + 4);
  EXPECT_EQ(report.dropped_steps, 1u + 2u);  // step 5 of ep 1; steps 0-1 of ep 3
  EXPECT_EQ(report.env, "pointmaze-medium");
  // The second trajectory starts right after the gap: its first state is episode 1 step 6.
  EXPECT_FLOAT_EQ(train.state(10 + 5)[0], 106.f);
  opt.split = "val";
  const core::Dataset val = LoadBagDataset({path}, opt, &report);
  EXPECT_EQ(val.size(), 8);
  EXPECT_EQ(val.num_trajectories(), 1);
  std::remove(path.c_str());
}

TEST(BagDataset, ErrorsNameTheBag) {
  ros::Time::init();
  const std::string a = Tmp("a.bag"), b = Tmp("b.bag");
  {
    rosbag::Bag bag(a, rosbag::bagmode::Write);
    WriteEpisode(bag, 0, "train", 5, {});
  }
  {
    rosbag::Bag bag(b, rosbag::bagmode::Write);
    WriteEpisode(bag, 0, "train", 5, {}, /*obs_dim=*/3);
  }
  BagLoadOptions opt;
  try {
    LoadBagDataset({a, b}, opt, nullptr);
    FAIL() << "mismatched dimensions accepted";
  } catch (const core::DatasetError& e) {
    EXPECT_NE(std::string(e.what()).find(b), std::string::npos) << e.what();
  }
  opt.images = true;  // no episode has images
  EXPECT_THROW(LoadBagDataset({a}, opt, nullptr), core::DatasetError);
  EXPECT_THROW(LoadBagDataset({Tmp("missing.bag")}, BagLoadOptions{}, nullptr), ros_bridge::BagError);
  std::remove(a.c_str());
  std::remove(b.c_str());
}

TEST(BagDataset, SampleBagWithImages) {
  ros::Time::init();
  BagLoadOptions opt;
  opt.images = true;
  BagLoadReport report;
  const core::Dataset d =
      LoadBagDataset({std::string(MSSPR_SOURCE_DIR) + "/rosbags/pointmaze-medium-navigate-pixels-sample.bag"}, opt,
                     &report);
  EXPECT_TRUE(d.has_images());
  EXPECT_EQ(d.num_trajectories(), 4);
  EXPECT_EQ(d.size(), 4 * 201);
  EXPECT_TRUE(report.problems.empty());
}

TEST(MazeEvaluator, DeterministicAndSane) {
  auto policy = core::Policy::Load(MSSPR_TEST_CHECKPOINT);
  MazeEvalOptions opt;
  opt.episodes = 3;
  opt.max_steps = 300;
  opt.keep_paths = true;
  const auto a = EvaluateOnMaze(policy, opt);
  const auto b = EvaluateOnMaze(policy, opt);
  ASSERT_EQ(a.success.size(), 5u);
  EXPECT_EQ(a.success, b.success);
  EXPECT_EQ(a.mean_steps_success, b.mean_steps_success);
  for (double s : a.success) {
    EXPECT_GE(s, 0.0);
    EXPECT_LE(s, 1.0);
  }
  ASSERT_EQ(a.paths.size(), 5u);
  ASSERT_EQ(a.paths[0].size(), 3u);
  for (size_t t = 0; t < 5; ++t)
    for (size_t e = 0; e < 3; ++e) {
      const size_t len = a.paths[t][e].size();
      EXPECT_GE(len, 2u);
      EXPECT_LE(len, 301u);
      if (!a.episode_success[t][e]) {
        EXPECT_EQ(len, 301u);  // a failure ran to the step limit
      }
    }
  opt.tasks = {7};
  EXPECT_THROW(EvaluateOnMaze(policy, opt), std::invalid_argument);
}

// Runs msspr_train; returns the pid.
pid_t StartTrain(const std::vector<std::string>& args, const std::string& log) {
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<char*> argv;
    std::string exe = MSSPR_TRAIN_EXE;
    argv.push_back(exe.data());
    std::vector<std::string> copy = args;
    for (auto& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    freopen(log.c_str(), "w", stderr);
    freopen(log.c_str(), "a", stdout);
    execv(exe.c_str(), argv.data());
    _exit(127);
  }
  return pid;
}

int CountLines(const std::string& path) {
  std::ifstream f(path);
  int n = 0;
  for (std::string line; std::getline(f, line);) ++n;
  return n;
}

TEST(TrainCli, KilledMidRunResumesAndFinishes) {
  const std::string out = Tmp("run");
  const std::string bag = std::string(MSSPR_SOURCE_DIR) + "/rosbags/pointmaze-medium-navigate-sample.bag";
  const std::vector<std::string> args = {"--data", bag, "--scale", "cpu", "--batch", "32", "--steps", "400",
                                         "--checkpoint-every", "20", "--log-every", "10", "--out", out,
                                         "--seed", "3", "--quiet"};
  const pid_t pid = StartTrain(args, out + ".log1");
  const std::string ckpt = out + "/checkpoint.ckpt";
  // Kill it without warning once a checkpoint exists (well before the end).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(5);
  while (!Exists(ckpt) && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  ASSERT_TRUE(Exists(ckpt)) << "no checkpoint appeared";
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  ASSERT_TRUE(WIFSIGNALED(status)) << "the run finished before it could be killed";
  EXPECT_FALSE(Exists(out + "/policy.pt"));
  // The checkpoint on disk is whole (atomic rename), and the run resumes to the end.
  const pid_t resumed = StartTrain({"--resume", "--data", bag, "--out", out, "--quiet"}, out + ".log2");
  waitpid(resumed, &status, 0);
  ASSERT_TRUE(WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 0) << "see " << out << ".log2";
  EXPECT_TRUE(Exists(out + "/policy.pt"));
  auto policy = core::Policy::Load(out + "/policy.pt");
  EXPECT_EQ(policy.obs_dim(), 2);
  std::ifstream log(out + ".log2");
  std::string text((std::istreambuf_iterator<char>(log)), {});
  EXPECT_NE(text.find("resumed"), std::string::npos) << text;
  EXPECT_NE(text.find("done at step 400"), std::string::npos) << text;
  EXPECT_GT(CountLines(out + "/metrics.csv"), 1);
}

}  // namespace
}  // namespace msspr::agent
