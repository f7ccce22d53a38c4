// The ant mazes' waypoint expert and datasets (msspr_eval/ant_waypoint_expert.h,
// msspr_eval/ant_dataset.h) with a tiny untrained expert: the expert's input
// layout (ob[2:] then the planner's direction), its noise (N(0, 0.2^2) on
// tanh(mean), then clipped), seeded episodes with the specified lengths,
// goals and dimensions, the stitch goal 4 BFS moves away, the .npz export
// with qpos and qvel, and the expert evaluation's bookkeeping.
#include "msspr_eval/ant_waypoint_expert.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "ant_test_policy.h"
#include "msspr_core/npz.h"
#include "msspr_eval/ant_dataset.h"
#include "msspr_sim/ant_maze.h"
#include "msspr_sim/ant_planner.h"
#include "msspr_sim/package_files.h"

namespace msspr::agent {
namespace {

class AntExpertTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = "/tmp/msspr_ant_expert_test_" + std::to_string(getpid());
    policy_ = std::make_unique<core::SacPolicy>(testing_util::WriteTinyAntExpert(dir_));
  }
  static void TearDownTestSuite() {
    policy_.reset();
    std::filesystem::remove_all(dir_);
  }
  static sim::AntMaze& Medium() {
    static sim::AntMaze env(sim::AntMazeOptions{});
    return env;
  }
  static std::string dir_;
  static std::unique_ptr<core::SacPolicy> policy_;
};
std::string AntExpertTest::dir_;
std::unique_ptr<core::SacPolicy> AntExpertTest::policy_;

bool IsVertex(const sim::MazeMap& map, sim::Cell c) {
  for (const sim::Cell& v : map.VertexCells())
    if (v == c) return true;
  return false;
}

TEST_F(AntExpertTest, InputIsBodyThenPlannerDirection) {
  sim::AntMaze& env = Medium();
  const Eigen::VectorXd ob = env.ResetToTask(1, 3);
  const Eigen::Vector2d goal = env.goal_xy();
  AntWaypointExpert expert(*policy_, env.map());
  const Eigen::VectorXd a = expert.Act(ob, goal);
  const std::vector<float>& in = expert.last_input();
  ASSERT_EQ(in.size(), 29u);
  ASSERT_EQ(AntWaypointExpert::kInputDim, 29);
  for (int k = 0; k < 27; ++k) EXPECT_EQ(in[k], static_cast<float>(ob[k + 2])) << k;
  sim::AntPlanner planner(env.map());
  const Eigen::Vector2d dir = planner.Direction(ob.head<2>(), goal);
  EXPECT_NEAR(dir.norm(), 1.0, 1e-5);
  EXPECT_EQ(expert.last_direction(), dir);
  EXPECT_EQ(in[27], static_cast<float>(dir.x()));
  EXPECT_EQ(in[28], static_cast<float>(dir.y()));
  // Noise-free: exactly the policy's tanh(mean) on that input.
  const std::vector<float> direct = policy_->Act(in);
  ASSERT_EQ(a.size(), 8);
  for (int k = 0; k < 8; ++k) EXPECT_EQ(a[k], static_cast<double>(direct[k])) << k;
  EXPECT_THROW(AntExpertInput(Eigen::VectorXd::Zero(27), dir), std::invalid_argument);
  EXPECT_THROW(AntWaypointExpert(*policy_, env.map(), -0.1), std::invalid_argument);
}

TEST_F(AntExpertTest, NoiseIsGaussianAroundTheDeterministicActionThenClipped) {
  sim::AntMaze& env = Medium();
  const Eigen::VectorXd ob = env.ResetToTask(2, 5);
  AntWaypointExpert expert(*policy_, env.map(), 0.2, 11);
  const int n = 4000;
  Eigen::VectorXd sum = Eigen::VectorXd::Zero(8), sq = Eigen::VectorXd::Zero(8);
  Eigen::VectorXd det;
  for (int i = 0; i < n; ++i) {
    const Eigen::VectorXd a = expert.Act(ob, env.goal_xy());
    det = expert.last_deterministic();
    const Eigen::VectorXd e = expert.last_unclipped() - det;
    sum += e;
    sq += e.cwiseProduct(e);
    for (int k = 0; k < 8; ++k) {
      EXPECT_GE(a[k], -1.0);
      EXPECT_LE(a[k], 1.0);
      EXPECT_EQ(a[k], std::clamp(expert.last_unclipped()[k], -1.0, 1.0));
    }
  }
  const std::vector<float> direct = policy_->Act(expert.last_input());
  for (int k = 0; k < 8; ++k) {
    EXPECT_EQ(det[k], static_cast<double>(direct[k]));
    const double mean = sum[k] / n, sd = std::sqrt(sq[k] / n - mean * mean);
    EXPECT_NEAR(mean, 0.0, 0.015) << k;  // 4.7 standard errors
    EXPECT_NEAR(sd, 0.2, 0.01) << k;
  }
  // Seeded: the same seed repeats the noise, another seed does not.
  AntWaypointExpert a1(*policy_, env.map(), 0.2, 7), a2(*policy_, env.map(), 0.2, 7),
      a3(*policy_, env.map(), 0.2, 8);
  const Eigen::VectorXd x1 = a1.Act(ob, env.goal_xy()), x2 = a2.Act(ob, env.goal_xy()),
                        x3 = a3.Act(ob, env.goal_xy());
  EXPECT_EQ(x1, x2);
  EXPECT_NE(x1, x3);
}

