#include "msspr_sim/cube_oracle.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "cube_test_util.h"

namespace msspr::sim {
namespace {

std::vector<CubePlanSample> Column(const std::vector<double>& v) {
  std::vector<CubePlanSample> out;
  for (double x : v) out.push_back(CubePlanSample::Constant(x));
  return out;
}

// SciPy: gaussian_filter1d(x, 0.5) has taps (0.00026, 0.10645, 0.78657,
// 0.10645, 0.00026) and mode "reflect" (d c b a | a b c d | d c b a).
TEST(CubeOracleTest, NoiseSmoothingIsScipysGaussianFilter) {
  const auto mid = SmoothPlanNoise(Column({0, 0, 0, 1, 0, 0, 0}));
  const double taps[] = {0.00026, 0.10645, 0.78657, 0.10645, 0.00026};
  for (int i = 0; i < 7; ++i)
    EXPECT_NEAR(mid[i][0], i >= 1 && i <= 5 ? taps[i - 1] : 0.0, 5e-6) << i;
  const auto edge = SmoothPlanNoise(Column({1, 0, 0, 0}));
  EXPECT_NEAR(edge[0][2], 0.78657 + 0.10645, 1e-5);  // x[-1] = x[0]
  EXPECT_NEAR(edge[1][2], 0.10645 + 0.00026, 1e-5);  // x[-1] = x[0] seen 2 steps on
  EXPECT_NEAR(edge[2][2], 0.00026, 1e-5);
  for (const auto& x : SmoothPlanNoise(Column({2.5, 2.5, 2.5})))
    EXPECT_NEAR(x[4], 2.5, 1e-12) << "a constant stays constant";
}

// Without noise the plan starts at the measured pinch, lasts 4.4 +- 0.08 s,
// closes the gripper at the cube and ends open.
TEST(CubeOracleTest, PlanFollowsTheKeyframes) {
  CubeEnv env(testing_util::CubeOptions());
  env.ResetForCollection(3);
  CubePlayOracleOptions o;
  o.noise_scale = 0;
  CubePlayOracle oracle(7, o);
  oracle.Act(env);
  const auto& plan = oracle.plan();
  EXPECT_GE(plan.size(), 87u);
  EXPECT_LE(plan.size(), 90u);
  EXPECT_LT((plan[0].head<3>() - env.PinchPosition()).norm(), 1e-12);
  EXPECT_NEAR(plan[0][4], 0.0, 1e-12);
  // Somewhere the plan is at the cube, closed; it ends open.
  double closest = 1e9, grip_there = -1;
  for (const auto& x : plan) {
    const double d = (x.head<3>() - env.CubePosition()).norm();
    if (d < closest) closest = d, grip_there = x[4];
  }
  EXPECT_LT(closest, 1e-9);
  EXPECT_GT(grip_there, 0.0);
  EXPECT_NEAR(plan.back()[4], 0.0, 1e-12);
  for (const auto& x : plan) EXPECT_TRUE(x.allFinite());
}

TEST(CubeOracleTest, SameSeedSameActions) {
  CubeEnv a(testing_util::CubeOptions()), b(testing_util::CubeOptions());
  a.ResetForCollection(11);
  b.ResetForCollection(11);
  CubePlayOracle oa(5), ob(5);
  for (int t = 0; t < 120; ++t) {
    const CubeEnv::Action x = oa.Act(a), y = ob.Act(b);
    ASSERT_EQ(x, y) << "step " << t;
    for (double v : x) ASSERT_TRUE(v >= -1 && v <= 1);
    a.Step(x);
    b.Step(y);
  }
  EXPECT_EQ(a.GetObservation(), b.GetObservation());
  CubeEnv c(testing_util::CubeOptions());
  c.ResetForCollection(11);
  CubePlayOracle oc(6);
  EXPECT_NE(oc.Act(c), CubePlayOracle(5).Act(c));
}

// The angle between two yaws, modulo 2 pi, in [0, pi].
double YawGap(double a, double b) {
  const double d = std::fmod(std::abs(a - b), 2 * M_PI);
  return std::min(d, 2 * M_PI - d);
}

// OGBench's shortest_yaw takes both yaws in [0, 2 pi): the chosen pick yaw
// is one of the cube's four symmetric yaws and never more than pi/4 from
// the effector's, for every pair of yaws in (-pi, pi]. (Taking only the
// effector's yaw in [0, 2 pi) asked for turns of up to pi when the cube's
// yaw was negative.)
TEST(CubeOracleTest, PickYawIsTheCubesSymmetricYawNearestTheEffector) {
  double worst = 0;
  for (int i = 0; i <= 72; ++i) {
    for (int j = 0; j <= 72; ++j) {
      const double effector = -M_PI + i * 2 * M_PI / 72, cube = -M_PI + j * 2 * M_PI / 72;
      const double yaw = NearestSymmetricYaw(cube, effector);
      // A symmetric yaw of the cube: a multiple of pi/2 away from it.
      const double k = (yaw - cube) / (M_PI / 2);
      ASSERT_NEAR(k, std::round(k), 1e-9) << "effector " << effector << " cube " << cube;
      worst = std::max(worst, YawGap(yaw, effector));
    }
  }
  EXPECT_LE(worst, M_PI / 4 + 1e-9);
  EXPECT_NEAR(NearestSymmetricYaw(-3.0, 3.0), -3.0 + 2 * M_PI, 1e-12);
  // The case the effector-only window got wrong: effector -0.1 (6.18 in
  // [0, 2 pi)) and cube -3.0 asked for -3.0 + 2 pi = 3.28, half a turn away.
  EXPECT_NEAR(NearestSymmetricYaw(-3.0, -0.1), -3.0 + 3 * M_PI, 1e-12);
  EXPECT_NEAR(YawIn0To2Pi(-0.5), 2 * M_PI - 0.5, 1e-12);
  EXPECT_NEAR(YawIn0To2Pi(7.0), 7.0 - 2 * M_PI, 1e-12);
}

// Over many collection resets, the noise-free plan's pick keyframe (the
// plan sample at the cube) turns the wrist by at most pi/4 from where it
// started, and its place keyframe by at most pi/4 from the pick's.
TEST(CubeOracleTest, PlansNeverAskForMoreThanAnEighthTurn) {
  CubeEnv env(testing_util::CubeOptions());
  CubePlayOracleOptions o;
  o.noise_scale = 0;
  o.time_jitter = 0;
  for (uint64_t seed = 1; seed <= 100; ++seed) {
    env.ResetForCollection(seed);
    CubePlayOracle oracle(seed, o);
    oracle.Act(env);
    const auto& plan = oracle.plan();
    // Keyframes without jitter: pick_start at 1.0 s, place_start at 3.2 s.
    const double at_cube = plan[20][3], at_target = plan[64][3];
    EXPECT_LT((plan[20].head<3>() - env.CubePosition()).norm(), 1e-9) << "seed " << seed;
    EXPECT_LE(YawGap(at_cube, env.PinchYaw()), M_PI / 4 + 1e-6) << "seed " << seed;
    EXPECT_LE(YawGap(at_target, at_cube), M_PI / 4 + 1e-6) << "seed " << seed;
  }
}

// Play data: over a 1000-step collection episode the oracle moves the cube
// to its target in most pick-and-place cycles.
TEST(CubeOracleTest, PlayCyclesPlaceTheCube) {
  CubeEnv env(testing_util::CubeOptions());
  int cycles = 0, placed = 0;
  for (uint64_t seed : {1, 2}) {
    env.ResetForCollection(seed);
    CubePlayOracle oracle(seed);
    for (int t = 0; t < 1000; ++t) {
      const Eigen::Vector3d cube = env.CubePosition(), goal = env.GoalPosition();
      const int before = oracle.cycles();
      const CubeEnv::Action a = oracle.Act(env);
      if (before > 0 && oracle.cycles() > before) {  // the previous cycle just ended
        ++cycles;
        placed += (cube - goal).norm() <= 0.04;
      }
      env.Step(a);
    }
  }
  std::printf("play oracle: the cube ended within 0.04 m of the target in %d of %d cycles\n",
              placed, cycles);
  EXPECT_GE(cycles, 18);  // ~4.4 s (88 steps) per cycle
  EXPECT_GE(placed, 0.8 * cycles);
}

}  // namespace
}  // namespace msspr::sim
