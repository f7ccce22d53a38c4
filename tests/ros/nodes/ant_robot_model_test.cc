// The ant's URDF (msspr_sim/urdf/ant.urdf) against the MuJoCo model (no master needed).
#include "msspr_sim_nodes/ant_robot_model.h"

#include <gtest/gtest.h>

#include <string>

#include "msspr_sim_nodes/robot_model.h"
#include "replace_once.h"

namespace msspr::ros_bridge {
namespace {

std::string AntUrdf() {
  return ReadTextFile(std::string(MSSPR_SOURCE_DIR) + "/msspr_sim/urdf/ant.urdf");
}

// The error CheckAntUrdf gives, or "" when the description passes.
std::string AntError(const std::string& xml, const std::string& maze = "medium") {
  sim::AntMazeOptions o;
  o.maze = maze;
  sim::AntMaze env(o);
  try {
    CheckAntUrdf(xml, "ant.urdf", env, "torso");
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind("ant.urdf: ", 0), 0u) << "the error starts with the source: " << what;
    return what;
  }
  return "";
}

TEST(AntRobotModel, ShippedUrdfAgreesWithBothAntMazes) {
  for (const char* maze : {"medium", "large"}) EXPECT_EQ(AntError(AntUrdf(), maze), "") << maze;
  sim::AntMaze env(sim::AntMazeOptions{});
  const AntRobotModel m = CheckAntUrdf(AntUrdf(), "x", env, "torso");
  EXPECT_EQ(m.base, "torso");
  int revolute = 0;
  for (const auto& j : m.joints) revolute += j.revolute ? 1 : 0;
  EXPECT_EQ(revolute, 8);
  EXPECT_EQ(m.joints.size(), 12u);  // four fixed thighs and eight hinges
  // Hinge 0 (hip_1) turns aux_1 about z: a quarter turn maps x to y.
  for (const auto& j : m.joints) {
    if (j.name != "hip_1") continue;
    Eigen::VectorXd q = Eigen::VectorXd::Zero(8);
    q[0] = M_PI / 2;
    EXPECT_TRUE((m.ChildPose(j, q).linear() * Eigen::Vector3d::UnitX())
                    .isApprox(Eigen::Vector3d::UnitY(), 1e-12));
  }
}

TEST(AntRobotModel, DisagreementsNameTheElement) {
  const std::string u = AntUrdf();
  auto expect = [](const std::string& err, const std::string& says) {
    EXPECT_NE(err.find(says), std::string::npos) << "expected '" << says << "' in: " << err;
  };
  expect(AntError(""), "the robot description is empty");
  expect(AntError(testing_util::ReplaceOnce(u, "name=\"hip_3\"", "name=\"hip_9\"")),
         "joint 'hip_9' moves");
  expect(AntError(testing_util::ReplaceOnce(u, "<joint name=\"ankle_2\" type=\"revolute\">",
                                            "<joint name=\"ankle_2\" type=\"continuous\">")),
         "joint 'ankle_2' must be revolute");
  expect(AntError(testing_util::ReplaceOnce(u, "<axis xyz=\"0 0 1\"/>", "<axis xyz=\"0 1 0\"/>")),
         "joint 'hip_1': axis (0 1 0)");
  expect(AntError(testing_util::ReplaceOnce(u, "lower=\"-0.52359878\"", "lower=\"-0.6\"")),
         "joint 'hip_1': limits must be");
  // A leg 1 cm too long: forward kinematics disagrees with MuJoCo's.
  expect(AntError(testing_util::ReplaceOnce(u, "<origin xyz=\"0.2 0.2 0\" rpy=\"0 0 0\"/>",
                                            "<origin xyz=\"0.21 0.2 0\" rpy=\"0 0 0\"/>")),
         "link 'aux_1' lies at");
  expect(AntError(testing_util::ReplaceOnce(u, "<origin xyz=\"0.2 0.2 0\" rpy=\"0 0 0\"/>",
                                            "<origin xyz=\"0.2 0.2 0\" rpy=\"0 0 0.1\"/>")),
         "must not rotate");
  sim::AntMaze env(sim::AntMazeOptions{});
  EXPECT_THROW(CheckAntUrdf(u, "x", env, "base_link"), std::runtime_error);
}

}  // namespace
}  // namespace msspr::ros_bridge
