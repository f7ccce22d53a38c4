#include "msspr_sim/cube_env.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "cube_test_util.h"
#include "msspr_sim/cube_failures.h"

namespace msspr::sim {
namespace {

// A proportional controller to a pinch position, as OGBench's oracles write
// actions: (target - current) / scale, clipped to [-1, 1].
CubeEnv::Action Toward(const CubeEnv& env, const Eigen::Vector3d& target, double grip) {
  CubeEnv::Action a{};
  const Eigen::Vector3d d = (target - env.PinchPosition()) / 0.05;
  for (int i = 0; i < 3; ++i) a[i] = std::clamp(d[i], -1.0, 1.0);
  a[3] = std::clamp(-env.PinchYaw() / 0.3, -1.0, 1.0);  // hold yaw 0
  a[4] = grip;
  return a;
}

TEST(CubeEnvTest, ObservationLayout) {
  CubeEnv env(testing_util::CubeOptions());
  env.SetCube(Eigen::Vector3d(0.40, -0.1, 0.02), 0.7);
  env.SetOpening(0.5);
  const CubeEnv::Observation o = env.GetObservation();
  const double home[] = {-M_PI / 2, -M_PI / 2, M_PI / 2, -M_PI / 2, -M_PI / 2, 0};
  for (int i = 0; i < 6; ++i) {
    EXPECT_FLOAT_EQ(o[i], static_cast<float>(home[i]));
    EXPECT_EQ(o[6 + i], 0.0f);
  }
  // Home pinch (0.492, 0.134, 0.332) pointing down with yaw 0; c = (0.425, 0, 0).
  EXPECT_NEAR(o[12], 10 * (0.492 - 0.425), 5e-3);
  EXPECT_NEAR(o[13], 10 * 0.134, 5e-3);
  EXPECT_NEAR(o[14], 10 * 0.332, 5e-3);
  EXPECT_NEAR(o[15], 1.0, 1e-6);
  EXPECT_NEAR(o[16], 0.0, 1e-6);
  EXPECT_FLOAT_EQ(o[17], 1.5f);
  EXPECT_EQ(o[18], 0.0f);
  EXPECT_NEAR(o[19], 10 * (0.40 - 0.425), 1e-6);
  EXPECT_NEAR(o[20], -1.0, 1e-6);
  EXPECT_NEAR(o[21], 0.2, 1e-6);
  EXPECT_NEAR(o[22], std::cos(0.35), 1e-6);
  EXPECT_EQ(o[23], 0.0f);
  EXPECT_EQ(o[24], 0.0f);
  EXPECT_NEAR(o[25], std::sin(0.35), 1e-6);
  EXPECT_NEAR(o[26], std::cos(0.7), 1e-6);
  EXPECT_NEAR(o[27], std::sin(0.7), 1e-6);
}

TEST(CubeEnvTest, PlacePinchPointsDownAtTheTarget) {
  CubeEnv env(testing_util::CubeOptions());
  for (double yaw : {-2.5, -0.4, 0.0, 1.0, 3.0}) {
    const Eigen::Vector3d p(0.3 + 0.05 * yaw, 0.1 * std::sin(yaw), 0.25);
    ASSERT_TRUE(env.PlacePinch(p, yaw)) << yaw;
    // IK tolerances are on the flange: 1e-4 m plus 1e-4 rad x 0.156 m.
    EXPECT_LT((env.PinchPosition() - p).norm(), 2e-4) << yaw;
    EXPECT_NEAR(std::remainder(env.PinchYaw() - yaw, 2 * M_PI), 0.0, 2e-4) << yaw;
  }
}

TEST(CubeEnvTest, SuccessIsWithinFourCentimetres) {
  CubeEnv env(testing_util::CubeOptions());
  env.SetCube(Eigen::Vector3d(0.45, 0.1, 0.02), 0.0);
  env.SetGoal(Eigen::Vector3d(0.45, 0.139, 0.02));
  EXPECT_TRUE(env.Success());
  env.SetGoal(Eigen::Vector3d(0.45, 0.141, 0.02));
  EXPECT_FALSE(env.Success());
  EXPECT_EQ(env.GoalPosition().y(), 0.141);
  EXPECT_FALSE(env.Step(CubeEnv::Action{}));
  env.SetGoal(env.CubePosition());
  EXPECT_TRUE(env.Step(CubeEnv::Action{}));
}

// The action moves the measured pinch pose (manipulation.md section 3; the
// [M] figures of a 2.2.2 re-creation: ~2.1 cm per full +x step, ~0.066 rad
// per full yaw step, ~1.3 mm sag per zero step).
TEST(CubeEnvTest, ActionsMoveThePinch) {
  CubeEnv env(testing_util::CubeOptions());
  ASSERT_TRUE(env.PlacePinch(Eigen::Vector3d(0.30, 0.0, 0.25), 0.0));
  Eigen::Vector3d start = env.PinchPosition();
  for (int t = 0; t < 10; ++t) env.Step({0, 0, 0, 0, 0});
  const double sag = (start.z() - env.PinchPosition().z()) / 10;
  start = env.PinchPosition();
  for (int t = 0; t < 5; ++t) {
    env.Step({1, 0, 0, 0, 0});
    EXPECT_TRUE(env.last_ik_converged());
  }
  const Eigen::Vector3d moved = env.PinchPosition() - start;
  double yaw_start = env.PinchYaw();
  for (int t = 0; t < 5; ++t) env.Step({0, 0, 0, 1, 0});
  const double yaw_rate = (env.PinchYaw() - yaw_start) / 5;
  std::printf(
      "zero action: %.2f mm sag per step; +x: %.2f cm per step (y %.2f, z %.2f cm in 5 "
      "steps); +yaw: %.3f rad per step\n",
      1000 * sag, 100 * moved.x() / 5, 100 * moved.y(), 100 * moved.z(), yaw_rate);
  EXPECT_GE(sag, 0.0);
  EXPECT_LT(sag, 0.005);
  EXPECT_GT(moved.x() / 5, 0.01);
  EXPECT_LT(moved.x() / 5, 0.05);
  EXPECT_LT(std::abs(moved.y()), 0.01);
  EXPECT_LT(std::abs(moved.z()), 0.02);
  EXPECT_GT(yaw_rate, 0.02);
  EXPECT_LT(yaw_rate, 0.3);
  // The target is clipped to the workspace (x <= 0.60).
  for (int t = 0; t < 40; ++t) env.Step({1, 0, 0, 0, 0});
  EXPECT_LT(env.PinchPosition().x(), 0.605);
  EXPECT_GT(env.PinchPosition().x(), 0.55);
}

TEST(CubeEnvTest, GripperClosesAndOpens) {
  CubeEnv env(testing_util::CubeOptions());
  ASSERT_TRUE(env.PlacePinch(Eigen::Vector3d(0.40, 0.0, 0.25), 0.0));
  std::string closing, opening;
  for (int t = 0; t < 8; ++t) {
    env.Step({0, 0, 0, 0, 1});
    closing += " " + std::to_string(env.Opening()).substr(0, 4);
  }
  EXPECT_GT(env.Opening(), 0.9);
  EXPECT_NEAR(env.GetObservation()[17], 3 * env.Opening(), 1e-6);
  for (int t = 0; t < 8; ++t) {
    env.Step({0, 0, 0, 0, -1});
    opening += " " + std::to_string(env.Opening()).substr(0, 4);
  }
  EXPECT_LT(env.Opening(), 0.1);
  std::printf("opening per step, closing:%s; opening:%s\n", closing.c_str(), opening.c_str());
}

// A scripted pick: above the cube, down to its centre, close, lift.
TEST(CubeEnvTest, GraspsAndLiftsTheCube) {
  CubeEnv env(testing_util::CubeOptions());
  const Eigen::Vector3d cube(0.45, 0.05, 0.02);
  env.SetCube(cube, 0.0);
  ASSERT_TRUE(env.PlacePinch(cube + Eigen::Vector3d(0, 0, 0.12), 0.0));
  for (int t = 0; t < 20; ++t) env.Step(Toward(env, cube, -1));
  EXPECT_LT((env.PinchPosition() - cube).norm(), 0.01) << env.PinchPosition().transpose();
  for (int t = 0; t < 8; ++t) env.Step(Toward(env, cube, 1));
  const double held_opening = env.Opening();
  for (int t = 0; t < 25; ++t) env.Step(Toward(env, cube + Eigen::Vector3d(0, 0, 0.2), 1));
  const CubeEnv::Observation o = env.GetObservation();
  std::printf("grasp: opening %.3f on the cube, cube lifted to z %.3f, contact %.2f\n",
              held_opening, env.CubePosition().z(), o[18]);
  EXPECT_GT(env.CubePosition().z(), 0.15);
  EXPECT_LT((env.CubePosition() - env.PinchPosition()).norm(), 0.02);
  // A 4 cm cube between the pads: travel (85 - 40) / 2 mm of 42.5 mm.
  EXPECT_NEAR(held_opening, 22.5 / 42.5, 0.05);
  EXPECT_GT(o[18], 0.5f);
}

// The tracker reads the cube from the observations: its rise while held, and where it ends
// against the goal, as the env's own positions give them.
TEST(CubeEnvTest, CubeEpisodeTrackerFollowsTheCubeFromObservations) {
  CubeEnv env(testing_util::CubeOptions());
  env.ResetToTask(2, 7);
  const CubeEnv::Observation goal = env.goal_observation();
  const Eigen::Vector3d cube = env.CubePosition();
  ASSERT_TRUE(env.PlacePinch(cube + Eigen::Vector3d(0, 0, 0.12), 0.0));
  CubeEpisodeTracker tracker;
  tracker.Start(env.GetObservation().data(), goal.data());
  const auto step = [&](const CubeEnv::Action& a) {
    env.Step(a);
    tracker.Observe(env.GetObservation().data());
  };
  for (int t = 0; t < 20; ++t) step(Toward(env, cube, -1));
  for (int t = 0; t < 8; ++t) step(Toward(env, cube, 1));
  for (int t = 0; t < 25; ++t) step(Toward(env, cube + Eigen::Vector3d(0, 0, 0.2), 1));
  const CubeOutcome held = tracker.Finish(false);
  EXPECT_GT(held.lift, 0.13);
  EXPECT_NEAR(held.lift, env.CubePosition().z() - cube.z(), 0.01);
  EXPECT_NEAR(held.goal_distance, (env.CubePosition() - env.GoalPosition()).norm(), 1e-3);
  EXPECT_NEAR(held.above_goal, env.CubePosition().z() - env.GoalPosition().z(), 1e-3);
  // The gripper against the goal observation's gripper, as PinchPosition gives both.
  const Eigen::Vector3d goal_pinch = PinchPositionFromObservation(goal.data());
  EXPECT_NEAR(held.gripper_to_goal_gripper, (env.PinchPosition() - goal_pinch).norm(), 1e-3);
  EXPECT_GT(held.gripper_to_goal_gripper, 0.05);  // lifted 20 cm: far from the goal's arm
  // Lifted straight up where it started: short of the goal by the whole way there.
  const Eigen::Vector2d way = (env.GoalPosition() - cube).head<2>();
  EXPECT_NEAR(held.along_start_to_goal, -way.norm(), 0.01);
  EXPECT_FALSE(held.success);
  EXPECT_TRUE(tracker.Finish(true).success);
}

// Failures are no grasp (a rise under 2 cm) or a missed placement, with medians of the second.
TEST(CubeEnvTest, CubeFailuresTellNoGraspFromAMissedPlacement) {
  const auto episode = [](bool success, double lift, double miss, double above, double gripper,
                          double along = -0.04) {
    CubeOutcome e;
    e.along_start_to_goal = along;
    e.success = success;
    e.lift = lift;
    e.goal_distance = miss;
    e.above_goal = above;
    e.gripper_to_goal_gripper = gripper;
    return e;
  };
  std::vector<CubeOutcome> made = {
      episode(true, 0.10, 0.01, 0.0, 0.30), episode(false, 0.005, 0.15, 0.0, 0.40),
      episode(false, 0.05, 0.05, 0.03, 0.02, -0.05), episode(false, 0.08, 0.20, 0.12, 0.25, 0.03),
      episode(false, 0.03, 0.10, 0.0, 0.12, -0.02)};
  const CubeFailures g = CountCubeFailures(made);
  EXPECT_EQ(g.episodes, 5);
  EXPECT_EQ(g.failed, 4);
  EXPECT_EQ(g.never_lifted, 1);
  EXPECT_EQ(g.lifted_not_placed, 3);
  EXPECT_NEAR(g.median_miss_cm, 10.0, 1e-9);     // of 5, 20 and 10 cm
  EXPECT_NEAR(g.median_above_cm, 3.0, 1e-9);     // of 3, 12 and 0 cm
  EXPECT_NEAR(g.median_across_cm, 10.0, 1e-9);   // of 4, 16 and 10 cm
  EXPECT_NEAR(g.median_gripper_cm, 12.0, 1e-9);  // of 2, 25 and 12 cm
  EXPECT_NEAR(g.median_along_cm, -2.0, 1e-9);    // of -5, 3 and -2 cm
  EXPECT_EQ(DescribeCubeFailures(g),
            "failures: 4 of 5 episodes: 1 never lifted the cube 2.0 cm (no grasp), 3 lifted it and "
            "ended a median 10.0 cm from the goal (10.0 cm across, 3.0 cm above, 2.0 cm short of "
            "it on the way from its start; the gripper a median 12.0 cm from the goal's)");
  made.resize(1);
  EXPECT_EQ(DescribeCubeFailures(CountCubeFailures(made)), "failures: 0 of 1 episodes");
  EXPECT_EQ(CountCubeFailures({}).episodes, 0);
}

TEST(CubeEnvTest, TaskResetsAreSeededAndFollowTheTasks) {
  CubeEnv env(testing_util::CubeOptions());
  CubeEnv other(testing_util::CubeOptions());
  for (int task = 1; task <= 5; ++task) {
    const CubeTask& t = CubeSingleTasks()[task - 1];
    const CubeEnv::Observation o = env.ResetToTask(task, 100 + task);
    EXPECT_EQ(env.episode_steps(), 0);
    // Same seed, same episode, bit for bit (also on another env instance).
    EXPECT_EQ(other.ResetToTask(task, 100 + task), o);
    EXPECT_EQ(other.goal_observation(), env.goal_observation());
    EXPECT_NE(other.ResetToTask(task, 200 + task), o);
    // The cube at the start +- 1 cm, on the floor; the goal marker at the goal.
    EXPECT_LE(std::abs(env.CubePosition().x() - t.start.x()), 0.01);
    EXPECT_LE(std::abs(env.CubePosition().y() - t.start.y()), 0.01);
    EXPECT_NEAR(env.CubePosition().z(), 0.02, 1e-9);
    EXPECT_EQ(env.GoalPosition(), Eigen::Vector3d(t.goal.x(), t.goal.y(), 0.02));
    EXPECT_FALSE(env.Success());
    // The pinch in the initial-pose box (IK tolerance aside), pointing down.
    const Eigen::Vector3d p = env.PinchPosition();
    EXPECT_TRUE(p.x() > 0.249 && p.x() < 0.601 && std::abs(p.y()) < 0.351 && p.z() > 0.199 &&
                p.z() < 0.351)
        << p.transpose();
    EXPECT_NEAR(o[17], 0.0, 1e-6);  // open
    // The goal observation shows the cube at the goal, upright (index 19-22).
    const auto& g = env.goal_observation();
    EXPECT_NEAR(g[19], 10 * (t.goal.x() - 0.425), 1e-3);
    EXPECT_NEAR(g[20], 10 * t.goal.y(), 1e-3);
    EXPECT_NEAR(g[21], 0.2, 1e-3);
    EXPECT_NEAR(g[22], 1.0, 1e-3);
  }
  EXPECT_THROW(env.ResetToTask(0, 1), std::out_of_range);
  EXPECT_THROW(env.ResetToTask(6, 1), std::out_of_range);
}

TEST(CubeEnvTest, CollectionResetsAreSeededAndInBounds) {
  CubeEnv env(testing_util::CubeOptions());
  CubeEnv other(testing_util::CubeOptions());
  for (uint64_t seed = 0; seed < 20; ++seed) {
    const CubeEnv::Observation o = env.ResetForCollection(seed);
    EXPECT_EQ(other.ResetForCollection(seed), o);
    EXPECT_EQ(other.GoalPosition(), env.GoalPosition());
    EXPECT_EQ(other.GoalYaw(), env.GoalYaw());
    for (const Eigen::Vector3d& p : {env.CubePosition(), env.GoalPosition()}) {
      EXPECT_TRUE(p.x() >= 0.30 && p.x() <= 0.55 && std::abs(p.y()) <= 0.30) << p.transpose();
      EXPECT_NEAR(p.z(), 0.02, 1e-9);
    }
    EXPECT_NEAR(o[17], 0.0, 1e-6);  // open
    EXPECT_EQ(env.episode_steps(), 0);
    // Cube yaw as drawn: its observed cos / sin agree with the quaternion.
    EXPECT_NEAR(std::hypot(o[26], o[27]), 1.0, 1e-6);
  }
  EXPECT_NE(env.ResetForCollection(1), env.ResetForCollection(2));
  env.SetGoal(Eigen::Vector3d(0.4, 0.1, 0.02), 1.2);
  EXPECT_NEAR(env.GoalYaw(), 1.2, 1e-12);
}

// A closed-loop scripted pick and place (in the spirit of OGBench's markov
// oracle) solves every evaluation task within the 200-step episode.
TEST(CubeEnvTest, ScriptedPickAndPlaceSolvesEveryTask) {
  CubeEnv env(testing_util::CubeOptions());
  for (int task = 1; task <= 5; ++task) {
    env.ResetToTask(task, task);
    const Eigen::Vector3d goal = env.GoalPosition();
    int phase = 0, phase_steps = 0;
    double grasp_yaw = 0;
    while (!env.EpisodeOver()) {
      const CubeEnv::Observation o = env.GetObservation();
      const Eigen::Vector3d cube = env.CubePosition(), pinch = env.PinchPosition();
      if (phase == 0) {
        // The cube's yaw + k pi/2 nearest the pinch's.
        const double cube_yaw = std::atan2(o[27], o[26]);
        grasp_yaw = cube_yaw +
                    std::round(std::remainder(env.PinchYaw() - cube_yaw, 2 * M_PI) / (M_PI / 2)) *
                        (M_PI / 2);
      }
      Eigen::Vector3d target;
      double grip = -1;
      switch (phase) {
        case 0:
          target = cube + Eigen::Vector3d(0, 0, 0.1);
          break;
        case 1:
          target = cube;
          break;
        case 2:
          target = pinch;
          grip = 1;
          break;
        case 3:
          target = Eigen::Vector3d(pinch.x(), pinch.y(), 0.15);
          grip = 1;
          break;
        case 4:
          target = goal + Eigen::Vector3d(0, 0, 0.13);
          grip = 1;
          break;
        case 5:
          target = goal;
          grip = 1;
          break;
        default:
          target = pinch;
          grip = -1;
          break;
      }
      CubeEnv::Action a = Toward(env, target, grip);
      a[3] = std::clamp(std::remainder(grasp_yaw - env.PinchYaw(), 2 * M_PI) / 0.3, -1.0, 1.0);
      env.Step(a);
      ++phase_steps;
      const double err = (target - env.PinchPosition()).norm();
      const bool next = (phase == 0 && err < 0.01 &&
                         std::abs(std::remainder(grasp_yaw - env.PinchYaw(), 2 * M_PI)) < 0.05) ||
                        (phase == 1 && err < 0.008) || (phase == 2 && phase_steps >= 6) ||
                        (phase == 3 && env.PinchPosition().z() > 0.13) ||
                        (phase == 4 && err < 0.01) || (phase == 5 && err < 0.01);
      if (next) {
        ++phase;
        phase_steps = 0;
      }
    }
    std::printf("task %d: %s after %d steps (phase %d), cube %.3f from the goal\n", task,
                env.Success() ? "success" : "failure", env.episode_steps(), phase,
                (env.CubePosition() - goal).norm());
    EXPECT_TRUE(env.Success()) << "task " << task;
  }
}

// Red cube pixels (0.96, 0.26, 0.33): their count and centroid (row, col).
struct RedBlob {
  int count = 0;
  double row = 0, col = 0;
};
RedBlob FindRed(const std::vector<uint8_t>& rgb, int size) {
  RedBlob b;
  for (int r = 0; r < size; ++r)
    for (int c = 0; c < size; ++c) {
      const uint8_t* p = &rgb[(static_cast<size_t>(r) * size + c) * 3];
      if (p[0] > 120 && p[1] < 100 && p[2] < 110 && p[0] > 2 * p[1]) {
        ++b.count;
        b.row += r;
        b.col += c;
      }
    }
  if (b.count > 0) b.row /= b.count, b.col /= b.count;
  return b;
}

// OGBench's pixel camera: image right is world +y, farther (smaller x) is
// higher up (row 0 = top); the goal image is rendered with the goal state.
TEST(CubeEnvTest, RendersFromTheFrontPixelsCamera) {
  CubeEnvOptions options = testing_util::CubeOptions();
  options.enable_rendering = true;
  options.scene.pixel_style = true;
  CubeEnv env(options);
  env.ResetToTask(2, 5);
  const int s = 64;
  const std::vector<uint8_t> image = env.Render();
  ASSERT_EQ(image.size(), static_cast<size_t>(s * s * 3));
  EXPECT_EQ(env.Render(), image) << "rendering must not change the state";
  ASSERT_EQ(env.goal_image().size(), image.size());
  EXPECT_NE(env.goal_image(), image);
  EXPECT_GT(FindRed(env.goal_image(), s).count, 0);

  env.SetArmJoints(Eigen::Matrix<double, 6, 1>::Zero());  // arm straight up, out of the way
  env.SetCube(Eigen::Vector3d(0.40, -0.15, 0.02), 0.0);
  const RedBlob left = FindRed(env.Render(), s);
  env.SetCube(Eigen::Vector3d(0.40, 0.15, 0.02), 0.0);
  const RedBlob right = FindRed(env.Render(), s);
  env.SetCube(Eigen::Vector3d(0.30, 0.0, 0.02), 0.0);
  const RedBlob far = FindRed(env.Render(), s);
  env.SetCube(Eigen::Vector3d(0.55, 0.0, 0.02), 0.0);
  const RedBlob near = FindRed(env.Render(), s);
  env.SetCube(Eigen::Vector3d(3.0, 0.0, 0.02), 0.0);  // behind the camera
  const RedBlob gone = FindRed(env.Render(), s);
  std::printf(
      "red cube pixels: y -0.15 at col %.1f, y +0.15 at col %.1f; x 0.30 at row %.1f, "
      "x 0.55 at row %.1f; %d pixels at x 0.55\n",
      left.col, right.col, far.row, near.row, near.count);
  ASSERT_GT(left.count, 0);
  ASSERT_GT(right.count, 0);
  ASSERT_GT(far.count, 0);
  ASSERT_GT(near.count, 0);
  EXPECT_LT(left.col + 10, right.col);
  EXPECT_LT(far.row + 3, near.row);
  EXPECT_EQ(gone.count, 0);
  EXPECT_THROW(CubeEnv(testing_util::CubeOptions()).Render(), std::logic_error);
}

// A goal given as an observation (the sim node's set_goal): the goal image is
// the scene posed as that observation, and the episode goes on bit-exactly.
TEST(CubeEnvTest, SetGoalObservationRendersItsGoalImageAndKeepsTheState) {
  CubeEnvOptions options = testing_util::CubeOptions();
  options.enable_rendering = true;
  options.scene.pixel_style = true;
  CubeEnv env(options), twin(options);
  env.ResetToTask(4, 11);
  twin.ResetToTask(4, 11);
  const CubeEnv::Observation task_goal = env.goal_observation();
  const std::vector<uint8_t> task_image = env.goal_image();
  const CubeEnv::Action a{0.3, -0.2, 0.1, 0.2, -1.0};
  env.Step(a);
  twin.Step(a);
  // The task's own goal, given back: its image again (the cube's tilt and the
  // arm's velocities are not posed, so not bit-exact, but within 1/255 on average).
  env.SetGoalObservation(task_goal);
  const std::vector<uint8_t> again = env.goal_image();
  ASSERT_EQ(again.size(), task_image.size());
  double diff = 0;
  for (size_t i = 0; i < again.size(); ++i) diff += std::abs(int(again[i]) - int(task_image[i]));
  EXPECT_LT(diff / again.size(), 1.0);
  // Another goal: the cube elsewhere; its image shows the red cube there.
  CubeEnv::Observation g = task_goal;
  g[19] = static_cast<float>(10 * (0.30 - 0.425));
  g[20] = static_cast<float>(10 * (-0.2));
  env.SetGoalObservation(g);
  EXPECT_EQ(env.goal_observation(), g);
  EXPECT_NEAR((env.GoalPosition() - CubePositionFromObservation(g.data())).norm(), 0.0, 1e-6);
  const RedBlob moved = FindRed(env.goal_image(), 64), before = FindRed(task_image, 64);
  ASSERT_GT(moved.count, 0);
  ASSERT_GT(before.count, 0);
  EXPECT_GT(std::hypot(moved.col - before.col, moved.row - before.row), 5.0);
  // The episode is untouched: both envs (the twin's marker moved the plain way) step on
  // identically.
  twin.SetGoal(CubePositionFromObservation(g.data()), CubeYawFromObservation(g.data()));
  for (int k = 0; k < 5; ++k) {
    env.Step(a);
    twin.Step(a);
  }
  EXPECT_EQ(env.GetObservation(), twin.GetObservation());
}

// One rendering env draws another env's scene bit for bit (the in-process
// evaluator of pixels policies renders every episode so): after a reset and
// mid-step, RenderStateOf(source) is what a rendering twin's Render() gives,
// and the source's episode goes on unchanged.
TEST(CubeEnvTest, RenderStateOfDrawsAnotherEnvsSceneBitForBit) {
  CubeEnvOptions options = testing_util::CubeOptions();
  options.scene.pixel_style = true;
  CubeEnv plain(options);  // no rendering, as the evaluator's episodes
  options.enable_rendering = true;
  CubeEnv drawn(options), renderer(options);
  plain.ResetToTask(3, 21);
  drawn.ResetToTask(3, 21);
  std::vector<uint8_t> image(64 * 64 * 3);
  renderer.RenderStateOf(plain, image.data());
  EXPECT_EQ(image, drawn.Render());
  const CubeEnv::Action a{0.4, 0.3, -0.5, 0.2, 1.0};
  for (int k = 0; k < 5; ++k) {
    plain.Step(a);
    drawn.Step(a);
  }
  renderer.RenderStateOf(plain, image.data());
  EXPECT_EQ(image, drawn.Render());
  EXPECT_NE(image, renderer.goal_image());
  plain.Step(a);
  drawn.Step(a);
  EXPECT_EQ(plain.GetObservation(), drawn.GetObservation()) << "the source's state was touched";
  // The goal image of the same task and seed, from the rendering env's own reset.
  renderer.ResetToTask(3, 21);
  EXPECT_EQ(renderer.goal_observation(), plain.goal_observation());
  EXPECT_EQ(renderer.goal_image(), drawn.goal_image());
  EXPECT_THROW(plain.RenderStateOf(drawn, image.data()), std::logic_error);
}

}  // namespace
}  // namespace msspr::sim
