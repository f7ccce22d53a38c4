// The agent's ROS layer without a master: bags into the core dataset, the
// in-process evaluator, and msspr_train killed mid-run and resumed.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <signal.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "bag_dataset.h"
#include "msspr/Action.h"
#include "msspr/EpisodeInfo.h"
#include "msspr/Observation.h"
#include "msspr_bags/dataset_bag.h"
#include "msspr_core/checkpoint.h"
#include "msspr_core/npz.h"
#include "msspr_core/options.h"
#include "msspr_core/policy.h"
#include "msspr_core/trainer.h"
#include "msspr_eval/ant_evaluator.h"
#include "msspr_eval/arm_task_evaluator.h"
#include "msspr_eval/cube_evaluator.h"
#include "msspr_eval/maze_evaluator.h"
#include "msspr_sim/package_files.h"
#include "test_util.h"
#include "torch_test_util.h"

namespace msspr::agent {
namespace {

std::string Tmp(const std::string& name) {
  return "/tmp/msspr_agent_test_" + std::to_string(getpid()) + "_" + name;
}

bool Exists(const std::string& p) {
  struct stat st;
  return stat(p.c_str(), &st) == 0;
}

// A state policy after one step of the tiny trainer on two constant episodes (torch seeded 0):
// untrained, but of the given sizes.
core::Policy UntrainedStatePolicy(int obs_dim, int action_dim) {
  torch::manual_seed(0);
  core::DatasetBuilder b(obs_dim, action_dim);
  std::vector<float> obs(static_cast<size_t>(10 * obs_dim), 0.1f),
      act(static_cast<size_t>(10 * action_dim), 0.2f);
  b.AddEpisode(obs, act);
  b.AddEpisode(obs, act);
  core::Trainer trainer(core::testing_util::TinyOptions(),
                        std::make_shared<const core::Dataset>(b.Build()));
  trainer.Step();
  return trainer.MakePolicy();
}

// Writes one episode with the given steps missing from the observations.
void WriteEpisode(rosbag::Bag& bag, uint32_t id, const std::string& split, int n,
                  const std::vector<int>& missing, int obs_dim = 2) {
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
    if (std::find(missing.begin(), missing.end(), t) == missing.end())
      bag.write(ros_bridge::kObservationTopic, stamp, o);
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
    WriteEpisode(bag, 1, "train", 12, {5});  // -> runs [0,5) and [6,12)
    WriteEpisode(bag, 2, "val", 8, {});
    WriteEpisode(bag, 3, "train", 6, {1});  // -> [0,1) is too short, [2,6)
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
  EXPECT_THROW(LoadBagDataset({Tmp("missing.bag")}, BagLoadOptions{}, nullptr),
               ros_bridge::BagError);
  std::remove(a.c_str());
  std::remove(b.c_str());
}

TEST(BagDataset, SampleBagWithImages) {
  ros::Time::init();
  BagLoadOptions opt;
  opt.images = true;
  BagLoadReport report;
  const core::Dataset d = LoadBagDataset(
      {std::string(MSSPR_SOURCE_DIR) + "/rosbags/pointmaze-medium-navigate-pixels-sample.bag"}, opt,
      &report);
  EXPECT_TRUE(d.has_images());
  EXPECT_EQ(d.num_trajectories(), 4);
  EXPECT_EQ(d.size(), 4 * 201);
  EXPECT_TRUE(report.problems.empty());
}

TEST(MazeEvaluator, SameOutcomesTwiceAndFailuresRunToTheStepLimit) {
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

// An untrained cube-single policy (28-D states, 5-D actions): the evaluator's
// bookkeeping, determinism and errors (the trained agent's numbers are in the README).
TEST(CubeEvaluator, DeterministicAndChecksThePolicy) {
  core::Policy policy = UntrainedStatePolicy(28, 5);
  CubeEvalOptions opt;
  opt.tasks = {2, 5};
  opt.episodes = 2;
  opt.max_steps = 15;
  const auto a = EvaluateOnCube(policy, opt);
  const auto c = EvaluateOnCube(policy, opt);
  ASSERT_EQ(a.tasks, opt.tasks);
  ASSERT_EQ(a.success.size(), 2u);
  EXPECT_EQ(a.success, c.success);
  EXPECT_EQ(a.mean_steps_success, c.mean_steps_success);
  for (size_t t = 0; t < 2; ++t) {
    EXPECT_GE(a.success[t], 0.0);
    EXPECT_LE(a.success[t], 1.0);
    EXPECT_LE(a.mean_steps_success[t], 15.0);
  }
  const auto report = MakeCubeEvalReport(a, opt, "untrained");
  EXPECT_EQ(report.env, "cube-single");
  ASSERT_EQ(report.tasks.size(), 2u);
  EXPECT_EQ(report.tasks[1].task_id, 5);
  ASSERT_EQ(report.tasks[1].start.size(), 2u);  // task 5: cube from (0.35, 0.2) to (0.5, -0.2)
  EXPECT_NEAR(report.tasks[1].start[1], 0.2, 1e-9);
  EXPECT_NEAR(report.tasks[1].goal[1], -0.2, 1e-9);
  opt.tasks = {6};
  EXPECT_THROW(EvaluateOnCube(policy, opt), std::invalid_argument);
  auto maze_policy = core::Policy::Load(MSSPR_TEST_CHECKPOINT);  // 2-D: not a cube policy
  opt.tasks = {1};
  EXPECT_THROW(EvaluateOnCube(maze_policy, opt), std::invalid_argument);
}

// The evaluator records each episode's cube (sim::CubeEpisodeTracker), so that its failures
// are told apart: 10 steps of an untrained policy lift nothing, and the cube stays 15 cm away.
TEST(CubeEvaluator, RecordsHowEachEpisodesCubeEnded) {
  core::Policy policy = UntrainedStatePolicy(28, 5);
  CubeEvalOptions opt;
  opt.tasks = {2};  // the cube from (0.35, 0) to (0.5, 0): 15 cm
  opt.episodes = 2;
  opt.max_steps = 10;
  const auto r = EvaluateOnCube(policy, opt);
  const std::vector<sim::CubeOutcome> cubes = CubeOutcomes(r);
  ASSERT_EQ(cubes.size(), 2u);
  for (const auto& c : cubes) {
    EXPECT_FALSE(c.success);
    EXPECT_GE(c.lift, 0.0);
    EXPECT_LT(c.lift, 0.02);
    EXPECT_NEAR(c.goal_distance, 0.15, 0.02);
    EXPECT_NEAR(c.above_goal, 0.0, 0.01);  // the cube rests on the table like the goal
  }
  const sim::CubeFailures f = sim::CountCubeFailures(cubes);
  EXPECT_EQ(f.episodes, 2);
  EXPECT_EQ(f.failed, 2);
  EXPECT_EQ(f.never_lifted, 2);
  EXPECT_EQ(f.lifted_not_placed, 0);
}

// The goal-shift probe: a value per shift and variant, each the mean of the critic over the
// pairs and directions (a shift of 0 is the same in every direction), steps that stand for
// that value, the same values on a second call, and the policies it cannot probe.
TEST(CubeEvaluator, GoalShiftProbeValuesEachShiftAndChecksThePolicy) {
  core::Policy policy = UntrainedStatePolicy(28, 5);
  CubeGoalShiftOptions opt;
  opt.shifts_cm = {0.0, 5.0};
  opt.pairs_per_task = 2;
  opt.directions = 4;
  const auto a = ProbeCubeGoalShifts(policy, opt);
  EXPECT_EQ(a.samples, 5 * 2 * 4);
  EXPECT_EQ(a.gamma, policy.options().agent.gamma);
  for (const auto* v : {&a.same_arm, &a.other_arm, &a.carrying}) {
    ASSERT_EQ(v->mean.size(), 2u);
    ASSERT_EQ(v->sd.size(), 2u);
    ASSERT_EQ(v->steps.size(), 2u);
    EXPECT_NE(v->mean[0], v->mean[1]) << "moving the goal's cube changes the critic's input";
    for (size_t i = 0; i < 2; ++i) {
      ASSERT_TRUE(std::isfinite(v->mean[i]));
      EXPECT_GE(v->sd[i], 0.0);
      if (v->mean[i] < 0)  // V = -(1 - gamma^n) / (1 - gamma)
        EXPECT_NEAR(-(1 - std::pow(a.gamma, v->steps[i])) / (1 - a.gamma), v->mean[i], 1e-6);
      else
        EXPECT_EQ(v->steps[i], 0.0);
    }
  }
  EXPECT_TRUE(a.same_arm.steer.empty());
  ASSERT_EQ(a.carrying.steer.size(), 2u);  // carrying: the actor's steer toward the moved goal
  EXPECT_TRUE(std::isnan(a.carrying.steer[0]));
  EXPECT_GE(a.carrying.steer[1], -1.0);
  EXPECT_LE(a.carrying.steer[1], 1.0);
  const auto b = ProbeCubeGoalShifts(policy, opt);
  EXPECT_EQ(a.same_arm.mean, b.same_arm.mean);
  EXPECT_EQ(a.carrying.mean, b.carrying.mean);
  EXPECT_EQ(a.other_arm.mean, b.other_arm.mean);
  opt.directions = 1;  // unshifted goals are the same whatever the directions
  const auto c = ProbeCubeGoalShifts(policy, opt);
  EXPECT_NEAR(c.same_arm.mean[0], a.same_arm.mean[0], 1e-5);
  EXPECT_NEAR(c.other_arm.mean[0], a.other_arm.mean[0], 1e-5);
  opt.shifts_cm = {-1.0};
  EXPECT_THROW(ProbeCubeGoalShifts(policy, opt), std::invalid_argument);
  opt.shifts_cm = {0.0};
  auto maze_policy = core::Policy::Load(MSSPR_TEST_CHECKPOINT);  // 2-D states
  EXPECT_THROW(ProbeCubeGoalShifts(maze_policy, opt), std::invalid_argument);
}

// The probe's carrying state: the cube grasped and held 5 cm above the goal it rested on.
TEST(CubeEvaluator, CarryOverGoalHoldsTheCubeAboveTheGoal) {
  sim::CubeEnvOptions eo;
  eo.urdf_path = sim::DefaultArmUrdf();
  sim::CubeEnv env(eo);
  for (int task = 1; task <= 5; ++task) {
    const sim::CubeEnv::Observation o = CarryOverGoal(env, task, 11);
    const Eigen::Vector3d cube = sim::CubePositionFromObservation(o.data());
    const Eigen::Vector3d goal = env.GoalPosition();
    EXPECT_NEAR(cube.z() - goal.z(), 0.05, 0.015) << "task " << task;
    EXPECT_LT((cube - goal).head<2>().norm(), 0.01) << "task " << task;
    EXPECT_LT((sim::PinchPositionFromObservation(o.data()) - cube).norm(), 0.02) << "held";
    EXPECT_FALSE(env.Success());  // 5 cm above is more than the 4 cm of success
  }
}

// An untrained puzzle-3x3 policy (55-D states, 5-D actions): the evaluator's bookkeeping,
// determinism, report and errors.
TEST(PuzzleEvaluator, DeterministicAndChecksThePolicy) {
  core::Policy policy = UntrainedStatePolicy(55, 5);
  PuzzleEvalOptions opt;
  opt.tasks = {1, 4};
  opt.episodes = 2;
  opt.max_steps = 12;
  const auto a = EvaluateOnPuzzle(policy, opt);
  const auto c = EvaluateOnPuzzle(policy, opt);
  ASSERT_EQ(a.tasks, opt.tasks);
  ASSERT_EQ(a.success.size(), 2u);
  EXPECT_EQ(a.success, c.success);
  EXPECT_EQ(a.mean_steps_success, c.mean_steps_success);
  // 12 steps cannot solve tasks of 2 and 9 presses.
  EXPECT_EQ(a.success, (std::vector<double>{0.0, 0.0}));
  const auto report = MakePuzzleEvalReport(a, opt, "untrained");
  EXPECT_EQ(report.env, "puzzle-3x3");
  ASSERT_EQ(report.tasks.size(), 2u);
  EXPECT_EQ(report.tasks[0].goal, (std::vector<double>{1, 1, 0, 1, 0, 1, 0, 1, 1}));
  EXPECT_NE(sim::EvalReportTable(report).find("000/000/000->110/101/011"), std::string::npos)
      << sim::EvalReportTable(report);
  opt.tasks = {6};
  EXPECT_THROW(EvaluateOnPuzzle(policy, opt), std::invalid_argument);
  opt.tasks = {1};
  opt.side = 4;  // 83-D observations: not this policy's
  EXPECT_THROW(EvaluateOnPuzzle(policy, opt), std::invalid_argument);
  opt.side = 5;
  EXPECT_THROW(EvaluateOnPuzzle(policy, opt), std::invalid_argument);
}

// An untrained cube-double policy (37-D states): determinism, the report, the policy check.
TEST(CubeDoubleEvaluator, DeterministicAndChecksThePolicy) {
  core::Policy policy = UntrainedStatePolicy(37, 5);
  ArmTaskEvalOptions opt;
  opt.tasks = {4};
  opt.episodes = 2;
  opt.max_steps = 10;
  const auto a = EvaluateOnCubeDouble(policy, opt);
  const auto c = EvaluateOnCubeDouble(policy, opt);
  EXPECT_EQ(a.success, c.success);
  EXPECT_EQ(a.success, (std::vector<double>{0.0}));  // no swap in 10 steps
  EXPECT_EQ(MakeCubeDoubleEvalReport(a, opt, "untrained").env, "cube-double");
  auto maze_policy = core::Policy::Load(MSSPR_TEST_CHECKPOINT);  // 2-D
  EXPECT_THROW(EvaluateOnCubeDouble(maze_policy, opt), std::invalid_argument);
}

// An untrained scene policy (40-D states): determinism, the cap (the scene's 750 when
// max_steps is 0), the report, the policy check.
TEST(SceneEvaluator, DeterministicRunsToTheScenesCapAndChecksThePolicy) {
  core::Policy policy = UntrainedStatePolicy(40, 5);
  ArmTaskEvalOptions opt;
  opt.tasks = {2};
  opt.episodes = 1;
  opt.max_steps = 10;
  const auto a = EvaluateOnScene(policy, opt);
  const auto c = EvaluateOnScene(policy, opt);
  EXPECT_EQ(a.success, c.success);
  EXPECT_EQ(a.success, (std::vector<double>{0.0}));  // nothing closes and locks in 10 steps
  ASSERT_EQ(a.episodes.size(), 1u);
  ASSERT_EQ(c.episodes.size(), 1u);
  EXPECT_EQ(a.episodes[0].steps, 10);
  EXPECT_EQ(a.episodes[0].final_obs.size(), 40u);
  EXPECT_EQ(a.episodes[0].final_obs, c.episodes[0].final_obs);
  // Episodes in groups of 2 give what all 6 side by side give, episode by episode.
  ArmTaskEvalOptions wide = opt;
  wide.tasks = {1, 3};
  wide.episodes = 3;
  const auto at_once = EvaluateOnScene(policy, wide);
  wide.episodes_at_once = 2;
  const auto in_pairs = EvaluateOnScene(policy, wide);
  ASSERT_EQ(at_once.episodes.size(), 6u);
  ASSERT_EQ(in_pairs.episodes.size(), 6u);
  for (size_t k = 0; k < 6; ++k) {
    EXPECT_EQ(at_once.episodes[k].steps, in_pairs.episodes[k].steps) << k;
    EXPECT_EQ(at_once.episodes[k].final_obs, in_pairs.episodes[k].final_obs) << k;
  }
  EXPECT_NE(at_once.episodes[0].final_obs, at_once.episodes[3].final_obs);  // other tasks
  wide.episodes_at_once = 0;
  EXPECT_THROW(EvaluateOnScene(policy, wide), std::invalid_argument);
  opt.max_steps = 0;
  const sim::EvalReport report = MakeSceneEvalReport(a, opt, "untrained");
  EXPECT_EQ(report.env, "scene");
  EXPECT_EQ(report.max_steps, 750);
  core::Policy cube_double_policy = UntrainedStatePolicy(37, 5);
  EXPECT_THROW(EvaluateOnScene(cube_double_policy, opt), std::invalid_argument);
  opt.tasks = {6};
  EXPECT_THROW(EvaluateOnScene(policy, opt), std::invalid_argument);
}

// An untrained pixels policy of cube-single (16x16 camera images, two frames
// stacked, 5-D actions): the evaluator renders the arm's camera and the goal
// image at the policy's size; outcomes are deterministic and an episode's is
// the same alone as among others (each episode renders its own scene).
TEST(CubeEvaluator, PixelsPoliciesAreServedTheCameraDeterministically) {
  torch::manual_seed(0);
  core::DatasetBuilder b(0, 5, core::ImageShape{16, 16, 3});
  std::vector<float> act(10 * 5, 0.2f);
  std::vector<uint8_t> images(10 * 16 * 16 * 3);
  for (size_t i = 0; i < images.size(); ++i) images[i] = static_cast<uint8_t>(i * 7);
  b.AddEpisode({}, act, images);
  b.AddEpisode({}, act, images);
  core::MsprOptions o = core::testing_util::TinyOptions();
  o.network.obs_mode = "pixels";
  o.network.cnn = "light";
  o.network.frame_stack = 2;
  core::Trainer trainer(o, std::make_shared<const core::Dataset>(b.Build()));
  trainer.Step();
  core::Policy policy = trainer.MakePolicy();
  ASSERT_TRUE(policy.pixels());
  CubeEvalOptions opt;
  opt.tasks = {1, 3};
  opt.episodes = 3;
  opt.max_steps = 12;
  const auto a = EvaluateOnCube(policy, opt);
  const auto c = EvaluateOnCube(policy, opt);
  ASSERT_EQ(a.episodes.size(), 6u);
  for (size_t k = 0; k < 6; ++k) {
    EXPECT_EQ(a.episodes[k].steps, c.episodes[k].steps);
    EXPECT_EQ(a.episodes[k].final_obs, c.episodes[k].final_obs);
  }
  CubeEvalOptions alone = opt;
  alone.tasks = {3};
  alone.episodes = 1;
  const auto one = EvaluateOnCube(policy, alone);
  EXPECT_EQ(one.episodes[0].final_obs, a.episodes[3].final_obs);
}

// An untrained ant policy (29-D states, 8-D actions) on antmaze-medium: the
// evaluator's bookkeeping, determinism, report and errors.
TEST(AntEvaluator, DeterministicAndChecksThePolicy) {
  core::Policy policy = UntrainedStatePolicy(29, 8);
  AntEvalOptions opt;
  opt.tasks = {1, 4};
  opt.episodes = 2;
  opt.max_steps = 12;
  const auto a = EvaluateOnAntMaze(policy, opt);
  const auto c = EvaluateOnAntMaze(policy, opt);
  ASSERT_EQ(a.tasks, opt.tasks);
  ASSERT_EQ(a.success.size(), 2u);
  EXPECT_EQ(a.success, c.success);
  EXPECT_EQ(a.mean_steps_success, c.mean_steps_success);
  // The tasks' goals are at least 8 m from their starts: 12 steps (1.2 s) reach none.
  EXPECT_EQ(a.mean_success, 0.0);
  const auto report = MakeAntEvalReport(a, opt, "untrained");
  EXPECT_EQ(report.env, "antmaze-medium");
  ASSERT_EQ(report.tasks.size(), 2u);
  EXPECT_EQ(report.tasks[1].task_id, 4);
  EXPECT_EQ(report.max_steps, 12);
  opt.tasks = {6};
  EXPECT_THROW(EvaluateOnAntMaze(policy, opt), std::invalid_argument);
  opt.tasks = {1};
  opt.maze = "giant";  // no ant env for the giant maze
  EXPECT_THROW(EvaluateOnAntMaze(policy, opt), std::invalid_argument);
  opt.maze = "medium";
  auto maze_policy = core::Policy::Load(MSSPR_TEST_CHECKPOINT);  // 2-D: not an ant policy
  EXPECT_THROW(EvaluateOnAntMaze(maze_policy, opt), std::invalid_argument);
}

TEST(MazeEvaluator, CustomTasksStartExactlyWhereTheySay) {
  auto policy = core::Policy::Load(MSSPR_TEST_CHECKPOINT);
  MazeEvalOptions opt;
  opt.episodes = 2;
  opt.max_steps = 400;
  opt.keep_paths = true;
  sim::CustomTask near, far;
  near.id = 7;
  near.start = {0.0, 0.0};
  near.goal = {0.5, 0.0};  // inside the success radius: done before the first step
  far.id = 9;
  far.start = {0.0, 0.0};
  far.goal = {4.0, 0.0};  // the next cell
  opt.custom_tasks = {near, far};
  const auto r = EvaluateOnMaze(policy, opt);
  ASSERT_EQ(r.tasks, (std::vector<int>{7, 9}));
  EXPECT_EQ(r.success[0], 1.0);
  EXPECT_EQ(r.mean_steps_success[0], 0.0);
  for (size_t t = 0; t < 2; ++t)
    for (const auto& [start, goal] : r.start_goal[t]) {
      EXPECT_EQ(start, opt.custom_tasks[t].start);
      EXPECT_EQ(goal, opt.custom_tasks[t].goal);
    }
  // No reset noise: both episodes of a task are the same episode.
  EXPECT_EQ(r.paths[1][0], r.paths[1][1]);
  EXPECT_EQ(r.success[1], 1.0) << "the shipped policy should cross one cell";
  opt.custom_tasks[1].goal = {-4.0, 0.0};  // a wall cell
  EXPECT_THROW(EvaluateOnMaze(policy, opt), std::invalid_argument);
}

// The value map's true value is the discounted return of the episode that
// EvaluateOnMaze runs from the same start, and its prediction is the critic
// at that start; a trained critic tracks the true values.
TEST(ValueMap, MatchesRolloutsAndTheCritic) {
  auto policy = core::Policy::Load(MSSPR_TEST_CHECKPOINT);
  const auto map = sim::MazeMap::FromName("medium");
  ValueMapOptions vo;
  vo.goal = map.CellCenter(map.Tasks()[0].goal);
  vo.per_cell = 1;
  vo.rollouts = 1;
  vo.start_noise = 0.0;
  vo.max_steps = 400;
  const auto r = ComputeValueMap(policy, vo);
  ASSERT_EQ(r.points.size(), map.FreeCells().size());
  EXPECT_EQ(r.episodes, static_cast<int>(map.FreeCells().size()));
  const double g = policy.options().agent.gamma;
  MazeEvalOptions eo;
  eo.episodes = 1;
  eo.max_steps = vo.max_steps;
  for (size_t i = 0; i < r.points.size(); ++i) {
    const auto& p = r.points[i];
    EXPECT_EQ(p.xy, map.CellCenter(map.FreeCells()[i]));
    sim::CustomTask t;
    t.id = static_cast<int>(i) + 1;
    t.start = p.xy;
    t.goal = vo.goal;
    eo.custom_tasks.push_back(t);
  }
  const auto ev = EvaluateOnMaze(policy, eo);
  double succ = 0;
  for (size_t i = 0; i < r.points.size(); ++i) {
    const auto& p = r.points[i];
    const int steps = ev.success[i] > 0 ? static_cast<int>(ev.mean_steps_success[i]) : vo.max_steps;
    EXPECT_NEAR(p.true_value, -(1 - std::pow(g, steps)) / (1 - g), 1e-9) << "point " << i;
    EXPECT_EQ(p.success, ev.success[i]);
    succ += ev.success[i] / r.points.size();
    torch::InferenceMode guard;
    const auto obs = torch::tensor({static_cast<float>(p.xy.x()), static_cast<float>(p.xy.y())});
    const auto goal =
        torch::tensor({static_cast<float>(vo.goal.x()), static_cast<float>(vo.goal.y())});
    const double q = policy.Q(obs, policy.Act(obs, goal), goal).min().item<double>();
    EXPECT_NEAR(p.predicted, q, 1e-4 * (1 + std::abs(q)));
  }
  EXPECT_NEAR(r.mean_success, succ, 1e-12);
  EXPECT_GT(r.correlation, 0.5) << "the shipped critic should rank starts by their true value";
  EXPECT_LT(r.mean_abs_error, 50.0);
  // Pictures and JSON.
  const std::string dir = ::testing::TempDir() + "/value_map_test";
  WriteValueMap(r, vo, "test", dir);
  for (const char* f :
       {"value_predicted.png", "value_true.png", "value_error.png", "value_map.json"})
    EXPECT_TRUE(std::ifstream(dir + "/" + f).good()) << f;
  std::ifstream js(dir + "/value_map.json");
  const std::string text((std::istreambuf_iterator<char>(js)), std::istreambuf_iterator<char>());
  EXPECT_NE(text.find("\"mean_abs_error\": "), std::string::npos);
  EXPECT_NE(text.find("\"correlation\": "), std::string::npos);
  vo.goal = {-4.0, 0.0};
  EXPECT_THROW(ComputeValueMap(policy, vo), std::invalid_argument);
}

// Runs msspr_train; returns the pid. fault: MSSPR_FAULT_KILL_IN_CHECKPOINT for the child.
pid_t StartTrain(const std::vector<std::string>& args, const std::string& log,
                 const char* fault = nullptr) {
  const pid_t pid = fork();
  if (pid == 0) {
    std::vector<char*> argv;
    std::string exe = MSSPR_TRAIN_EXE;
    argv.push_back(exe.data());
    std::vector<std::string> copy = args;
    for (auto& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    if (fault) setenv("MSSPR_FAULT_KILL_IN_CHECKPOINT", fault, 1);
    freopen(log.c_str(), "a", stderr);
    freopen(log.c_str(), "a", stdout);
    execv(exe.c_str(), argv.data());
    _exit(127);
  }
  return pid;
}

int Wait(pid_t pid) {
  int status = 0;
  waitpid(pid, &status, 0);
  return status;
}

std::string ReadAll(const std::string& path) {
  std::ifstream f(path);
  return std::string((std::istreambuf_iterator<char>(f)), {});
}

// metrics.csv without its wall-clock columns (wall_s, steps_per_s).
std::vector<std::string> LossRows(const std::string& path) {
  std::vector<std::string> rows;
  std::ifstream f(path);
  for (std::string line; std::getline(f, line);) {
    std::vector<std::string> cells;
    std::stringstream ss(line);
    for (std::string c; std::getline(ss, c, ',');) cells.push_back(c);
    std::string row;
    for (size_t i = 0; i < cells.size(); ++i)
      if (i != 1 && i != 2) row += cells[i] + ",";
    rows.push_back(row);
  }
  return rows;
}

// A tiny run: 12 short trajectories and a tiny network, a few seconds in all.
struct TinyRun {
  std::string dir, data, config;
  // 12 episodes of 30 random steps, 2-D states and actions (the point maze's) unless given.
  explicit TinyRun(const std::string& name, int obs_dim = 2, int action_dim = 2)
      : dir(Tmp(name)), data(dir + "/data.npz"), config(dir + "/tiny.yaml") {
    mkdir(dir.c_str(), 0755);
    std::mt19937_64 rng(1);
    std::normal_distribution<float> normal;
    core::DatasetBuilder b(obs_dim, action_dim);
    for (int e = 0; e < 12; ++e) {
      std::vector<float> obs(30 * obs_dim), act(30 * action_dim);
      for (auto& v : obs) v = normal(rng);
      for (auto& v : act) v = std::tanh(normal(rng));
      b.AddEpisode(obs, act);
    }
    core::SaveNpzDataset(b.Build(), data);
    core::MsprOptions o = core::testing_util::TinyOptions();
    o.representation.updates_per_step = 1.0;
    std::ofstream(config) << core::OptionsToYaml(o);
  }
  ~TinyRun() { std::filesystem::remove_all(dir); }
  // The run's flags; `set` replaces the values of flags in that list (a flag
  // not in it is a test bug and throws).
  std::vector<std::string> Args(
      const std::string& out,
      const std::vector<std::pair<std::string, std::string>>& set = {}) const {
    std::vector<std::string> a = {"--data",
                                  data,
                                  "--val",
                                  data,
                                  "--config",
                                  config,
                                  "--steps",
                                  "40",
                                  "--batch",
                                  "16",
                                  "--checkpoint-every",
                                  "3",
                                  "--log-every",
                                  "1",
                                  "--eval-every",
                                  "5",
                                  "--threads",
                                  "1",
                                  "--seed",
                                  "3",
                                  "--quiet",
                                  "--out",
                                  out};
    for (const auto& [flag, value] : set) {
      const auto it = std::find(a.begin(), a.end(), flag);
      if (it == a.end() || it + 1 == a.end())
        throw std::invalid_argument("TinyRun::Args: no flag " + flag);
      *(it + 1) = value;
    }
    return a;
  }
};

TEST(TrainCli, KilledAtRandomPointsResumesBitExact) {
  TinyRun tiny("killed");
  const std::string ref = tiny.dir + "/ref", run = tiny.dir + "/run";
  ASSERT_EQ(Wait(StartTrain(tiny.Args(ref), ref + ".log")), 0) << ReadAll(ref + ".log");
  // The learning curve is drawn at every evaluation (here validation losses only).
  EXPECT_TRUE(Exists(ref + "/learning_curve.png"));

  // Kill the same run again and again: once inside a checkpoint write (the
  // fault hook), then at seeded random moments, resuming each time.
  std::mt19937 rng(2024);
  int kills = 0, attempts = 0, status = 0;
  for (; attempts < 12; ++attempts) {
    const bool fresh = !Exists(run + "/run.yaml");
    const std::vector<std::string> args =
        fresh ? tiny.Args(run) : std::vector<std::string>{"--resume", "--out", run, "--quiet"};
    const pid_t pid = StartTrain(args, run + ".log", attempts == 0 ? "2" : nullptr);
    if (attempts > 0 && attempts < 8) {
      std::this_thread::sleep_for(
          std::chrono::milliseconds(std::uniform_int_distribution<int>(300, 2500)(rng)));
      kill(pid, SIGKILL);
    }
    status = Wait(pid);
    if (WIFSIGNALED(status)) {
      ++kills;
      continue;
    }
    ASSERT_TRUE(WIFEXITED(status));
    ASSERT_EQ(WEXITSTATUS(status), 0) << ReadAll(run + ".log");
    break;
  }
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << ReadAll(run + ".log");
  EXPECT_GE(kills, 1);
  const std::string log = ReadAll(run + ".log");
  EXPECT_NE(log.find("resumed"), std::string::npos) << log;

  // Bit for bit: the exported weights, every logged loss, every evaluation row.
  auto a = core::Policy::Load(ref + "/policy.pt"), b = core::Policy::Load(run + "/policy.pt");
  using Pair = std::pair<torch::nn::Module*, torch::nn::Module*>;
  for (const Pair& m : std::vector<Pair>{{a.repr().get(), b.repr().get()},
                                         {a.actor().get(), b.actor().get()},
                                         {a.critic().get(), b.critic().get()}}) {
    const auto pa = m.first->parameters(), pb = m.second->parameters();
    ASSERT_EQ(pa.size(), pb.size());
    for (size_t i = 0; i < pa.size(); ++i)
      EXPECT_TRUE(torch::equal(pa[i], pb[i])) << "parameter " << i;
  }
  const auto ref_rows = LossRows(ref + "/metrics.csv"), run_rows = LossRows(run + "/metrics.csv");
  EXPECT_EQ(ref_rows.size(), 41u);  // header + 40 steps, no duplicates
  EXPECT_EQ(run_rows, ref_rows);
  EXPECT_EQ(ReadAll(run + "/eval.csv"), ReadAll(ref + "/eval.csv"));
}

// SIGTERM: the run stops at a step boundary with its checkpoint and policy
// written at that step (not at the last periodic checkpoint), exits 143, and
// --resume finishes it equal to an uninterrupted run.
TEST(TrainCli, SigtermStopsAtAStepAndResumesBitExact) {
  TinyRun tiny("sigterm");
  const std::string ref = tiny.dir + "/ref", run = tiny.dir + "/run";
  auto args = [&](const std::string& out) {
    // --checkpoint-every 1000: only at the end.
    return tiny.Args(out,
                     {{"--steps", "300"}, {"--checkpoint-every", "1000"}, {"--eval-every", "50"}});
  };
  ASSERT_EQ(Wait(StartTrain(args(ref), ref + ".log")), 0) << ReadAll(ref + ".log");

  const pid_t pid = StartTrain(args(run), run + ".log");
  // Signal once a few steps are logged.
  for (int i = 0; i < 6000 && LossRows(run + "/metrics.csv").size() < 8; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  kill(pid, SIGTERM);
  const int st = Wait(pid);
  const std::string log = ReadAll(run + ".log");
  ASSERT_TRUE(WIFEXITED(st)) << log;
  ASSERT_EQ(WEXITSTATUS(st), 128 + SIGTERM) << log;
  const size_t at = log.find("SIGTERM: stopped at step ");
  ASSERT_NE(at, std::string::npos) << log;
  const int stopped = std::atoi(log.c_str() + at + std::strlen("SIGTERM: stopped at step "));
  EXPECT_GE(stopped, 7);
  ASSERT_LT(stopped, 300) << "the run ended before the signal";
  EXPECT_TRUE(Exists(run + "/checkpoint.ckpt"));
  EXPECT_TRUE(Exists(run + "/policy.pt"));
  EXPECT_EQ(LossRows(run + "/metrics.csv").size(), static_cast<size_t>(stopped) + 1);

  ASSERT_EQ(Wait(StartTrain({"--resume", "--out", run, "--quiet"}, run + ".resume")), 0)
      << ReadAll(run + ".resume");
  EXPECT_NE(ReadAll(run + ".resume").find("at step " + std::to_string(stopped)), std::string::npos)
      << ReadAll(run + ".resume");
  auto a = core::Policy::Load(ref + "/policy.pt"), b = core::Policy::Load(run + "/policy.pt");
  const auto pa = a.actor()->parameters(), pb = b.actor()->parameters();
  ASSERT_EQ(pa.size(), pb.size());
  for (size_t i = 0; i < pa.size(); ++i)
    EXPECT_TRUE(torch::equal(pa[i], pb[i])) << "actor parameter " << i;
  EXPECT_EQ(LossRows(run + "/metrics.csv"), LossRows(ref + "/metrics.csv"));
}

TEST(TrainCli, EvaluatesCustomTasksBesideTheOfficialOnes) {
  TinyRun tiny("custom_tasks");
  const std::string out = tiny.dir + "/run";
  const std::string tasks = std::string(MSSPR_SOURCE_DIR) + "/config/eval_tasks_medium_easy.yaml";
  std::vector<std::string> args = tiny.Args(out);
  for (const char* a : {"--eval-maze", "medium", "--eval-episodes", "1", "--eval-max-steps", "20",
                        "--eval-tasks", "2", "--eval-tasks-file"})
    args.push_back(a);
  args.push_back(tasks);
  args[std::find(args.begin(), args.end(), "--steps") - args.begin() + 1] = "10";
  ASSERT_EQ(Wait(StartTrain(args, out + ".log")), 0) << ReadAll(out + ".log");
  const std::string eval = ReadAll(out + "/eval.csv");
  for (const char* key : {"10,success_task2,", "10,success_custom1,", "10,success_custom3,",
                          "10,mean_success,", "10,mean_success_custom,"})
    EXPECT_NE(eval.find(key), std::string::npos) << key << "\n" << eval;
  const std::string js = ReadAll(out + "/eval/step_00000010_custom.json");
  EXPECT_NE(js.find("\"start\": [16.0000, 0.0000], \"goal\": [20.0000, 0.0000]"), std::string::npos)
      << js;
  // A tasks file with a goal in a wall: a usage error naming the file, before any training.
  const std::string bad = tiny.dir + "/bad_tasks.yaml";
  std::ofstream(bad) << "tasks:\n  - {id: 1, start: [0, 0], goal: [-4, 0]}\n";
  args.back() = bad;
  args[std::find(args.begin(), args.end(), "--out") - args.begin() + 1] = tiny.dir + "/run2";
  const int st = Wait(StartTrain(args, out + ".bad"));
  EXPECT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) == 2) << ReadAll(out + ".bad");
  EXPECT_NE(ReadAll(out + ".bad").find(bad + ": task 1: goal"), std::string::npos)
      << ReadAll(out + ".bad");
}

// .npz data carries no env: --eval-env names the sim to evaluate in (here an
// OGBench-shaped antmaze file: 29-D states, 8-D actions); a bad name is a usage error.
TEST(TrainCli, EvalEnvEvaluatesNpzDataInTheAntMaze) {
  TinyRun tiny("eval_env", 29, 8);
  const std::string out = tiny.dir + "/run";
  std::vector<std::string> args = tiny.Args(out, {{"--steps", "5"}});
  for (const char* a : {"--eval-env", "antmaze-medium", "--eval-episodes", "1", "--eval-max-steps",
                        "10", "--eval-tasks", "3"})
    args.push_back(a);
  ASSERT_EQ(Wait(StartTrain(args, out + ".log")), 0) << ReadAll(out + ".log");
  const std::string eval = ReadAll(out + "/eval.csv");
  EXPECT_NE(eval.find("5,success_task3,0.000000"), std::string::npos) << eval;
  const std::string js = ReadAll(out + "/eval/step_00000005.json");
  EXPECT_NE(js.find("\"env\": \"antmaze-medium\""), std::string::npos) << js;
  EXPECT_NE(js.find("\"max_steps\": 10"), std::string::npos) << js;
  args[std::find(args.begin(), args.end(), "--eval-env") - args.begin() + 1] = "antmaze-huge";
  args[std::find(args.begin(), args.end(), "--out") - args.begin() + 1] = tiny.dir + "/run2";
  const int st = Wait(StartTrain(args, out + ".bad"));
  EXPECT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) == 2) << ReadAll(out + ".bad");
  EXPECT_NE(ReadAll(out + ".bad").find("--eval-env: 'antmaze-huge'"), std::string::npos)
      << ReadAll(out + ".bad");
}

// A baseline from images, as a user trains it from the pixels sample bag: GCIVL
// with the light CNN layer trains, evaluates in the rendered maze and exports a
// pixels policy.
TEST(TrainCli, GcivlTrainsFromImagesOfTheSampleBag) {
  const std::string dir = Tmp("gcivl_pixels");
  mkdir(dir.c_str(), 0755);
  const std::string src = MSSPR_SOURCE_DIR, out = dir + "/run";
  const std::vector<std::string> args = {
      "--agent",
      "gcivl",
      "--observation-mode",
      "pixels",
      "--data",
      src + "/rosbags/pointmaze-medium-navigate-pixels-sample.bag",
      "--config",
      src + "/config/agents/pointmaze_cpu.yaml",
      "--config",
      src + "/config/agents/pixels_light.yaml",
      "--steps",
      "20",
      "--batch",
      "16",
      "--eval-every",
      "10",
      "--eval-episodes",
      "1",
      "--eval-max-steps",
      "10",
      "--eval-tasks",
      "1",
      "--threads",
      "1",
      "--seed",
      "2",
      "--quiet",
      "--out",
      out};
  ASSERT_EQ(Wait(StartTrain(args, out + ".log")), 0) << ReadAll(out + ".log");
  const std::string eval = ReadAll(out + "/eval.csv");
  for (const char* key : {"10,mean_success,", "20,mean_success,"})
    EXPECT_NE(eval.find(key), std::string::npos) << key << "\n" << eval;
  const std::string options = ReadAll(out + "/options.yaml");
  EXPECT_NE(options.find("obs_mode: pixels"), std::string::npos) << options;
  EXPECT_NE(options.find("agent: gcivl"), std::string::npos) << options;
  core::Policy policy = core::Policy::Load(out + "/policy.pt");
  EXPECT_EQ(policy.agent_name(), "gcivl");
  const torch::Tensor img = torch::zeros({64, 64, 3}, torch::kUInt8);
  EXPECT_EQ(policy.Act(img, img).sizes(), (std::vector<int64_t>{2}));
  std::filesystem::remove_all(dir);
}

TEST(TrainCli, ResumeRefusesChangedOptionsAndASecondRun) {
  TinyRun tiny("resume_rules");
  const std::string out = tiny.dir + "/run";
  ASSERT_EQ(Wait(StartTrain(tiny.Args(out), out + ".log")), 0) << ReadAll(out + ".log");
  auto exit_code = [&](const std::vector<std::string>& args, const std::string& log) {
    const int st = Wait(StartTrain(args, log));
    return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  };
  // A changed option: exit 2, naming it.
  EXPECT_EQ(exit_code({"--resume", "--out", out, "--batch", "32"}, out + ".batch"), 2);
  EXPECT_NE(ReadAll(out + ".batch").find("--batch 32 differs"), std::string::npos)
      << ReadAll(out + ".batch");
  EXPECT_EQ(exit_code({"--resume", "--out", out, "--data", tiny.config}, out + ".data"), 2);
  // A fresh run into a directory that holds one: exit 2.
  EXPECT_EQ(exit_code(tiny.Args(out), out + ".again"), 2);
  EXPECT_NE(ReadAll(out + ".again").find("--resume"), std::string::npos);
  // An allowed change: more steps.
  EXPECT_EQ(exit_code({"--resume", "--out", out, "--steps", "45", "--quiet"}, out + ".more"), 0)
      << ReadAll(out + ".more");
  EXPECT_EQ(LossRows(out + "/metrics.csv").size(), 46u);
  // Another: bf16 from here on (recorded, so a plain --resume keeps it).
  EXPECT_EQ(exit_code({"--resume", "--out", out, "--steps", "48", "--precision", "bf16", "--quiet"},
                      out + ".bf16"),
            0)
      << ReadAll(out + ".bf16");
  EXPECT_EQ(LossRows(out + "/metrics.csv").size(), 49u);
  EXPECT_NE(ReadAll(out + "/run.yaml").find("precision: \"bf16\""), std::string::npos)
      << ReadAll(out + "/run.yaml");
  EXPECT_NE(ReadAll(out + "/options.yaml").find("precision: bf16"), std::string::npos);
  // A second run while one holds the directory's lock.
  const int fd = open((out + "/.lock").c_str(), O_RDWR);
  ASSERT_GE(fd, 0);
  ASSERT_EQ(flock(fd, LOCK_EX | LOCK_NB), 0);
  EXPECT_EQ(exit_code({"--resume", "--out", out, "--steps", "50"}, out + ".locked"), 1);
  EXPECT_NE(ReadAll(out + ".locked").find("another training run"), std::string::npos)
      << ReadAll(out + ".locked");
  close(fd);
}

// --- Data-parallel msspr_train: two processes, Gloo on loopback ----------------

// TinyRun's arguments for one of two ranks, with `steps` steps.
std::vector<std::string> RankArgs(const TinyRun& tiny, const std::string& out, int rank, int port,
                                  const std::string& steps) {
  std::vector<std::string> a = tiny.Args(out, {{"--steps", steps}});
  for (const std::string& extra :
       {std::string("--world-size"), std::string("2"), std::string("--rank"), std::to_string(rank),
        std::string("--master"), "127.0.0.1:" + std::to_string(port), std::string("--dist-timeout"),
        std::string("30")})
    a.push_back(extra);
  return a;
}

std::vector<std::string> ResumeArgs(const std::string& out, int rank, int port,
                                    const std::string& steps) {
  return {"--resume",
          "--out",
          out,
          "--quiet",
          "--steps",
          steps,
          "--world-size",
          "2",
          "--rank",
          std::to_string(rank),
          "--master",
          "127.0.0.1:" + std::to_string(port),
          "--dist-timeout",
          "30"};
}

// Starts both ranks, waits for both; returns their exit statuses.
std::pair<int, int> RunRanks(const std::vector<std::string>& a0, const std::vector<std::string>& a1,
                             const std::string& log) {
  const pid_t p0 = StartTrain(a0, log + ".rank0"), p1 = StartTrain(a1, log + ".rank1");
  const int s0 = Wait(p0), s1 = Wait(p1);
  return {s0, s1};
}

bool ExitedOk(int status) { return WIFEXITED(status) && WEXITSTATUS(status) == 0; }

TEST(TrainCli, TwoRanksTrainCheckpointResumeAndExportAsOne) {
  TinyRun tiny("two_ranks");
  const std::string run = tiny.dir + "/run", ref = tiny.dir + "/ref";
  // 20 steps, then resumed to 30, against 30 straight.
  int port = core::testing_util::FreePort();
  auto st = RunRanks(RankArgs(tiny, run, 0, port, "20"), RankArgs(tiny, run, 1, port, "20"), run);
  ASSERT_TRUE(ExitedOk(st.first) && ExitedOk(st.second))
      << ReadAll(run + ".rank0") << ReadAll(run + ".rank1");
  EXPECT_NE(ReadAll(run + ".rank1").find("rank 1 of 2 (gloo"), std::string::npos)
      << ReadAll(run + ".rank1");
  EXPECT_NE(ReadAll(run + ".rank0").find("batch 8 of 16"), std::string::npos)
      << ReadAll(run + ".rank0");
  const core::CheckpointFile file = core::ReadCheckpointFile(run + "/checkpoint.ckpt");
  const core::CheckpointHeader h = core::ParseCheckpointHeader(file.header, run);
  EXPECT_EQ(h.step, 20);
  EXPECT_EQ(h.rank_states.size(), 2u);
  EXPECT_NE(h.rank_states[0], h.rank_states[1]);
  // One writer: metrics.csv has each step once.
  EXPECT_EQ(LossRows(run + "/metrics.csv").size(), 21u);
  port = core::testing_util::FreePort();
  st = RunRanks(ResumeArgs(run, 0, port, "30"), ResumeArgs(run, 1, port, "30"), run + ".resumed");
  ASSERT_TRUE(ExitedOk(st.first) && ExitedOk(st.second))
      << ReadAll(run + ".resumed.rank0") << ReadAll(run + ".resumed.rank1");
  port = core::testing_util::FreePort();
  st = RunRanks(RankArgs(tiny, ref, 0, port, "30"), RankArgs(tiny, ref, 1, port, "30"), ref);
  ASSERT_TRUE(ExitedOk(st.first) && ExitedOk(st.second))
      << ReadAll(ref + ".rank0") << ReadAll(ref + ".rank1");
  auto a = core::Policy::Load(ref + "/policy.pt"), b = core::Policy::Load(run + "/policy.pt");
  for (const auto& pair : std::vector<std::pair<torch::nn::Module*, torch::nn::Module*>>{
           {a.repr().get(), b.repr().get()},
           {a.actor().get(), b.actor().get()},
           {a.critic().get(), b.critic().get()}}) {
    const auto pa = pair.first->parameters(), pb = pair.second->parameters();
    ASSERT_EQ(pa.size(), pb.size());
    for (size_t i = 0; i < pa.size(); ++i)
      EXPECT_TRUE(torch::equal(pa[i], pb[i])) << "parameter " << i;
  }
  EXPECT_EQ(LossRows(run + "/metrics.csv"), LossRows(ref + "/metrics.csv"));
  // The export serves actions like any other.
  EXPECT_EQ(b.Act(std::vector<float>{0.1f, 0.2f}, std::vector<float>{1.f, -1.f}).size(), 2u);
  // Resuming with another world size is refused, naming the group's.
  const int s = Wait(StartTrain({"--resume", "--out", run, "--steps", "35"}, run + ".single"));
  EXPECT_TRUE(WIFEXITED(s) && WEXITSTATUS(s) != 0);
  EXPECT_NE(ReadAll(run + ".single").find("world-size"), std::string::npos)
      << ReadAll(run + ".single");
}

TEST(TrainCli, AKilledRankIsAClearErrorOnTheOtherAndTheCheckpointStaysGood) {
  TinyRun tiny("killed_rank");
  const std::string run = tiny.dir + "/run";
  const int port = core::testing_util::FreePort();
  const pid_t p0 = StartTrain(RankArgs(tiny, run, 0, port, "1000000"), run + ".rank0");
  const pid_t p1 = StartTrain(RankArgs(tiny, run, 1, port, "1000000"), run + ".rank1");
  // Wait for a checkpoint (every 3 steps), then kill rank 1.
  bool have = false;
  for (int i = 0; i < 600 && !have; ++i) {
    have = Exists(run + "/checkpoint.ckpt");
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_TRUE(have) << ReadAll(run + ".rank0");
  kill(p1, SIGKILL);
  Wait(p1);
  const auto t0 = std::chrono::steady_clock::now();
  const int s0 = Wait(p0);
  const double waited =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  EXPECT_TRUE(WIFEXITED(s0) && WEXITSTATUS(s0) == 1) << "status " << s0;
  const std::string log = ReadAll(run + ".rank0");
  EXPECT_NE(log.find("rank 0/2"), std::string::npos) << log;
  EXPECT_NE(log.find("a peer exited or timed out"), std::string::npos) << log;
  EXPECT_LT(waited, 60.0) << "rank 0 hung";
  // The last checkpoint is whole, and it resumes (single-rank refusal aside, it reads).
  EXPECT_NO_THROW(core::ReadCheckpointFile(run + "/checkpoint.ckpt", "trainer"));
  EXPECT_NO_THROW(core::Policy::Load(run + "/checkpoint.ckpt"));
}

}  // namespace
}  // namespace msspr::agent
