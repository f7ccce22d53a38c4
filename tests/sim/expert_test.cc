#include "msspr_sim/expert.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <set>
#include <stdexcept>

#include "msspr_sim/point_maze.h"

namespace msspr::sim {
namespace {

TEST(ExpertTest, EpisodeSeedMixes) {
  EXPECT_EQ(EpisodeSeed(0, 0), EpisodeSeed(0, 0));
  std::set<uint64_t> seen;
  for (uint64_t base = 0; base < 10; ++base) {
    for (uint64_t k = 0; k < 100; ++k) seen.insert(EpisodeSeed(base, k));
  }
  EXPECT_EQ(seen.size(), 1000u);
}

TEST(ExpertTest, ParseDatasetKind) {
  EXPECT_EQ(ParseDatasetKind("navigate"), DatasetKind::kNavigate);
  EXPECT_EQ(ParseDatasetKind("stitch"), DatasetKind::kStitch);
  EXPECT_THROW(ParseDatasetKind("explore"), std::invalid_argument);
  EXPECT_EQ(DatasetKindName(DatasetKind::kStitch), "stitch");
}

TEST(ExpertTest, GoalExpertDirection) {
  const MazeMap m = MazeMap::FromName("medium");
  GoalExpert expert(m);
  // From (1,1) toward (1,2) (one step right): unit vector to (4, 0).
  Eigen::Vector2d a = expert.Act({0, 0}, m.CellCenter({1, 2}));
  EXPECT_NEAR(a.x(), 1.0, 1e-12);
  EXPECT_NEAR(a.y(), 0.0, 1e-12);
  // Inside the goal cell: toward the goal point itself.
  a = expert.Act({0, 0}, {0.3, 0.4});
  EXPECT_NEAR(a.x(), 0.6, 1e-12);
  EXPECT_NEAR(a.y(), 0.8, 1e-12);
  // Noisy expert stays in [-1, 1] and is seeded.
  GoalExpert n1(m, 0.5, 9), n2(m, 0.5, 9);
  for (int t = 0; t < 200; ++t) {
    const Eigen::Vector2d b = n1.Act({0, 0}, {12, 20});
    EXPECT_EQ(b, n2.Act({0, 0}, {12, 20}));
    EXPECT_LE(b.cwiseAbs().maxCoeff(), 1.0);
  }
}

// Noise-free GoalExpert success over `episodes` seeded episodes per task.
void ExpectExpertSucceeds(const std::string& maze, int episodes, double min_rate) {
  PointMazeOptions o;
  o.maze = maze;
  PointMaze env(o);
  GoalExpert expert(env.map());
  for (const MazeMap::Task& task : env.map().Tasks()) {
    int successes = 0, total_steps = 0;
    for (int e = 0; e < episodes; ++e) {
      Eigen::Vector2d s = env.ResetToTask(task.id, 1000 * task.id + e);
      bool ok = env.success();
      for (int t = 0; t < 1000 && !ok; ++t) {
        s = env.Step(expert.Act(s, env.goal()));
        ok = env.success();
      }
      successes += ok;
      total_steps += env.steps();
    }
    const double rate = static_cast<double>(successes) / episodes;
    std::printf("[ INFO ] GoalExpert %s task %d: success %d/%d (%.0f%%), mean steps %.1f\n",
                maze.c_str(), task.id, successes, episodes, 100 * rate,
                static_cast<double>(total_steps) / episodes);
    EXPECT_GE(rate, min_rate) << maze << " task " << task.id;
  }
}

TEST(ExpertTest, GoalExpertSolvesMediumTasks) { ExpectExpertSucceeds("medium", 20, 0.95); }
TEST(ExpertTest, GoalExpertSolvesLargeTasks) { ExpectExpertSucceeds("large", 20, 0.95); }
TEST(ExpertTest, GoalExpertSolvesGiantAndArenaTasks) {
  ExpectExpertSucceeds("giant", 10, 0.95);
  ExpectExpertSucceeds("arena", 10, 0.95);
}

TEST(ExpertTest, NavigateRedrawsVertexGoals) {
  PointMazeOptions o;
  PointMaze env(o);
  const MazeMap& m = env.map();
  const std::vector<Cell> vertices = m.VertexCells();
  for (const double noise : {0.0, 0.5}) {
    Eigen::Vector2d s = env.ResetRandom(EpisodeSeed(3, 0));
    CollectionExpert expert(m, DatasetKind::kNavigate, noise, EpisodeSeed(3, 0));
    std::set<std::pair<int, int>> goals;
    Cell previous_goal{-1, -1};
    int previous_count = 0;
    for (int t = 0; t < 1001; ++t) {
      const Eigen::Vector2d a = expert.Act(s);
      ASSERT_LE(a.cwiseAbs().maxCoeff(), 1.0);
      if (expert.num_goals() != previous_count) {
        // A new goal only when the old one was reached (within 1 m of its centre).
        ASSERT_EQ(expert.num_goals(), previous_count + 1);
        if (previous_count > 0) {
          ASSERT_LE((s - m.CellCenter(previous_goal)).norm(), 1.0);
        }
        previous_count = expert.num_goals();
      }
      previous_goal = expert.goal_cell();
      ASSERT_NE(std::find(vertices.begin(), vertices.end(), expert.goal_cell()), vertices.end());
      goals.insert({expert.goal_cell().i, expert.goal_cell().j});
      s = env.Step(a);
    }
    std::printf("[ INFO ] navigate noise %.1f: %d goals in 1001 steps\n", noise,
                expert.num_goals());
    EXPECT_GE(expert.num_goals(), 4) << "noise " << noise;
    EXPECT_GE(goals.size(), 3u);
  }
}

TEST(ExpertTest, StitchGoalIsFourBfsStepsAndTheExpertStays) {
  PointMazeOptions o;
  o.maze = "large";
  PointMaze env(o);
  const MazeMap& m = env.map();
  int arrived_eps = 0, near_after = 0, total_after = 0;
  for (uint64_t k = 0; k < 40; ++k) {
    const double noise = k % 2 ? 0.5 : 0.0;
    Eigen::Vector2d s = env.ResetRandom(EpisodeSeed(5, k));
    const Cell start = m.XYToCell(s);
    CollectionExpert expert(m, DatasetKind::kStitch, noise, EpisodeSeed(5, k));
    expert.Act(s);
    const Cell goal = expert.goal_cell();
    ASSERT_EQ(m.BfsDistance(start, goal), 4) << "episode " << k;
    bool arrived = false;
    for (int t = 0; t < 201; ++t) {
      const Eigen::Vector2d a = expert.Act(s);
      ASSERT_EQ(expert.goal_cell(), goal);
      ASSERT_EQ(expert.num_goals(), 1);
      s = env.Step(a);
      const double d = (s - m.CellCenter(goal)).norm();
      if (d <= 1.0) arrived = true;
      if (arrived) {
        ++total_after;
        near_after += d <= (noise > 0 ? 2.0 : 1.0);
        if (noise == 0.0) {
          ASSERT_LE(d, 1.0) << "left the goal at step " << t;
        }
      }
    }
    arrived_eps += arrived;
  }
  std::printf("[ INFO ] stitch: %d/40 episodes arrived; %.1f%% of steps after arrival near goal\n",
              arrived_eps, 100.0 * near_after / std::max(total_after, 1));
  EXPECT_GE(arrived_eps, 38);
  EXPECT_GE(near_after, 0.9 * total_after);
}

}  // namespace
}  // namespace msspr::sim
