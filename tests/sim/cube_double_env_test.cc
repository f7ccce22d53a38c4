#include "msspr_sim/cube_double_env.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "cube_test_util.h"
#include "msspr_sim/cube_double_oracle.h"

namespace msspr::sim {
namespace {

CubeDoubleEnvOptions CubeDoubleOptions() {
  CubeDoubleEnvOptions o;
  o.urdf_path = testing_util::ArmUrdfPath();
  return o;
}

TEST(CubeDoubleEnvTest, ObservationLayout) {
  CubeDoubleEnv env(CubeDoubleOptions());
  const CubeDoubleEnv::Observation o = env.ResetToTask(2, 3);
  ASSERT_EQ(o.size(), 37u);
  EXPECT_EQ(env.Qpos().size(), 8u + 14u);  // arm 6, fingers 2, two free joints
  for (int i = 0; i < 2; ++i) {
    const Eigen::Vector3d p = env.CubePosition(i);
    const float* c = o.data() + 19 + 9 * i;
    EXPECT_NEAR(c[0], 10 * (p.x() - 0.425), 1e-5);
    EXPECT_NEAR(c[1], 10 * p.y(), 1e-5);
    EXPECT_NEAR(c[2], 10 * p.z(), 1e-5);
    EXPECT_NEAR(std::atan2(c[8], c[7]), env.CubeYaw(i), 1e-5);
  }
}

TEST(CubeDoubleEnvTest, TaskResetsPermuteTheRowsOverTheCubes) {
  CubeDoubleEnv env(CubeDoubleOptions());
  const CubeDoubleTask& t = CubeDoubleTasks()[3];  // swap
  int swapped = 0;
  for (uint64_t seed = 0; seed < 20; ++seed) {
    env.ResetToTask(4, seed);
    // Cube 0 got row A or row B; its goal is that row's, its start within 1 cm of it.
    const int row = (env.GoalPosition(0) - t.goal[0]).norm() < 1e-9 ? 0 : 1;
    swapped += row;
    EXPECT_LT((env.GoalPosition(0) - t.goal[row]).norm(), 1e-9);
    EXPECT_LT((env.GoalPosition(1) - t.goal[1 - row]).norm(), 1e-9);
    EXPECT_LE((env.CubePosition(0) - t.start[row]).head<2>().cwiseAbs().maxCoeff(), 0.0101);
    EXPECT_LE((env.CubePosition(1) - t.start[1 - row]).head<2>().cwiseAbs().maxCoeff(), 0.0101);
    EXPECT_FALSE(env.Success());
  }
  EXPECT_GT(swapped, 3);  // both orders occur
  EXPECT_LT(swapped, 17);
  CubeDoubleEnv other(CubeDoubleOptions());
  EXPECT_EQ(env.ResetToTask(5, 9), other.ResetToTask(5, 9));
  EXPECT_EQ(env.goal_observation(), other.goal_observation());
  EXPECT_THROW(env.ResetToTask(0, 0), std::out_of_range);
}

TEST(CubeDoubleEnvTest, SuccessNeedsBothCubesAtTheirOwnGoals) {
  CubeDoubleEnv env(CubeDoubleOptions());
  env.ResetToTask(4, 1);
  const Eigen::Vector3d g0 = env.GoalPosition(0), g1 = env.GoalPosition(1);
  env.SetCube(0, g1, 0);  // each cube at the other's goal: not a success
  env.SetCube(1, g0, 0);
  EXPECT_FALSE(env.Success());
  env.SetCube(0, g0 + Eigen::Vector3d(0.03, 0, 0), 0);
  env.SetCube(1, g1, 0);
  EXPECT_TRUE(env.Success());
  env.SetCube(0, g0 + Eigen::Vector3d(0.05, 0, 0), 0);
  EXPECT_FALSE(env.Success());
}

TEST(CubeDoubleEnvTest, NewTargetsStackOnlyOnTopCubes) {
  CubeDoubleEnv env(CubeDoubleOptions());
  env.ResetForCollection(0);
  env.SetCube(0, Eigen::Vector3d(0.40, 0.0, 0.02), 0);
  env.SetCube(1, Eigen::Vector3d(0.40, 0.005, 0.06), 0);  // cube 1 on cube 0
  EXPECT_FALSE(env.IsTop(0));
  EXPECT_TRUE(env.IsTop(1));
  std::mt19937_64 rng(3);
  for (int k = 0; k < 10; ++k) {
    EXPECT_EQ(env.SetNewTarget(rng, 1.0), 1);  // only cube 1 may move
    EXPECT_NEAR(env.GoalPosition(1).z(), 0.02, 1e-12);
    EXPECT_NEAR(env.GoalPosition(0).z(), -0.3, 1e-12);  // parked
  }
  env.SetCube(1, Eigen::Vector3d(0.50, 0.1, 0.02), 0);
  const int target = env.SetNewTarget(rng, 1.0);  // p_stack 1: on the other cube
  EXPECT_LT(
      (env.GoalPosition(target) - (env.CubePosition(1 - target) + Eigen::Vector3d(0, 0, 0.04)))
          .norm(),
      1e-9);
}

TEST(CubeDoubleEnvTest, TaskOracleSolvesEveryTask) {
  CubeDoubleEnv env(CubeDoubleOptions());
  for (int task = 1; task <= 5; ++task) {
    env.ResetToTask(task, 21);
    CubeDoubleTaskOracle oracle(21);
    while (!env.EpisodeOver()) env.Step(oracle.Act(env));
    EXPECT_TRUE(env.Success()) << "task " << task << " after " << env.episode_steps() << " steps";
  }
}

TEST(CubeDoubleDatasetTest, EpisodesAreSeededAndReplay) {
  CubeDoubleEnv env(CubeDoubleOptions());
  CubeDoubleCollectOptions opt;
  opt.episode_length = 150;
  opt.seed = 2;
  const PlayEpisode a = CollectCubeDoubleEpisode(env, opt, 1);
  const PlayEpisode b = CollectCubeDoubleEpisode(env, opt, 1);
  ASSERT_EQ(a.observations.size(), 150u * 37);
  EXPECT_EQ(a.observations, b.observations);
  EXPECT_EQ(a.actions, b.actions);
  env.ResetForCollection(a.seed);
  for (int t = 0; t < a.length; ++t) {
    const CubeDoubleEnv::Observation o = env.GetObservation();
    ASSERT_TRUE(std::equal(o.begin(), o.end(), a.observations.begin() + 37 * t)) << "row " << t;
    CubeDoubleEnv::Action act;
    for (int i = 0; i < 5; ++i) act[i] = a.actions[5 * t + i];
    env.Step(act);
  }
  // The oracle moved a cube within 150 steps (one pick and place takes about 90).
  const float* first = a.observations.data() + 19;
  const float* last = a.observations.data() + 37 * 149 + 19;
  double moved = 0;
  for (int k : {0, 1, 2, 9, 10, 11}) moved += std::abs(last[k] - first[k]);
  EXPECT_GT(moved, 0.3);  // 3 cm
}

}  // namespace
}  // namespace msspr::sim
