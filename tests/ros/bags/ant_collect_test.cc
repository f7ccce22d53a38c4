// msspr_collect --env antmaze-medium|antmaze-large: the bag has the dataset
// layout with 29-D observations and 8-D actions in [-1, 1], the episode
// lengths and splits asked for, each episode's start and full 29-D goal, and
// holds exactly the episodes of agent::CollectAntEpisode for the seed (so a
// second run is identical); stitch goals are 4 BFS moves from the start;
// msspr_bag_info reports the 29-D observation. A tiny untrained expert; no
// master needed.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "../../eval/ant_test_policy.h"
#include "cli_test_util.h"
#include "msspr_bags/dataset_bag.h"
#include "msspr_eval/ant_dataset.h"
#include "msspr_sim/ant_maze.h"
#include "msspr_sim/ant_planner.h"

namespace msspr::ros_bridge {
namespace {

// msspr_collect ARGS to its end (test::RunTool): the exit status, and its output into *output.
int RunCollect(const std::string& args, std::string* output) {
  const test::ToolOutput r = test::RunTool(std::string(MSSPR_COLLECT_EXE) + " " + args, 280);
  if (output != nullptr) *output = r.text;
  return r.status;
}

class AntCollect : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = "/tmp/msspr_ant_collect_test_" + std::to_string(getpid());
    expert_ = testing_util::WriteTinyAntExpert(dir_);
  }
  static void TearDownTestSuite() { std::filesystem::remove_all(dir_); }
  static std::string dir_, expert_;
};
std::string AntCollect::dir_, AntCollect::expert_;

std::vector<BagEpisode> ReadAll(const std::string& bag) {
  std::vector<BagEpisode> eps;
  DatasetBagReader reader(bag);
  reader.ForEachEpisode([&](BagEpisode&& ep) { eps.push_back(std::move(ep)); });
  return eps;
}

TEST_F(AntCollect, NavigateBagHasTheLayoutAndTheSeededEpisodes) {
  const std::string bag = dir_ + "/nav.bag";
  std::string out;
  ASSERT_EQ(RunCollect("--env antmaze-medium --expert " + expert_ +
                           " --episodes 2 --val-episodes 1 --length 201 --seed 5 --out " + bag,
                       &out),
            0)
      << out;
  EXPECT_NE(out.find("antmaze-medium-navigate, 2 train + 1 val episodes of 201 steps"),
            std::string::npos)
      << out;
  EXPECT_NE(out.find("steps/s"), std::string::npos) << out;
  const std::vector<BagEpisode> eps = ReadAll(bag);
  ASSERT_EQ(eps.size(), 3u);

  core::SacPolicy policy(expert_);
  sim::AntMaze env(sim::AntMazeOptions{});
  agent::AntCollectOptions o;
  o.episode_length = 201;
  o.seed = 5;
  const std::vector<std::string> splits{"train", "train", "val"};
  for (size_t k = 0; k < eps.size(); ++k) {
    const BagEpisode& ep = eps[k];
    ASSERT_TRUE(ep.complete()) << ep.problems.front();
    ASSERT_TRUE(ep.has_meta);
    EXPECT_EQ(ep.meta.env, "antmaze-medium");
    EXPECT_EQ(ep.meta.split, splits[k]);
    EXPECT_EQ(ep.num_steps, 201);
    EXPECT_EQ(ep.obs_dim, 29);
    EXPECT_EQ(ep.act_dim, 8);
    EXPECT_EQ(ep.image_size, 0);
    for (float a : ep.actions) {
      ASSERT_GE(a, -1.0f);
      ASSERT_LE(a, 1.0f);
    }
    const agent::AntEpisode ref = agent::CollectAntEpisode(env, policy, o, k);
    EXPECT_EQ(ep.meta.seed, ref.seed);
    EXPECT_EQ(ep.observations, ref.observations) << "episode " << k;
    EXPECT_EQ(ep.actions, ref.actions) << "episode " << k;
    EXPECT_EQ(ep.meta.start,
              std::vector<float>(ref.observations.begin(), ref.observations.begin() + 29));
    ASSERT_EQ(ep.meta.goal.size(), 29u);
    for (int i = 0; i < 29; ++i) EXPECT_EQ(ep.meta.goal[i], static_cast<float>(ref.goal[i]));
    // the goal is a vertex cell's (navigate)
    const sim::Cell g =
        sim::AntPlanner::XYToCell(Eigen::Vector2d(ep.meta.goal[0], ep.meta.goal[1]));
    bool vertex = false;
    for (const sim::Cell& v : env.map().VertexCells()) vertex = vertex || v == g;
    EXPECT_TRUE(vertex);
  }

  // The same command again writes the same data.
  const std::string bag2 = dir_ + "/nav2.bag";
  ASSERT_EQ(
      RunCollect("--env antmaze-medium --expert " + expert_ +
                     " --episodes 2 --val-episodes 1 --length 201 --seed 5 --quiet --out " + bag2,
                 &out),
      0)
      << out;
  const std::vector<BagEpisode> again = ReadAll(bag2);
  ASSERT_EQ(again.size(), eps.size());
  for (size_t k = 0; k < eps.size(); ++k) {
    EXPECT_EQ(again[k].observations, eps[k].observations);
    EXPECT_EQ(again[k].actions, eps[k].actions);
  }

  // msspr_bag_info shows the 29-D observation.
  const test::ToolOutput info = test::RunTool(std::string(MSSPR_BAG_INFO_EXE) + " " + bag, 280);
  out = info.text;
  ASSERT_EQ(info.status, 0) << out;
  EXPECT_NE(out.find("observation:  dim 29 float32"), std::string::npos) << out;
  EXPECT_NE(out.find("action:       dim 8 float32"), std::string::npos) << out;
}

