#include "msspr_sim/point_maze.h"

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <stdexcept>
#include <thread>

namespace msspr::sim {
namespace {

// Distance from p to the nearest wall block (4 x 4 squares), including the
// blocks outside the map.
double DistanceToWalls(const MazeMap& m, const Eigen::Vector2d& p) {
  const Cell c = m.XYToCell(p);
  double best = std::numeric_limits<double>::infinity();
  for (int di = -2; di <= 2; ++di) {
    for (int dj = -2; dj <= 2; ++dj) {
      const Cell w{c.i + di, c.j + dj};
      if (!m.IsWall(w)) continue;
      const Eigen::Vector2d d =
          ((p - m.CellCenter(w)).cwiseAbs().array() - kCellSize / 2).cwiseMax(0.0).matrix();
      best = std::min(best, d.norm());
    }
  }
  return best;
}

PointMazeOptions PointOptions(const std::string& maze, bool render = false) {
  PointMazeOptions o;
  o.maze = maze;
  o.enable_rendering = render;
  return o;
}

TEST(PointMazeTest, OneStepMovesByPointTwoTimesActionInFreeSpace) {
  PointMaze env(PointOptions("medium"));
  env.Reset({0.1, -0.2}, {8, 8});
  const Eigen::Vector2d a(0.5, -0.3);
  const Eigen::Vector2d s = env.Step(a);
  EXPECT_NEAR(s.x(), 0.1 + 0.2 * 0.5, 1e-6);
  EXPECT_NEAR(s.y(), -0.2 - 0.2 * 0.3, 1e-6);
  EXPECT_EQ(env.steps(), 1);
  EXPECT_EQ(env.state(), s);
  // Clipping: (5, -5) acts as (1, -1).
  const Eigen::Vector2d s2 = env.Step({5, -5});
  EXPECT_NEAR(s2.x(), s.x() + 0.2, 1e-6);
  EXPECT_NEAR(s2.y(), s.y() - 0.2, 1e-6);
}

// The physics-only MJCF (no floor tiles, no unreachable wall blocks) steps
// like the full one.
TEST(PointMazeTest, PhysicsModelMatchesFullModel) {
  const MazeMap map = MazeMap::FromName("medium");
  const std::filesystem::path dir = MSSPR_TEST_TMPDIR;
  std::filesystem::create_directories(dir);
  mjModel* models[2];
  for (int v = 0; v < 2; ++v) {
    const std::string path = (dir / ("model_" + std::to_string(v) + ".xml")).string();
    std::ofstream(path) << map.ToMjcf(64, v == 1);
    char err[512] = {0};
    models[v] = mj_loadXML(path.c_str(), nullptr, err, sizeof(err));
    ASSERT_NE(models[v], nullptr) << err;
  }
  EXPECT_LT(models[0]->ngeom, models[1]->ngeom);
  mjData* data[2] = {mj_makeData(models[0]), mj_makeData(models[1])};
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  double max_diff = 0;
  for (int t = 0; t < 3000; ++t) {
    const double a[2] = {u(rng), u(rng)};
    for (int v = 0; v < 2; ++v) {
      for (int k = 0; k < 2; ++k) {
        data[v]->qpos[k] += 0.2 * a[k];
        data[v]->qvel[k] = 0;
      }
      for (int s = 0; s < 5; ++s) mj_step(models[v], data[v]);
    }
    for (int k = 0; k < 2; ++k) {
      max_diff = std::max(max_diff, std::abs(data[0]->qpos[k] - data[1]->qpos[k]));
    }
  }
  EXPECT_LT(max_diff, 1e-9);
  for (int v = 0; v < 2; ++v) {
    mj_deleteData(data[v]);
    mj_deleteModel(models[v]);
  }
}

TEST(PointMazeTest, NonFiniteActionThrows) {
  PointMaze env(PointOptions("medium"));
  env.Reset({0, 0}, {4, 4});
  EXPECT_THROW(env.Step({std::nan(""), 0}), std::invalid_argument);
  EXPECT_THROW(env.Step({0, std::numeric_limits<double>::infinity()}), std::invalid_argument);
  EXPECT_EQ(env.steps(), 0);
}

TEST(PointMazeTest, WallsStopTheAgent) {
  PointMaze env(PointOptions("medium"));
  // Cell (1,1) at the origin: wall (1,0) spans x <= -2, wall (0,1) y <= -2.
  env.Reset({0, 0}, {8, 8});
  double min_x = 0;
  for (int t = 0; t < 60; ++t) min_x = std::min(min_x, env.Step({-1, 0}).x());
  const double rest_x = env.state().x();
  EXPECT_GT(min_x, -2.0 + kAgentRadius - 0.25) << "penetrated the wall";
  EXPECT_NEAR(rest_x, -2.0 + kAgentRadius, 0.25);
  EXPECT_NEAR(env.state().y(), 0.0, 1e-6);  // no sideways drift
  // Moving diagonally into the corner.
  for (int t = 0; t < 60; ++t) env.Step({-1, -1});
  EXPECT_GT(env.state().y(), -2.0 + kAgentRadius - 0.25);
  EXPECT_GT(env.state().x(), -2.0 + kAgentRadius - 0.25);
  // And it can leave again.
  for (int t = 0; t < 10; ++t) env.Step({1, 1});
  EXPECT_GT(env.state().x(), 0.5);
  RecordProperty("rest_x", std::to_string(rest_x));
}

TEST(PointMazeTest, NeverInsideAWallOver100kRandomSteps) {
  for (const std::string maze : {"medium", "large"}) {
    PointMaze env(PointOptions(maze));
    std::mt19937_64 rng(7);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    env.ResetRandom(1);
    double min_clearance = 1e9;
    const int n = maze == std::string("medium") ? 60000 : 40000;
    for (int t = 0; t < n; ++t) {
      if (t % 2000 == 1999) env.ResetRandom(t);
      // Bias toward long pushes so the agent spends time against walls.
      const Eigen::Vector2d a = (t / 50) % 2 ? Eigen::Vector2d(u(rng), u(rng))
                                             : Eigen::Vector2d(u(rng) > 0 ? 1 : -1, u(rng));
      const Eigen::Vector2d s = env.Step(a);
      ASSERT_FALSE(env.map().IsWall(env.map().XYToCell(s))) << maze << " step " << t;
      const double clearance = DistanceToWalls(env.map(), s);
      min_clearance = std::min(min_clearance, clearance);
      ASSERT_GT(clearance, kAgentRadius - 0.3) << maze << " step " << t << " at " << s.transpose();
    }
    std::printf("[ INFO ] %s: min clearance from walls %.4f (radius %.1f)\n", maze.c_str(),
                min_clearance, kAgentRadius);
  }
}

TEST(PointMazeTest, ResetToTaskIsSeededAndNoisy) {
  PointMaze env(PointOptions("large"));
  for (const MazeMap::Task& task : env.map().Tasks()) {
    const Eigen::Vector2d s1 = env.ResetToTask(task.id, 11);
    const Eigen::Vector2d g1 = env.goal();
    EXPECT_EQ(env.steps(), 0);
    const Eigen::Vector2d s2 = env.ResetToTask(task.id, 11);
    EXPECT_EQ(s1, s2);
    EXPECT_EQ(g1, env.goal());
    EXPECT_LE((s1 - env.map().CellCenter(task.start)).cwiseAbs().maxCoeff(), 1.1);
    EXPECT_LE((g1 - env.map().CellCenter(task.goal)).cwiseAbs().maxCoeff(), 1.0);
    const Eigen::Vector2d s3 = env.ResetToTask(task.id, 12);
    EXPECT_NE(s1, s3);
  }
  EXPECT_THROW(env.ResetToTask(0, 1), std::invalid_argument);
  EXPECT_THROW(env.ResetToTask(6, 1), std::invalid_argument);
}

TEST(PointMazeTest, ResetRandomIsSeeded) {
  PointMaze env(PointOptions("medium"));
  const MazeMap& m = env.map();
  const std::vector<Cell> vertices = m.VertexCells();
  for (uint64_t seed = 0; seed < 50; ++seed) {
    const Eigen::Vector2d s = env.ResetRandom(seed);
    const Eigen::Vector2d g = env.goal();
    EXPECT_EQ(s, env.ResetRandom(seed));
    EXPECT_EQ(g, env.goal());
    EXPECT_FALSE(m.IsWall(m.XYToCell(s)));
    EXPECT_NE(std::find(vertices.begin(), vertices.end(), m.XYToCell(g)), vertices.end());
    EXPECT_GT(DistanceToWalls(m, s), kAgentRadius - 1e-9);
  }
}

TEST(PointMazeTest, SuccessRadius) {
  PointMaze env(PointOptions("medium"));
  env.Reset({0, 0}, {0.99, 0});
  EXPECT_TRUE(env.success());
  env.SetGoal({1.01, 0});
  EXPECT_FALSE(env.success());
  EXPECT_EQ(env.goal(), Eigen::Vector2d(1.01, 0));
}

TEST(PointMazeTest, BadOptionsThrow) {
  EXPECT_THROW(PointMaze(PointOptions("nope")), std::invalid_argument);
  PointMazeOptions o = PointOptions("medium");
  o.image_size = 0;
  EXPECT_THROW(PointMaze{o}, std::invalid_argument);
  PointMaze env(PointOptions("medium"));
  EXPECT_THROW(env.Render(), std::logic_error);
}

double Variance(const std::vector<uint8_t>& img) {
  double mean = 0, sq = 0;
  for (uint8_t v : img) mean += v;
  mean /= img.size();
  for (uint8_t v : img) sq += (v - mean) * (v - mean);
  return sq / img.size();
}

TEST(PointMazeRenderTest, ImagesAreDeterministicNotBlankAndShowTheGoal) {
  PointMaze env(PointOptions("medium", true));
  env.ResetToTask(1, 3);
  const Eigen::Vector2d s = env.state();
  const std::vector<uint8_t> a = env.Render();
  ASSERT_EQ(a.size(), 64u * 64u * 3u);
  EXPECT_GT(Variance(a), 100.0);
  EXPECT_EQ(a, env.Render());
  const std::vector<uint8_t> g = env.RenderGoal();
  EXPECT_NE(a, g);
  EXPECT_GT(Variance(g), 100.0);
  EXPECT_EQ(env.state(), s);  // RenderAt restores the state
  EXPECT_EQ(a, env.Render());
  EXPECT_EQ(g, env.RenderAt(env.goal()));
  // The goal image equals a render with the agent at the goal.
  PointMaze other(PointOptions("medium", true));
  other.Reset(env.goal(), env.goal());
  EXPECT_EQ(other.Render(), g);
  // Rendering never changes the physics.
  PointMaze plain(PointOptions("medium"));
  plain.ResetToTask(1, 3);
  for (int t = 0; t < 100; ++t) {
    const Eigen::Vector2d act(std::sin(0.3 * t), std::cos(0.7 * t));
    env.Render();
    ASSERT_EQ(env.Step(act), plain.Step(act));
  }
}

TEST(PointMazeRenderTest, FloorGradientEncodesPosition) {
  // Renders at nearby positions in the same open area differ, and the top
  // half of the image (floor ahead of the agent) gets redder moving +x.
  PointMaze env(PointOptions("arena", true));
  env.Reset({4, 4}, {0, 0});
  const std::vector<uint8_t> a = env.RenderAt({8, 8});
  const std::vector<uint8_t> b = env.RenderAt({12, 8});
  EXPECT_NE(a, b);
  double red_a = 0, red_b = 0;
  for (size_t p = 0; p < a.size(); p += 3) red_a += a[p], red_b += b[p];
  EXPECT_GT(red_b, red_a);
}

TEST(PointMazeRenderTest, EveryMazeBuildsAndRenders) {
  for (const std::string& name : MazeMap::Names()) {
    PointMaze env(PointOptions(name, true));
    for (const MazeMap::Task& task : env.map().Tasks()) {
      env.ResetToTask(task.id, 1);
      EXPECT_GT(Variance(env.Render()), 100.0) << name << " task " << task.id;
    }
  }
}

TEST(PointMazeRenderTest, OtherImageSizes) {
  PointMazeOptions o = PointOptions("large", true);
  o.image_size = 32;
  PointMaze env(o);
  env.ResetRandom(4);
  std::vector<uint8_t> img(32 * 32 * 3);
  env.Render(img.data());
  EXPECT_GT(Variance(img), 50.0);
}

TEST(PointMazeRenderTest, RendersFromOtherThreads) {
  // Constructed here, rendered in a worker, then here again; plus two
  // threads each with their own env at the same time.
  PointMaze env(PointOptions("medium", true));
  env.ResetToTask(2, 5);
  const std::vector<uint8_t> here = env.Render();
  std::vector<uint8_t> worker;
  std::thread([&] { worker = env.Render(); }).join();
  EXPECT_EQ(worker, here);
  EXPECT_EQ(env.Render(), here);
  std::vector<uint8_t> a, b;
  std::thread ta([&] {
    PointMaze e(PointOptions("medium", true));
    e.ResetToTask(2, 5);
    for (int k = 0; k < 20; ++k) a = e.Render();
  });
  std::thread tb([&] {
    PointMaze e(PointOptions("medium", true));
    e.ResetToTask(2, 5);
    for (int k = 0; k < 20; ++k) b = e.Render();
  });
  ta.join();
  tb.join();
  EXPECT_EQ(a, here);
  EXPECT_EQ(b, here);
}

}  // namespace
}  // namespace msspr::sim
