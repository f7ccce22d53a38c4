#include "msspr_sim/puzzle_env.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "cube_test_util.h"
#include "msspr_sim/puzzle_dataset.h"
#include "msspr_sim/puzzle_oracle.h"

namespace msspr::sim {
namespace {

PuzzleEnvOptions PuzzleOptions(int side) {
  PuzzleEnvOptions o;
  o.urdf_path = testing_util::ArmUrdfPath();
  o.side = side;
  return o;
}

// Runs the task oracle until success or the episode cap; returns whether it succeeded.
bool SolveWithOracle(PuzzleEnv& env, uint64_t seed, int* steps = nullptr) {
  PuzzleTaskOracle oracle(seed);
  while (!env.EpisodeOver()) env.Step(oracle.Act(env));
  if (steps != nullptr) *steps = env.episode_steps();
  return env.Success();
}

TEST(PuzzleEnvTest, ObservationAndStateSizesFollowTheSide) {
  for (const int side : {3, 4}) {
    PuzzleEnv env(PuzzleOptions(side));
    const int n = side * side;
    EXPECT_EQ(env.num_buttons(), n);
    EXPECT_EQ(env.observation_size(), side == 3 ? 55 : 83);
    const PuzzleEnv::Observation o = env.ResetToTask(1, 0);
    ASSERT_EQ(static_cast<int>(o.size()), env.observation_size());
    // 6 arm joints, 2 finger joints, one slide per button.
    EXPECT_EQ(static_cast<int>(env.Qpos().size()), 8 + n);
    for (int k = 0; k < n; ++k) {
      const float* b = o.data() + 19 + 4 * k;
      const int state = env.button_states()[k];
      EXPECT_EQ(b[0], state == 0 ? 1.f : 0.f) << "button " << k;
      EXPECT_EQ(b[1], state == 0 ? 0.f : 1.f) << "button " << k;
      EXPECT_FLOAT_EQ(b[2], static_cast<float>(120 * env.ButtonJoint(k)));
    }
  }
}

TEST(PuzzleEnvTest, ButtonsSitOnTheGridAndRestUp) {
  PuzzleEnv env(PuzzleOptions(4));
  env.ResetForCollection(3);
  for (int i = 0; i < 4; ++i) {
    for (int j = 0; j < 4; ++j) {
      const Eigen::Vector3d top = env.ButtonTop(4 * i + j);
      EXPECT_NEAR(top.x(), 0.275 + 0.1 * i, 1e-3);
      EXPECT_NEAR(top.y(), -0.15 + 0.1 * j, 1e-3);
      EXPECT_NEAR(top.z(), 0.1254, 1e-3);
    }
  }
  // Holding still, the spring keeps every button up and nothing toggles.
  const LightsOutState before = env.button_states();
  for (int t = 0; t < 20; ++t) env.Step({0, 0, 0, 0, 0});
  for (int k = 0; k < 16; ++k) EXPECT_GT(env.ButtonJoint(k), -0.002) << "button " << k;
  EXPECT_EQ(env.button_states(), before);
  EXPECT_EQ(env.presses(), 0);
}

TEST(PuzzleEnvTest, PressingTheCentreTogglesItsCrossOnly) {
  PuzzleEnv env(PuzzleOptions(3));
  env.ResetForCollection(0);
  env.SetButtonStates(env.board().Parse("000/000/000"));
  env.SetGoalStates(env.board().Parse("010/111/010"));
  int steps = 0;
  ASSERT_TRUE(SolveWithOracle(env, 1, &steps)) << env.board().Format(env.button_states());
  EXPECT_EQ(env.presses(), 1);
  EXPECT_LT(steps, 60);
}

TEST(PuzzleEnvTest, TaskResetsAreSeededAndSetTheTaskBoards) {
  PuzzleEnv a(PuzzleOptions(3)), b(PuzzleOptions(3));
  for (int task = 1; task <= 5; ++task) {
    const PuzzleEnv::Observation oa = a.ResetToTask(task, 7), ob = b.ResetToTask(task, 7);
    EXPECT_EQ(oa, ob) << "task " << task;
    EXPECT_EQ(a.goal_observation(), b.goal_observation()) << "task " << task;
    EXPECT_EQ(a.button_states(), PuzzleTasks(3)[task - 1].start);
    EXPECT_EQ(a.goal_states(), PuzzleTasks(3)[task - 1].goal);
    EXPECT_FALSE(a.Success());
    // The goal observation shows a closed gripper (its random steps close it).
    EXPECT_GT(a.goal_observation()[17], 1.0f) << "task " << task;
  }
  const PuzzleEnv::Observation other = b.ResetToTask(5, 8);
  EXPECT_NE(a.GetObservation(), other);  // another seed, another arm pose
  EXPECT_THROW(a.ResetToTask(6, 0), std::out_of_range);
}

TEST(PuzzleEnvTest, CollectionResetsDrawEveryBoardState) {
  PuzzleEnv env(PuzzleOptions(3));
  int ones = 0;
  for (uint64_t seed = 0; seed < 20; ++seed) {
    env.ResetForCollection(seed);
    for (uint8_t s : env.button_states()) ones += s;
    const Eigen::Vector3d p = env.PinchPosition();
    EXPECT_GE(p.z(), 0.19);
    EXPECT_LE(p.z(), 0.26);
  }
  EXPECT_GT(ones, 60);  // 180 draws of U{0, 1}
  EXPECT_LT(ones, 120);
}

TEST(PuzzleEnvTest, TaskOracleSolvesEveryThreeByThreeTask) {
  PuzzleEnv env(PuzzleOptions(3));
  for (int task = 1; task <= 5; ++task) {
    env.ResetToTask(task, 11);
    int steps = 0;
    EXPECT_TRUE(SolveWithOracle(env, 11, &steps))
        << "task " << task << ": " << env.board().Format(env.button_states()) << " after " << steps
        << " steps";
  }
}

TEST(PuzzleEnvTest, PlayOraclePressesRandomButtons) {
  PuzzleEnv env(PuzzleOptions(3));
  env.ResetForCollection(2);
  PuzzlePlayOracle oracle(2);
  std::vector<int> seen(9, 0);
  for (int t = 0; t < 800; ++t) {
    env.Step(oracle.Act(env));
    seen[oracle.target()] = 1;
  }
  // About 33 steps per plan, and every finished plan presses its button once (the press
  // keyframe is 3.5 cm below the top, the press counts at 2 cm).
  const int plans = oracle.cycles();
  EXPECT_GE(plans, 20);
  EXPECT_GE(env.presses(), 0.95 * (plans - 1)) << plans << " plans";
  EXPECT_LE(env.presses(), plans);
  int buttons = 0;
  for (int s : seen) buttons += s;
  EXPECT_GE(buttons, 6);  // uniform targets
}

TEST(PuzzleDatasetTest, EpisodesAreSeededAndReplayFromTheirStoredActions) {
  PuzzleEnv env(PuzzleOptions(4));
  PuzzleCollectOptions opt;
  opt.episode_length = 120;
  opt.seed = 5;
  const PlayEpisode a = CollectPuzzleEpisode(env, opt, 2), b = CollectPuzzleEpisode(env, opt, 2);
  ASSERT_EQ(a.observations.size(), 120u * 83);
  ASSERT_EQ(a.actions.size(), 120u * 5);
  ASSERT_EQ(a.qpos.size(), 120u * 24);
  EXPECT_EQ(a.observations, b.observations);
  EXPECT_EQ(a.actions, b.actions);
  EXPECT_NE(a.observations, CollectPuzzleEpisode(env, opt, 3).observations);
  // Replay: the same reset, the stored actions, the same rows.
  env.ResetForCollection(a.seed);
  for (int t = 0; t < a.length; ++t) {
    const PuzzleEnv::Observation o = env.GetObservation();
    ASSERT_TRUE(std::equal(o.begin(), o.end(), a.observations.begin() + 83 * t)) << "row " << t;
    PuzzleEnv::Action act;
    for (int i = 0; i < 5; ++i) act[i] = a.actions[5 * t + i];
    env.Step(act);
  }
  EXPECT_GT(env.presses(), 0);  // the oracle pressed buttons in 120 steps
}

TEST(PuzzleEnvTest, RejectsBadSidesAndBoards) {
  EXPECT_THROW(PuzzleEnv(PuzzleOptions(5)), std::invalid_argument);
  PuzzleEnv env(PuzzleOptions(3));
  EXPECT_THROW(env.SetButtonStates(LightsOutState(4, 0)), std::invalid_argument);
  EXPECT_THROW(env.SetGoalStates(LightsOutState(9, 2)), std::invalid_argument);
}

}  // namespace
}  // namespace msspr::sim
