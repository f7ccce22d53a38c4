#include "msspr_sim/arm_ik.h"

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <random>
#include <string>

#include "cube_test_util.h"
#include "msspr_sim/cube_scene.h"

namespace msspr::sim {
namespace {

Eigen::VectorXd Home() {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(7);
  q.head<6>() << -M_PI / 2, -M_PI / 2, M_PI / 2, -M_PI / 2, -M_PI / 2, 0;
  return q;
}

Eigen::VectorXd Uniform(std::mt19937_64& rng, int n, double half) {
  Eigen::VectorXd v(n);
  for (int i = 0; i < n; ++i) v[i] = std::uniform_real_distribution<double>(-half, half)(rng);
  return v;
}

TEST(ArmIkTest, PoseErrorIsTheRotationVector) {
  Eigen::Isometry3d current = Eigen::Isometry3d::Identity();
  current.linear() =
      Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  current.translation() << 0.1, 0.2, 0.3;
  const Eigen::Vector3d w = Eigen::Vector3d(-0.3, 0.5, 0.2);
  Eigen::Isometry3d target = current;
  target.linear() =
      Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix() * current.linear();
  target.translation() += Eigen::Vector3d(0.01, -0.02, 0.03);
  const Eigen::Matrix<double, 6, 1> e = PoseError(target, current);
  EXPECT_LT((e.head<3>() - Eigen::Vector3d(0.01, -0.02, 0.03)).norm(), 1e-15);
  EXPECT_LT((e.tail<3>() - w).norm(), 1e-12);
  // Angles past pi wrap: a 1.5 pi turn is a -0.5 pi turn.
  target.linear() =
      Eigen::AngleAxisd(1.5 * M_PI, Eigen::Vector3d::UnitZ()).toRotationMatrix() * current.linear();
  EXPECT_LT((PoseError(target, current).tail<3>() - Eigen::Vector3d(0, 0, -0.5 * M_PI)).norm(),
            1e-12);
}

// The Jacobian equals finite differences of the URDF forward kinematics and
// MuJoCo's mj_jacSite on the generated scene.
TEST(ArmIkTest, JacobianMatchesFiniteDifferencesAndMujoco) {
  const ArmModel arm = ArmModel::FromFile(testing_util::ArmUrdfPath());
  const ArmIk ik(arm);
  const std::string xml = CubeSceneMjcf(arm);
  const std::filesystem::path dir = MSSPR_TEST_TMPDIR;
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "arm_ik_scene.xml").string();
  std::ofstream(path) << xml;
  char error[1024] = {0};
  std::unique_ptr<mjModel, void (*)(mjModel*)> m(mj_loadXML(path.c_str(), nullptr, error, 1024),
                                                 mj_deleteModel);
  ASSERT_TRUE(m) << error;
  std::unique_ptr<mjData, void (*)(mjData*)> d(mj_makeData(m.get()), mj_deleteData);
  std::mt19937_64 rng(11);
  double max_fd = 0, max_mj = 0;
  for (int k = 0; k < 10; ++k) {
    Eigen::VectorXd q = Home();
    q.head<6>() += Uniform(rng, 6, 1.5);
    for (int link : {arm.flange_link(), arm.tip_link()}) {
      const auto j = ik.Jacobian(link, q);
      ASSERT_EQ(j.cols(), 6);
      const Eigen::Isometry3d base = arm.LinkPose(link, q);
      const double h = 1e-7;
      for (int i = 0; i < 6; ++i) {
        Eigen::VectorXd qh = q;
        qh[i] += h;
        // PoseError(moved, base) / h is the twist per unit joint motion.
        const Eigen::Matrix<double, 6, 1> fd = PoseError(arm.LinkPose(link, qh), base) / h;
        max_fd = std::max(max_fd, (fd - j.col(i)).norm());
      }
      // MuJoCo: site Jacobian, 3 x nv row-major each.
      mj_resetData(m.get(), d.get());
      for (int i = 0; i < 6; ++i) d->qpos[i] = q[i];
      mj_kinematics(m.get(), d.get());
      mj_comPos(m.get(), d.get());
      const int site = mj_name2id(m.get(), mjOBJ_SITE, arm.links()[link].name.c_str());
      ASSERT_GE(site, 0);
      std::vector<mjtNum> jacp(3 * m->nv), jacr(3 * m->nv);
      mj_jacSite(m.get(), d.get(), jacp.data(), jacr.data(), site);
      for (int r = 0; r < 3; ++r)
        for (int i = 0; i < 6; ++i) {
          max_mj = std::max(max_mj, std::abs(jacp[r * m->nv + i] - j(r, i)));
          max_mj = std::max(max_mj, std::abs(jacr[r * m->nv + i] - j(3 + r, i)));
        }
    }
  }
  std::printf("Jacobian: max |J - finite differences| %.3g, max |J - mj_jacSite| %.3g\n", max_fd,
              max_mj);
  EXPECT_LT(max_fd, 1e-5);
  EXPECT_LT(max_mj, 1e-12);
}

// Reachable targets (the flange pose of a random configuration near home,
// as the cube task's targets are) are met within OGBench's tolerances and
// 20 iterations, starting from home.
TEST(ArmIkTest, ConvergesToReachablePoses) {
  const ArmModel arm = ArmModel::FromFile(testing_util::ArmUrdfPath());
  const ArmIk ik(arm);
  std::mt19937_64 rng(2026);
  const Eigen::VectorXd lo = arm.LowerLimits(), hi = arm.UpperLimits();
  int worst_iterations = 0;
  double worst_pos = 0, worst_rot = 0;
  for (int k = 0; k < 50; ++k) {
    Eigen::VectorXd q_goal = Home();
    q_goal.head<6>() += Uniform(rng, 6, 0.5);
    for (int link : {arm.flange_link(), arm.tip_link()}) {
      const Eigen::Isometry3d target = arm.LinkPose(link, q_goal);
      const ArmIkResult r = ik.Solve(target, link, Home());
      ASSERT_TRUE(r.converged) << "target " << k << ": " << r.position_error << " m, "
                               << r.rotation_error << " rad after " << r.iterations;
      const Eigen::Matrix<double, 6, 1> e = PoseError(target, arm.LinkPose(link, r.q));
      EXPECT_LE(e.head<3>().norm(), 1e-4);
      EXPECT_LE(e.tail<3>().norm(), 1e-4);
      EXPECT_TRUE((r.q.array() >= lo.array()).all() && (r.q.array() <= hi.array()).all());
      EXPECT_EQ(r.q[6], 0.0) << "the gripper is not the IK's";
      worst_iterations = std::max(worst_iterations, r.iterations);
      worst_pos = std::max(worst_pos, r.position_error);
      worst_rot = std::max(worst_rot, r.rotation_error);
    }
  }
  std::printf("IK over 100 targets: at most %d iterations, errors <= %.2g m, %.2g rad\n",
              worst_iterations, worst_pos, worst_rot);
  EXPECT_LE(worst_iterations, 20);
}

// A target that needs the elbow past its limit (+-3.1415): the clamped solver
// stays inside the limits (and reports no convergence); the unclamped one,
// as OGBench's, leaves them.
TEST(ArmIkTest, RespectsJointLimits) {
  const ArmModel arm = ArmModel::FromFile(testing_util::ArmUrdfPath());
  Eigen::VectorXd q_goal = Home();
  q_goal[2] = 3.3;  // beyond the elbow's limit
  Eigen::VectorXd q0 = Home();
  q0[2] = 3.0;
  const int flange = arm.flange_link();
  const Eigen::Isometry3d target = arm.LinkPose(flange, q_goal);
  const ArmIkResult clamped = ArmIk(arm).Solve(target, flange, q0);
  EXPECT_LE(clamped.q[2], 3.1415);
  EXPECT_TRUE((clamped.q.array() >= arm.LowerLimits().array()).all() &&
              (clamped.q.array() <= arm.UpperLimits().array()).all());
  ArmIkOptions free;
  free.clamp_to_limits = false;
  const ArmIkResult unclamped = ArmIk(arm, free).Solve(target, flange, q0);
  EXPECT_TRUE(unclamped.converged);
  EXPECT_GT(unclamped.q[2], 3.1415) << "the test's target does not need the elbow past its limit";
}

// The step cap: one iteration toward a far target moves no joint by more
// than 45 degrees.
TEST(ArmIkTest, CapsEachStep) {
  const ArmModel arm = ArmModel::FromFile(testing_util::ArmUrdfPath());
  ArmIkOptions one;
  one.max_iterations = 1;
  Eigen::VectorXd q_goal = Home();
  q_goal.head<6>() += Eigen::VectorXd::Constant(6, 1.2);
  const ArmIkResult r =
      ArmIk(arm, one).Solve(arm.LinkPose(arm.flange_link(), q_goal), arm.flange_link(), Home());
  EXPECT_EQ(r.iterations, 1);
  EXPECT_FALSE(r.converged);
  const double biggest = (r.q - Home()).cwiseAbs().maxCoeff();
  EXPECT_NEAR(biggest, M_PI / 4, 1e-12);
}

}  // namespace
}  // namespace msspr::sim