TEST_F(AntCollect, StitchGoalsAreFourBfsMovesFromTheStart) {
  const std::string bag = dir_ + "/stitch.bag";
  std::string out;
  ASSERT_EQ(RunCollect("--env antmaze-large --kind stitch --expert " + expert_ +
                           " --episodes 6 --val-episodes 0 --length 20 --quiet --out " + bag,
                       &out),
            0)
      << out;
  const std::vector<BagEpisode> eps = ReadAll(bag);
  ASSERT_EQ(eps.size(), 6u);
  const sim::MazeMap map = sim::MazeMap::FromName("large");
  for (const BagEpisode& ep : eps) {
    EXPECT_EQ(ep.meta.env, "antmaze-large");
    EXPECT_EQ(ep.num_steps, 20);
    ASSERT_EQ(ep.meta.goal.size(), 29u);
    const sim::Cell s =
        sim::AntPlanner::XYToCell(Eigen::Vector2d(ep.meta.start[0], ep.meta.start[1]));
    const sim::Cell g =
        sim::AntPlanner::XYToCell(Eigen::Vector2d(ep.meta.goal[0], ep.meta.goal[1]));
    EXPECT_EQ(map.BfsDistance(s, g), 4) << ep.meta.episode_id;
  }
}

TEST_F(AntCollect, UsageErrors) {
  std::string out;
  const std::string bag = dir_ + "/usage.bag";  // never written
  // Without --expert, the shipped expert (msspr_sim/experts/ant_xy_expert.pt) drives.
  const std::string shipped = "/tmp/msspr_ant_default_expert_" + std::to_string(getpid()) + ".bag";
  EXPECT_EQ(
      RunCollect(
          "--env antmaze-medium --episodes 1 --val-episodes 0 --length 5 --quiet --out " + shipped,
          &out),
      0)
      << out;
  EXPECT_TRUE(std::filesystem::exists(shipped));
  std::filesystem::remove(shipped);
  EXPECT_EQ(
      RunCollect("--env antmaze-medium --expert " + expert_ + " --maze large --out " + bag, &out),
      2);
  EXPECT_NE(out.find("--maze does not apply"), std::string::npos) << out;
  EXPECT_EQ(RunCollect("--env antmaze-medium --expert " + expert_ + " --images --out " + bag, &out),
            2);
  EXPECT_EQ(RunCollect("--expert " + expert_ + " --out " + bag, &out), 2);
  EXPECT_EQ(
      RunCollect("--env antmaze-medium --expert /nonexistent.pt --episodes 1 --quiet --out " + bag,
                 &out),
      1);
  EXPECT_NE(out.find("/nonexistent.pt"), std::string::npos) << out;
  EXPECT_FALSE(std::filesystem::exists(bag));
}

}  // namespace
}  // namespace msspr::ros_bridge