TEST_F(AntExpertTest, NavigateEpisodeHasTheLayoutAndIsSeeded) {
  sim::AntMaze& env = Medium();
  AntCollectOptions o;
  o.episode_length = 30;
  o.seed = 4;
  const AntEpisode ep = CollectAntEpisode(env, *policy_, o, 1);
  EXPECT_EQ(ep.length, 30);
  EXPECT_EQ(ep.seed, sim::EpisodeSeed(4, 1));
  ASSERT_EQ(ep.observations.size(), 30u * 29);
  ASSERT_EQ(ep.actions.size(), 30u * 8);
  ASSERT_EQ(ep.qpos.size(), 30u * 15);
  ASSERT_EQ(ep.qvel.size(), 30u * 14);
  for (float a : ep.actions) {
    EXPECT_GE(a, -1.0f);
    EXPECT_LE(a, 1.0f);
  }
  for (size_t t = 0; t < 30; ++t) {
    for (size_t k = 0; k < 15; ++k)
      EXPECT_EQ(ep.observations[t * 29 + k], static_cast<float>(ep.qpos[t * 15 + k]));
    for (size_t k = 0; k < 14; ++k)
      EXPECT_EQ(ep.observations[t * 29 + 15 + k], static_cast<float>(ep.qvel[t * 14 + k]));
  }
  // The rows move: the actions were stepped.
  EXPECT_NE(ep.observations[2], ep.observations[29 * 29 + 2]);
  // The start in a free cell, the goal a vertex cell, the goal state the env's.
  const sim::MazeMap& map = env.map();
  EXPECT_FALSE(map.IsWall(ep.start_cell));
  EXPECT_TRUE(IsVertex(map, ep.goal_cell));
  const Eigen::Vector2d start(ep.observations[0], ep.observations[1]);
  EXPECT_EQ(sim::AntPlanner::XYToCell(start), ep.start_cell);
  ASSERT_EQ(ep.goal.size(), 29);
  EXPECT_EQ(sim::AntPlanner::XYToCell(ep.goal.head<2>()), ep.goal_cell);
  ASSERT_EQ(ep.goal_rows.size(), 1u);  // an untrained expert does not get there in 3 s
  EXPECT_EQ(ep.goal_xys[0], ep.goal.head<2>());
  // A function of (seed, index): again equal, another index differs.
  const AntEpisode again = CollectAntEpisode(env, *policy_, o, 1);
  EXPECT_EQ(again.observations, ep.observations);
  EXPECT_EQ(again.actions, ep.actions);
  const AntEpisode other = CollectAntEpisode(env, *policy_, o, 2);
  EXPECT_NE(other.observations, ep.observations);
}

TEST_F(AntExpertTest, NavigateDrawsANewVertexGoalWhenTheGoalIsReached) {
  // A success radius that every state meets: a new goal after every step.
  sim::AntMazeOptions eo;
  eo.success_radius = 1000.0;
  sim::AntMaze env(eo);
  AntCollectOptions o;
  o.episode_length = 6;
  const AntEpisode ep = CollectAntEpisode(env, *policy_, o, 0);
  ASSERT_EQ(ep.goal_rows.size(), 6u);  // the first, then one after each of the 5 steps
  for (size_t g = 0; g < ep.goal_rows.size(); ++g) {
    EXPECT_EQ(ep.goal_rows[g], static_cast<int>(g));
    EXPECT_TRUE(IsVertex(env.map(), ep.goal_cells[g]));
    EXPECT_EQ(sim::AntPlanner::XYToCell(ep.goal_xys[g]), ep.goal_cells[g]);
    EXPECT_LE((ep.goal_xys[g] - env.map().CellCenter(ep.goal_cells[g])).cwiseAbs().maxCoeff(), 1.0);
  }
  // stitch keeps its one goal
  o.kind = sim::DatasetKind::kStitch;
  EXPECT_EQ(CollectAntEpisode(env, *policy_, o, 0).goal_rows.size(), 1u);
}

