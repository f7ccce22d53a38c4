#include "msspr_sim/ant_maze.h"

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <stdexcept>
#include <string>

#include "msspr_sim/ant_model.h"
#include "msspr_sim/ant_planner.h"
#include "msspr_sim/ant_xy_env.h"
#include "msspr_sim/env_id.h"

namespace msspr::sim {
namespace {

constexpr double kPi = 3.14159265358979323846;
// OGBench's orders, spelled out here so that a change to ant_model.h fails.
const char* const kQposOrder[8] = {"hip_1", "ankle_1", "hip_2", "ankle_2",
                                   "hip_3", "ankle_3", "hip_4", "ankle_4"};
const char* const kActionOrder[8] = {"hip_4", "ankle_4", "hip_1", "ankle_1",
                                     "hip_2", "ankle_2", "hip_3", "ankle_3"};

AntMazeOptions AntOptions(const std::string& maze) {
  AntMazeOptions o;
  o.maze = maze;
  return o;
}

Eigen::VectorXd RandomAction(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Eigen::VectorXd a(kAntActionDim);
  for (int k = 0; k < kAntActionDim; ++k) a[k] = u(rng);
  return a;
}

// qpos0 with every ankle in the middle of its range, the torso at height z.
Eigen::VectorXd MidRangePose(const mjModel* m, double z) {
  Eigen::VectorXd q = AntQpos0();
  q[2] = z;
  for (int k = 0; k < kAntActionDim; ++k) {
    const int j = mj_name2id(m, mjOBJ_JOINT, kAntHingeJoints[k]);
    q[7 + k] = 0.5 * (m->jnt_range[2 * j] + m->jnt_range[2 * j + 1]);
  }
  return q;
}

TEST(AntMazeTest, EnvIdsNameTheMediumAndLargeMazes) {
  EXPECT_EQ(EnvIdNames(AntMazeEnvIds()),
            (std::set<std::string>{"antmaze-medium", "antmaze-large"}));
  EXPECT_EQ(AntMazeName(ParseEnvId("antmaze-large")), "large");
  EXPECT_THROW(ParseEnvId("pointmaze-medium"), std::invalid_argument);
  EXPECT_THROW(AntMazeName(EnvId::kPointMaze), std::invalid_argument);
  EXPECT_EQ(EnvIdName(AntMaze(AntOptions("large")).env_id()), "antmaze-large");
  EXPECT_THROW(AntMaze(AntOptions("nope")), std::invalid_argument);
}

// qpos (x, y, z, quaternion w first, 8 hinges) then qvel (14); qpos0's z is
// 0.75 and its quaternion (1, 0, 0, 0), each within the reset noise of 0.1.
TEST(AntMazeTest, ObservationLayoutAtReset) {
  AntMaze env(AntOptions("medium"));
  const mjModel* m = env.model();
  ASSERT_EQ(m->nq, 15);
  ASSERT_EQ(m->nv, 14);
  EXPECT_EQ(m->jnt_type[0], mjJNT_FREE);
  EXPECT_STREQ(mj_id2name(m, mjOBJ_JOINT, 0), "root");
  for (int k = 0; k < 8; ++k) {
    EXPECT_STREQ(kAntHingeJoints[k], kQposOrder[k]);
    EXPECT_STREQ(kAntActuatorJoints[k], kActionOrder[k]);
    const int j = mj_name2id(m, mjOBJ_JOINT, kQposOrder[k]);
    ASSERT_GE(j, 0) << kQposOrder[k];
    EXPECT_EQ(m->jnt_qposadr[j], 7 + k) << kQposOrder[k];
    EXPECT_EQ(m->jnt_dofadr[j], 6 + k) << kQposOrder[k];
  }
  // Angles in degrees in the MJCF, radians in the model.
  const int ankle_2 = mj_name2id(m, mjOBJ_JOINT, "ankle_2");
  EXPECT_NEAR(m->jnt_range[2 * ankle_2], -70 * kPi / 180, 1e-9);
  EXPECT_NEAR(m->jnt_range[2 * ankle_2 + 1], -30 * kPi / 180, 1e-9);

  for (uint64_t seed : {1u, 2u, 3u}) {
    const Eigen::VectorXd ob = env.ResetToTask(1, seed);
    ASSERT_EQ(ob.size(), 29);
    EXPECT_EQ(ob, env.state());
    EXPECT_EQ(ob.head<2>(), env.xy());
    EXPECT_EQ(ob.head(15), env.qpos());
    EXPECT_EQ(ob.tail(14), env.qvel());
    EXPECT_EQ(ob[2], env.z());
    EXPECT_NEAR(ob[2], 0.75, 0.1 + 1e-12);
    EXPECT_NEAR(ob[3], 1.0, 0.1 + 1e-12);  // quaternion w
    for (int k = 4; k < 15; ++k) EXPECT_NEAR(ob[k], 0.0, 0.1 + 1e-12) << k;
    // The start: task 1's start cell (1, 1) centre (0, 0) + U[-1, 1].
    EXPECT_LE(ob.head<2>().cwiseAbs().maxCoeff(), 1.0);
    EXPECT_GT(ob.tail(14).norm(), 0.0);  // qvel noise
    EXPECT_EQ(env.steps(), 0);
  }
}

// Hinge axes and ranges of OGBench's ant.xml (degrees there, radians here),
// armature 1, damping 1.
TEST(AntMazeTest, HingeAxesAndRangesMatchOgbench) {
  AntMaze env(AntOptions("medium"));
  const mjModel* m = env.model();
  struct Expect {
    const char* name;
    double ax, ay, az, lo, hi;
  };
  const double r = std::sqrt(0.5);
  const Expect hinges[8] = {{"hip_1", 0, 0, 1, -30, 30}, {"ankle_1", -r, r, 0, 30, 70},
                            {"hip_2", 0, 0, 1, -30, 30}, {"ankle_2", r, r, 0, -70, -30},
                            {"hip_3", 0, 0, 1, -30, 30}, {"ankle_3", -r, r, 0, -70, -30},
                            {"hip_4", 0, 0, 1, -30, 30}, {"ankle_4", r, r, 0, 30, 70}};
  for (const Expect& e : hinges) {
    const int j = mj_name2id(m, mjOBJ_JOINT, e.name);
    ASSERT_GE(j, 0) << e.name;
    EXPECT_EQ(m->jnt_type[j], mjJNT_HINGE) << e.name;
    EXPECT_NEAR(m->jnt_axis[3 * j], e.ax, 1e-9) << e.name;
    EXPECT_NEAR(m->jnt_axis[3 * j + 1], e.ay, 1e-9) << e.name;
    EXPECT_NEAR(m->jnt_axis[3 * j + 2], e.az, 1e-9) << e.name;
    EXPECT_TRUE(m->jnt_limited[j]) << e.name;
    EXPECT_NEAR(m->jnt_range[2 * j], e.lo * kPi / 180, 1e-9) << e.name;
    EXPECT_NEAR(m->jnt_range[2 * j + 1], e.hi * kPi / 180, 1e-9) << e.name;
    EXPECT_DOUBLE_EQ(m->dof_armature[m->jnt_dofadr[j]], 1.0) << e.name;
    EXPECT_DOUBLE_EQ(m->dof_damping[m->jnt_dofadr[j]], 1.0) << e.name;
  }
  EXPECT_DOUBLE_EQ(m->dof_armature[0], 0.0);  // the free joint
  EXPECT_DOUBLE_EQ(m->dof_damping[0], 0.0);
  const std::vector<PointMaze::AgentJoint> joints = env.AgentJoints();
  ASSERT_EQ(joints.size(), 9u);
  EXPECT_EQ(joints[0].type, "free");
  EXPECT_EQ(joints[4].name, "ankle_2");
}

// Action k drives kActionOrder[k] with gear 30: as a generalised force
// on that joint alone, and (from one pose, in the air) that joint moves most
// and in the torque's direction over one step.
TEST(AntMazeTest, ActuatorOrderMatchesOgbench) {
  AntMaze env(AntOptions("medium"));
  const mjModel* m = env.model();
  ASSERT_EQ(m->nu, 8);
  mjData* d = mj_makeData(m);
  const Eigen::VectorXd pose = MidRangePose(m, 3.0);
  for (int k = 0; k < 8; ++k) {
    const int joint = mj_name2id(m, mjOBJ_JOINT, kActionOrder[k]);
    EXPECT_EQ(m->actuator_trnid[2 * k], joint) << k;
    EXPECT_EQ(m->actuator_gear[6 * k], 30.0);
    EXPECT_EQ(m->actuator_ctrlrange[2 * k], -1.0);
    EXPECT_EQ(m->actuator_ctrlrange[2 * k + 1], 1.0);
    mj_resetData(m, d);
    for (int q = 0; q < 15; ++q) d->qpos[q] = pose[q];
    d->ctrl[k] = 1.0;
    mj_forward(m, d);
    for (int v = 0; v < 14; ++v) {
      EXPECT_NEAR(d->qfrc_actuator[v], v == m->jnt_dofadr[joint] ? 30.0 : 0.0, 1e-9)
          << "actuator " << k << " dof " << v;
    }
  }
  mj_deleteData(d);

  const Eigen::VectorXd qvel0 = Eigen::VectorXd::Zero(14);
  env.SetState(pose, qvel0);
  const Eigen::VectorXd rest = env.Step(Eigen::VectorXd::Zero(8));
  for (int k = 0; k < 8; ++k) {
    Eigen::VectorXd action = Eigen::VectorXd::Zero(8);
    action[k] = 1.0;
    env.SetState(pose, qvel0);
    const Eigen::VectorXd moved = env.Step(action);
    const Eigen::VectorXd delta = (moved - rest).segment(7, 8);  // hinge angles
    int argmax = 0;
    delta.cwiseAbs().maxCoeff(&argmax);
    EXPECT_STREQ(kQposOrder[argmax], kActionOrder[k]) << "action " << k;
    EXPECT_GT(delta[argmax], 0.0) << "action " << k;
  }
  EXPECT_THROW(env.Step(Eigen::VectorXd::Zero(2)), std::invalid_argument);
  Eigen::VectorXd bad = Eigen::VectorXd::Zero(8);
  bad[3] = std::nan("");
  EXPECT_THROW(env.Step(bad), std::invalid_argument);
}

TEST(AntMazeTest, MediumWallsAndFloorAreWhereOgbenchPutsThem) {
  AntMaze env(AntOptions("medium"));
  const mjModel* m = env.model();
  const MazeMap& map = env.map();
  int walls = 0;
  for (int i = 0; i < map.rows(); ++i) {
    for (int j = 0; j < map.cols(); ++j) {
      const std::string name = "block_" + std::to_string(i) + "_" + std::to_string(j);
      const int g = mj_name2id(m, mjOBJ_GEOM, name.c_str());
      if (!map.IsWall({i, j})) {
        EXPECT_LT(g, 0) << name;
        continue;
      }
      ++walls;
      ASSERT_GE(g, 0) << name;
      EXPECT_EQ(m->geom_type[g], mjGEOM_BOX);
      EXPECT_DOUBLE_EQ(m->geom_pos[3 * g], 4.0 * j - 4.0) << name;
      EXPECT_DOUBLE_EQ(m->geom_pos[3 * g + 1], 4.0 * i - 4.0) << name;
      EXPECT_DOUBLE_EQ(m->geom_pos[3 * g + 2], 1.0) << name;
      EXPECT_DOUBLE_EQ(m->geom_size[3 * g], 2.0);
      EXPECT_DOUBLE_EQ(m->geom_size[3 * g + 1], 2.0);
      EXPECT_DOUBLE_EQ(m->geom_size[3 * g + 2], 1.0);
      EXPECT_EQ(m->geom_conaffinity[g], 1);
    }
  }
  EXPECT_EQ(walls, 64 - static_cast<int>(map.FreeCells().size()));
  // Medium's row 1 is 10011001: cell (1, 3) is a wall block centred at (8, 0).
  const int g13 = mj_name2id(m, mjOBJ_GEOM, "block_1_3");
  ASSERT_GE(g13, 0);
  EXPECT_DOUBLE_EQ(m->geom_pos[3 * g13], 8.0);
  EXPECT_DOUBLE_EQ(m->geom_pos[3 * g13 + 1], 0.0);
  EXPECT_LT(mj_name2id(m, mjOBJ_GEOM, "block_1_1"), 0);
  // Floor: centred at (2 (W - 3), 2 (H - 3)) = (10, 10), half-size (16, 16).
  const int floor = mj_name2id(m, mjOBJ_GEOM, "floor");
  ASSERT_GE(floor, 0);
  EXPECT_DOUBLE_EQ(m->geom_pos[3 * floor], 10.0);
  EXPECT_DOUBLE_EQ(m->geom_pos[3 * floor + 1], 10.0);
  EXPECT_DOUBLE_EQ(m->geom_size[3 * floor], 16.0);
  EXPECT_DOUBLE_EQ(m->geom_size[3 * floor + 1], 16.0);
  // The ant's own geoms collide with floor and walls, not with each other.
  const int torso = mj_name2id(m, mjOBJ_GEOM, "torso_geom");
  ASSERT_GE(torso, 0);
  EXPECT_EQ(m->geom_conaffinity[torso], 0);
  EXPECT_EQ(m->geom_contype[torso], 1);
  EXPECT_DOUBLE_EQ(m->geom_margin[torso], 0.01);
  EXPECT_DOUBLE_EQ(m->opt.timestep, 0.02);
  EXPECT_EQ(m->opt.integrator, mjINT_RK4);
}

// A wall stops the ant: thrown hard toward wall block (1, 3) (x in [6, 10])
// from the free cell (1, 2), the torso (radius 0.25) never enters it.
TEST(AntMazeTest, WallStopsTheTorso) {
  AntMaze env(AntOptions("medium"));
  Eigen::VectorXd q = AntQpos0();
  q[0] = 4.0;
  Eigen::VectorXd v = Eigen::VectorXd::Zero(14);
  v[0] = 8.0;  // m/s toward +x
  env.SetState(q, v);
  double max_x = 0;
  for (int t = 0; t < 20; ++t) {
    env.Step(Eigen::VectorXd::Zero(8));
    max_x = std::max(max_x, env.xy().x());
  }
  EXPECT_LT(max_x, 6.0 - 0.25);
  EXPECT_GT(max_x, 4.5);  // it did move
}

TEST(AntMazeTest, SuccessWithinHalfAMetre) {
  AntMaze env(AntOptions("medium"));
  env.ResetToTask(1, 5);
  EXPECT_FALSE(env.success());  // task 1 ends at the far corner
  Eigen::VectorXd goal = env.goal();
  goal.head<2>() = env.xy() + Eigen::Vector2d(0.3, 0.39);  // 0.4924 m away
  env.SetGoal(goal);
  EXPECT_TRUE(env.success());
  goal.head<2>() = env.xy() + Eigen::Vector2d(0.3, 0.41);  // 0.508 m away
  env.SetGoal(goal);
  EXPECT_FALSE(env.success());
  EXPECT_THROW(env.SetGoal(Eigen::VectorXd::Zero(2)), std::invalid_argument);
  AntMazeOptions wide = AntOptions("medium");
  wide.success_radius = 1.0;
  AntMaze loose(wide);
  loose.ResetToTask(1, 5);
  loose.SetGoal(goal);
  EXPECT_TRUE(loose.success());
}

// The goal is a full 29-D state: a noisy pose after 5 random steps (so not
// the start's pose, and moving), placed at the goal xy.
TEST(AntMazeTest, GoalIsAFullStateAtTheGoalXy) {
  AntMaze env(AntOptions("large"));
  const Eigen::Vector2d start(0.3, -0.2), goal_xy(24.5, 11.7);
  const Eigen::VectorXd ob = env.Reset(start, goal_xy, 9);
  EXPECT_EQ(ob.head<2>(), start);
  const Eigen::VectorXd& goal = env.goal();
  ASSERT_EQ(goal.size(), 29);
  EXPECT_EQ(goal.head<2>(), goal_xy);
  EXPECT_EQ(env.goal_xy(), goal_xy);
  EXPECT_GT(goal[2], 0.2);
  EXPECT_LT(goal[2], 1.0);
  EXPECT_GT((goal.segment(2, 13) - ob.segment(2, 13)).norm(), 0.05);
  EXPECT_GT(goal.tail(14).norm(), 0.1);
  // Tasks: the goal xy is the goal cell's centre + U[-1, 1] per axis.
  for (int task = 1; task <= 5; ++task) {
    env.ResetToTask(task, 100 + task);
    const MazeMap::Task& t = env.map().Tasks()[task - 1];
    EXPECT_LE((env.goal_xy() - env.map().CellCenter(t.goal)).cwiseAbs().maxCoeff(), 1.0);
    EXPECT_LE((env.xy() - env.map().CellCenter(t.start)).cwiseAbs().maxCoeff(), 1.0);
  }
  EXPECT_THROW(env.ResetToTask(6, 1), std::invalid_argument);
  EXPECT_THROW(env.ResetToTask(0, 1), std::invalid_argument);
}

TEST(AntMazeTest, SeededEpisodeIsDeterministic) {
  AntMaze a(AntOptions("medium")), b(AntOptions("medium"));
  const auto run = [](AntMaze& env, uint64_t seed) {
    std::vector<Eigen::VectorXd> obs = {env.ResetToTask(2, seed), env.goal()};
    std::mt19937_64 rng(seed);
    for (int t = 0; t < 40; ++t) obs.push_back(env.Step(RandomAction(rng)));
    return obs;
  };
  const auto first = run(a, 42);
  run(a, 7);  // a different episode in between
  const auto again = run(a, 42);
  const auto other = run(b, 42);
  ASSERT_EQ(first.size(), again.size());
  for (size_t t = 0; t < first.size(); ++t) {
    EXPECT_EQ(first[t], again[t]) << t;
    EXPECT_EQ(first[t], other[t]) << t;
  }
  const auto different = run(b, 43);
  EXPECT_NE(first[0], different[0]);
  EXPECT_NE(first.back(), different.back());
  EXPECT_EQ(a.steps(), 40);
  // ResetRandom: deterministic too, a free start and a vertex goal cell.
  const Eigen::VectorXd r1 = a.ResetRandom(11), g1 = a.goal();
  EXPECT_EQ(b.ResetRandom(11), r1);
  EXPECT_EQ(b.goal(), g1);
}

// Ants of one maze share one compiled model (the evaluators build hundreds side
// by side); each keeps its own state, and another maze gets its own model.
TEST(AntMazeTest, MazesOfOneMapShareOneCompiledModelAndKeepTheirOwnState) {
  AntMaze a(AntOptions("medium")), b(AntOptions("medium")), large(AntOptions("large"));
  EXPECT_EQ(a.model(), b.model());
  EXPECT_NE(a.model(), large.model());
  EXPECT_NE(a.data(), b.data());
  const Eigen::VectorXd start_a = a.ResetToTask(1, 5), start_b = b.ResetToTask(1, 5);
  ASSERT_EQ(start_a, start_b);
  std::mt19937_64 rng(3);
  Eigen::VectorXd last;
  for (int t = 0; t < 20; ++t) last = a.Step(RandomAction(rng));
  EXPECT_NE(last, start_a);
  EXPECT_EQ(b.state(), start_b);  // stepping a left b where it was
  rng.seed(3);
  for (int t = 0; t < 20; ++t) b.Step(RandomAction(rng));
  EXPECT_EQ(b.state(), last);
  // The model lives while any ant holds it: one built after another is gone shares it.
  const mjModel* shared = b.model();
  {
    AntMaze c(AntOptions("medium"));
    EXPECT_EQ(c.model(), shared);
  }
  AntMaze d(AntOptions("medium"));
  EXPECT_EQ(d.model(), shared);
}

// The ant with zero action settles on its legs and stays upright.
TEST(AntMazeTest, AntAtRestStaysUpright) {
  AntMaze env(AntOptions("medium"));
  env.ResetToTask(1, 3);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(8);
  double lo = 1e9, hi = -1e9;
  for (int t = 0; t < 200; ++t) {
    env.Step(zero);
    lo = std::min(lo, env.z());
    hi = std::max(hi, env.z());
  }
  EXPECT_GE(lo, 0.3);
  EXPECT_LE(hi, 1.0);
  // Upright: the torso's z axis points up (quaternion w, x, y, z).
  const Eigen::VectorXd q = env.qpos();
  const double up = 1.0 - 2.0 * (q[4] * q[4] + q[5] * q[5]) / q.segment(3, 4).squaredNorm();
  EXPECT_GT(up, 0.9);
  EXPECT_LT(env.qvel().norm(), 0.05);  // at rest
  EXPECT_FALSE(env.truncated());
}

TEST(AntMazeTest, TruncatesAtMaxEpisodeSteps) {
  AntMazeOptions o = AntOptions("medium");
  o.max_episode_steps = 3;
  AntMaze env(o);
  env.ResetToTask(1, 1);
  for (int t = 0; t < 3; ++t) {
    EXPECT_FALSE(env.truncated());
    env.Step(Eigen::VectorXd::Zero(8));
  }
  EXPECT_TRUE(env.truncated());
  EXPECT_EQ(AntMazeOptions().max_episode_steps, 1000);
  EXPECT_EQ(AntMazeOptions().success_radius, 0.5);
}

// --- AntXyEnv ---------------------------------------------------------------

TEST(AntXyEnvTest, ObservationIsTheBodyThenTheDirection) {
  AntXyEnv env;
  const Eigen::VectorXd ob = env.Reset(4);
  ASSERT_EQ(ob.size(), 29);
  EXPECT_EQ(ob.head(13), env.qpos().tail(13));  // qpos[2:]
  EXPECT_EQ(ob.segment(13, 14), env.qvel());
  EXPECT_EQ(ob.tail<2>(), env.direction());
  EXPECT_NEAR(env.direction().norm(), 1.0, 1e-12);
  EXPECT_NEAR(ob[0], 0.75, 0.1 + 1e-12);  // z
  EXPECT_NEAR(env.xy().norm(), 0.0, 0.15);
  // No walls: the floor alone, half-size 40.
  const mjModel* m = env.model();
  const int floor = mj_name2id(m, mjOBJ_GEOM, "floor");
  ASSERT_GE(floor, 0);
  EXPECT_DOUBLE_EQ(m->geom_size[3 * floor], 40.0);
  EXPECT_EQ(m->ngeom, 1 + 13);
}

// Reward = xy displacement over the step . direction: pushing the torso along
// the direction is rewarded, against it penalised.
TEST(AntXyEnvTest, RewardIsDisplacementAlongTheDirection) {
  AntXyEnv env;
  env.Reset(1);
  Eigen::VectorXd q = AntQpos0();
  q[2] = 0.6;
  Eigen::VectorXd v = Eigen::VectorXd::Zero(14);
  v[0] = 1.5;
  v[1] = 0.5;
  for (const Eigen::Vector2d& dir :
       {Eigen::Vector2d(1, 0), Eigen::Vector2d(-1, 0), Eigen::Vector2d(0, 3)}) {
    env.SetState(q, v);
    env.SetDirection(dir);
    const Eigen::Vector2d before = env.xy();
    const AntXyEnv::StepResult r = env.Step(Eigen::VectorXd::Zero(8));
    EXPECT_NEAR(r.reward, (env.xy() - before).dot(dir.normalized()), 1e-12);
    if (dir.x() > 0) {
      EXPECT_GT(r.reward, 0.05);
    } else if (dir.x() < 0) {
      EXPECT_LT(r.reward, -0.05);
    } else {
      EXPECT_GT(r.reward, 0.01);
    }
    EXPECT_FALSE(r.terminated);
  }
  EXPECT_THROW(env.SetDirection(Eigen::Vector2d::Zero()), std::invalid_argument);
}

TEST(AntXyEnvTest, TerminatesWhenTheTorsoLeavesTheHealthyRange) {
  AntXyEnv env;
  env.Reset(2);
  EXPECT_TRUE(env.healthy());
  EXPECT_FALSE(env.Step(Eigen::VectorXd::Zero(8)).terminated);
  Eigen::VectorXd q = AntQpos0();
  const Eigen::VectorXd v = Eigen::VectorXd::Zero(14);
  q[2] = 1.5;  // falls 5 cm in a step: still above 1.0
  env.SetState(q, v);
  EXPECT_FALSE(env.healthy());
  AntXyEnv::StepResult r = env.Step(Eigen::VectorXd::Zero(8));
  EXPECT_GT(env.z(), 1.0);
  EXPECT_TRUE(r.terminated);
  q[2] = 0.95;
  env.SetState(q, v);
  EXPECT_TRUE(env.healthy());
  q[2] = 0.15;
  env.SetState(q, v);
  EXPECT_FALSE(env.healthy());
  // A custom range.
  AntXyEnvOptions o;
  o.healthy_z_min = 0.8;
  AntXyEnv strict(o);
  strict.Reset(2);
  bool terminated = false;
  for (int t = 0; t < 30 && !terminated; ++t) {
    terminated = strict.Step(Eigen::VectorXd::Zero(8)).terminated;
  }
  EXPECT_TRUE(terminated);  // the resting ant's torso sits below 0.8
}

TEST(AntXyEnvTest, DirectionRedrawnEveryIntervalAndEpisodesAreSeeded) {
  AntXyEnvOptions o;
  o.direction_interval = 10;
  o.max_episode_steps = 25;
  AntXyEnv a(o), b(o);
  a.Reset(5);
  b.Reset(5);
  std::mt19937_64 rng(5);
  Eigen::Vector2d dir = a.direction();
  for (int t = 1; t <= 25; ++t) {
    const Eigen::VectorXd action = RandomAction(rng);
    const Eigen::Vector2d before = a.xy();
    const Eigen::Vector2d used = a.direction();
    const AntXyEnv::StepResult ra = a.Step(action);
    const AntXyEnv::StepResult rb = b.Step(action);
    EXPECT_EQ(ra.observation, rb.observation) << t;
    EXPECT_EQ(ra.reward, rb.reward) << t;
    EXPECT_NEAR(ra.reward, (a.xy() - before).dot(used), 1e-12);
    EXPECT_EQ(ra.observation.tail<2>(), a.direction());
    if (t % 10 == 0) {
      EXPECT_NE(a.direction(), dir) << t;
      dir = a.direction();
    } else {
      EXPECT_EQ(a.direction(), dir) << t;
    }
    EXPECT_EQ(ra.truncated, t == 25) << t;
  }
  EXPECT_NE(AntXyEnv().Reset(6), AntXyEnv().Reset(5));
  EXPECT_EQ(AntXyEnv().Reset(5), AntXyEnv().Reset(5));
}

// --- AntPlanner -------------------------------------------------------------

TEST(AntPlannerTest, CellsFollowOgbenchsFormula) {
  EXPECT_EQ(AntPlanner::XYToCell({0, 0}), (Cell{1, 1}));
  EXPECT_EQ(AntPlanner::XYToCell({1.99, -1.99}), (Cell{1, 1}));
  EXPECT_EQ(AntPlanner::XYToCell({2.01, 2.01}), (Cell{2, 2}));
  EXPECT_EQ(AntPlanner::XYToCell({20.5, 8.1}), (Cell{3, 6}));  // (y + 6) / 4 = 3.525
}

TEST(AntPlannerTest, SubgoalIsTheNeighbourNearestTheGoal) {
  const MazeMap map = MazeMap::FromName("medium");
  AntPlanner planner(map);
  // Medium (1, 1) -> (6, 6): both free neighbours of (1, 1), (2, 1) and
  // (1, 2), are 9 BFS steps from the goal (10 from (1, 1)); OGBench's scan
  // order (up, left, down, right) keeps the first, (2, 1).
  const Eigen::Vector2d goal = map.CellCenter({6, 6}) + Eigen::Vector2d(0.7, -0.4);
  ASSERT_EQ(map.BfsDistance({2, 1}, {6, 6}), 9);
  ASSERT_EQ(map.BfsDistance({1, 2}, {6, 6}), 9);
  EXPECT_EQ(planner.Subgoal({0.3, -0.5}, goal), map.CellCenter({2, 1}));
  // From (1, 2) the only lower neighbour is (2, 2) (8 steps).
  EXPECT_EQ(planner.Subgoal(map.CellCenter({1, 2}), goal), map.CellCenter({2, 2}));
  const Eigen::Vector2d dir = planner.Direction({0.3, -0.5}, goal);
  EXPECT_NEAR(dir.norm(), 1.0, 1e-6);
  const Eigen::Vector2d expect = map.CellCenter({2, 1}) - Eigen::Vector2d(0.3, -0.5);
  EXPECT_NEAR((dir - expect / (expect.norm() + 1e-6)).norm(), 0.0, 1e-12);
  // In the goal cell: its centre, not the goal point.
  EXPECT_EQ(planner.Subgoal(map.CellCenter({6, 6}) + Eigen::Vector2d(1, 1), goal),
            map.CellCenter({6, 6}));
  // Every step of a subgoal walk lowers the BFS distance by one.
  for (const MazeMap::Task& t : map.Tasks()) {
    Cell c = t.start;
    const Eigen::Vector2d g = map.CellCenter(t.goal);
    for (int n = 0; n < 40 && c != t.goal; ++n) {
      const Cell next = AntPlanner::XYToCell(planner.Subgoal(map.CellCenter(c), g));
      EXPECT_EQ(map.BfsDistance(next, t.goal), map.BfsDistance(c, t.goal) - 1);
      c = next;
    }
    EXPECT_EQ(c, t.goal) << "task " << t.id;
  }
}

// A point that follows the planner's directions at 0.2 m per step reaches
// every evaluation goal of both mazes.
TEST(AntPlannerTest, FollowingTheDirectionsReachesEveryTaskGoal) {
  for (const std::string name : {"medium", "large"}) {
    const MazeMap map = MazeMap::FromName(name);
    AntPlanner planner(map);
    for (const MazeMap::Task& t : map.Tasks()) {
      Eigen::Vector2d p = map.CellCenter(t.start) + Eigen::Vector2d(0.6, -0.8);
      const Eigen::Vector2d goal = map.CellCenter(t.goal);
      int steps = 0;
      for (; steps < 1000 && (p - goal).norm() > 0.5; ++steps) {
        p += 0.2 * planner.Direction(p, goal);
        ASSERT_FALSE(map.IsWall(AntPlanner::XYToCell(p))) << name << " task " << t.id;
      }
      EXPECT_LT(steps, 1000) << name << " task " << t.id;
    }
  }
}

}  // namespace
}  // namespace msspr::sim