TEST_F(AntExpertTest, StitchGoalIsExactlyFourBfsMovesAway) {
  for (const char* name : {"medium", "large"}) {
    const sim::MazeMap map = sim::MazeMap::FromName(name);
    std::mt19937_64 rng(3);
    int with_goal = 0;
    for (const sim::Cell& c : map.FreeCells()) {
      bool any = false;  // OGBench falls back to the start cell when no cell is 4 away
      for (const sim::Cell& d : map.FreeCells()) any = any || map.BfsDistance(c, d) == 4;
      const sim::Cell g = StitchGoalCell(map, c, rng);
      EXPECT_EQ(map.BfsDistance(c, g), any ? 4 : 0) << name << " (" << c.i << "," << c.j << ")";
      with_goal += any;
    }
    EXPECT_GT(with_goal, static_cast<int>(map.FreeCells().size()) / 2) << name;
  }
  sim::AntMaze& env = Medium();
  AntCollectOptions o;
  o.kind = sim::DatasetKind::kStitch;
  o.episode_length = 3;
  for (uint64_t k = 0; k < 8; ++k) {
    const AntEpisode ep = CollectAntEpisode(env, *policy_, o, k);
    EXPECT_EQ(env.map().BfsDistance(ep.start_cell, ep.goal_cell), 4) << k;
    const Eigen::Vector2d start(ep.observations[0], ep.observations[1]);
    EXPECT_EQ(env.map().BfsDistance(sim::AntPlanner::XYToCell(start),
                                    sim::AntPlanner::XYToCell(ep.goal.head<2>())),
              4)
        << k;
  }
}

TEST_F(AntExpertTest, NpzHoldsOgbenchKeysWithQposAndQvel) {
  sim::AntMaze& env = Medium();
  AntCollectOptions o;
  o.episode_length = 5;
  const AntEpisode e0 = CollectAntEpisode(env, *policy_, o, 0);
  const AntEpisode e1 = CollectAntEpisode(env, *policy_, o, 1);
  const std::string path = dir_ + "/ant.npz";
  SaveAntNpz({&e0, &e1}, path);
  std::vector<std::string> keys = core::ListNpzKeys(path);
  std::sort(keys.begin(), keys.end());
  EXPECT_EQ(keys,
            (std::vector<std::string>{"actions", "observations", "qpos", "qvel", "terminals"}));
  core::NpyInfo info;
  const std::vector<float> qpos = core::ReadNpzFloat(path, "qpos", &info);
  EXPECT_EQ(info.shape, (std::vector<int64_t>{10, 15}));
  EXPECT_EQ(info.descr, "<f4");
  const std::vector<float> qvel = core::ReadNpzFloat(path, "qvel", &info);
  EXPECT_EQ(info.shape, (std::vector<int64_t>{10, 14}));
  const core::Dataset d = core::LoadNpzDataset(path);
  ASSERT_EQ(d.size(), 10);
  EXPECT_EQ(d.obs_dim(), 29);
  EXPECT_EQ(d.action_dim(), 8);
  const std::vector<uint8_t> term = d.terminals();
  EXPECT_EQ(term, (std::vector<uint8_t>{0, 0, 0, 0, 1, 0, 0, 0, 0, 1}));
  for (int t = 0; t < 5; ++t) {
    for (int k = 0; k < 15; ++k) EXPECT_EQ(qpos[t * 15 + k], e0.observations[t * 29 + k]);
    for (int k = 0; k < 14; ++k)
      EXPECT_EQ(qvel[(t + 5) * 14 + k], e1.observations[t * 29 + 15 + k]);
  }
}

TEST_F(AntExpertTest, EvaluationCountsStepsAndSpeed) {
  AntExpertEvalOptions o;
  o.tasks = {1, 3};
  o.episodes = 2;
  o.max_steps = 15;
  int calls = 0;
  o.on_episode = [&](int, int, bool, int steps) {
    ++calls;
    EXPECT_EQ(steps, 15);
  };
  const AntExpertEvalResult r = EvaluateAntExpert(*policy_, o);
  EXPECT_EQ(calls, 4);
  EXPECT_EQ(r.steps, 60);
  EXPECT_EQ(r.tasks, (std::vector<int>{1, 3}));
  ASSERT_EQ(r.speed.size(), 2u);
  EXPECT_GT(r.mean_speed, 0.0);
  EXPECT_LT(r.mean_speed, 10.0);
  EXPECT_EQ(r.mean_success, 0.0);
  o.tasks = {6};
  EXPECT_THROW(EvaluateAntExpert(*policy_, o), std::invalid_argument);
}

// The shipped expert (msspr_sim/experts/ant_xy_expert.pt) with the planner,
// noise-free, reaches the goals of antmaze-medium's five tasks (92% over 5 x 50
// episodes when it was shipped; here 2 episodes each).
TEST(ShippedAntExpert, ReachesAntmazeMediumGoals) {
  core::SacPolicy policy(sim::DefaultAntExpert());
  AntExpertEvalOptions o;
  o.episodes = 2;
  const AntExpertEvalResult r = EvaluateAntExpert(policy, o);
  EXPECT_GE(r.mean_success, 0.8) << "mean success over 5 tasks x 2 episodes";
  EXPECT_GT(r.mean_speed, 0.8) << "m/s";
}

}  // namespace
}  // namespace msspr::agent
