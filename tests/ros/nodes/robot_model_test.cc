// The point robot's URDF against the MuJoCo model (no master needed).
#include "msspr_sim_nodes/robot_model.h"

#include <gtest/gtest.h>

#include <string>

#include "replace_once.h"

namespace msspr::ros_bridge {
namespace {

std::string ShippedUrdf() {
  return ReadTextFile(std::string(MSSPR_SOURCE_DIR) + "/msspr_sim/urdf/point_robot.urdf");
}

// The error CheckPointRobotUrdf gives, or "" when the description passes.
std::string Error(const std::string& xml, const std::string& maze = "medium") {
  sim::PointMazeOptions o;
  o.maze = maze;
  sim::PointMaze env(o);
  try {
    CheckPointRobotUrdf(xml, "test.urdf", env, "world", "agent");
  } catch (const std::runtime_error& e) {
    const std::string what = e.what();
    EXPECT_EQ(what.rfind("test.urdf: ", 0), 0u) << "the error starts with the source: " << what;
    return what;
  }
  return "";
}

TEST(RobotModel, ShippedUrdfAgreesWithEveryMaze) {
  for (const char* maze : {"arena", "medium", "large", "giant"})
    EXPECT_EQ(Error(ShippedUrdf(), maze), "") << maze;
  sim::PointMaze env(sim::PointMazeOptions{});
  const auto m = CheckPointRobotUrdf(ShippedUrdf(), "x", env, "world", "agent");
  ASSERT_EQ(m.chain.size(), 2u);
  EXPECT_EQ(m.chain[0].name, "agent_x");
  EXPECT_EQ(m.chain[0].parent, "world");
  EXPECT_EQ(m.chain[1].child, "agent");
  EXPECT_EQ(m.chain[0].axis, Eigen::Vector3d::UnitX());
  EXPECT_EQ(m.chain[1].axis, Eigen::Vector3d::UnitY());
  EXPECT_DOUBLE_EQ(m.chain[0].origin.z(), sim::kAgentRadius);
  EXPECT_DOUBLE_EQ(m.radius, sim::kAgentRadius);
}

TEST(RobotModel, DisagreementsNameTheElement) {
  const std::string u = ShippedUrdf();
  auto expect = [](const std::string& err, const std::string& says) {
    EXPECT_NE(err.find(says), std::string::npos) << "expected '" << says << "' in: " << err;
  };
  expect(Error(""), "the robot description is empty");
  expect(Error("<robot name='x'><link name='world'/>"), "urdfdom could not parse");
  expect(Error(testing_util::ReplaceOnce(u, "name=\"agent_y\"", "name=\"agent_z\"")),
         "joint 'agent_z': joint 2 of the chain must be the simulation's 'agent_y'");
  expect(Error(testing_util::ReplaceOnce(u, "<axis xyz=\"0 1 0\"/>", "<axis xyz=\"1 0 0\"/>")),
         "joint 'agent_y': axis (1 0 0) differs from the simulation's (0 1 0)");
  expect(Error(testing_util::ReplaceOnce(u, "<joint name=\"agent_x\" type=\"prismatic\">",
                                         "<joint name=\"agent_x\" type=\"revolute\">")),
         "joint 'agent_x': must be prismatic");
  expect(Error(testing_util::ReplaceOnce(
             u, "<geometry><sphere radius=\"0.7\"/></geometry>\n      <material",
             "<geometry><sphere radius=\"0.5\"/></geometry>\n      <material")),
         "link 'agent': sphere radius 0.500000 differs from the simulation's 0.700000");
  expect(Error(testing_util::ReplaceOnce(
             u, "<geometry><sphere radius=\"0.7\"/></geometry>\n    </collision>",
             "<geometry><box size=\"1 1 1\"/></geometry>\n    </collision>")),
         "its collision geometry must be a sphere");
  expect(Error(testing_util::ReplaceOnce(u, "<origin xyz=\"0 0 0.7\" rpy=\"0 0 0\"/>",
                                         "<origin xyz=\"0 0 0\" rpy=\"0 0 0\"/>")),
         "lift the agent by 0");
  expect(Error(testing_util::ReplaceOnce(u, "<origin xyz=\"0 0 0\" rpy=\"0 0 0\"/>",
                                         "<origin xyz=\"0 0 0\" rpy=\"0 0 0.3\"/>")),
         "joint 'agent_y': origin rpy must be 0 0 0");
  // Limits that fit the medium maze but not the giant one.
  const std::string small = testing_util::ReplaceOnce(
      testing_util::ReplaceOnce(u, "<limit lower=\"-10\" upper=\"60\"",
                                "<limit lower=\"-6\" upper=\"30\""),
      "<limit lower=\"-10\" upper=\"60\"", "<limit lower=\"-6\" upper=\"30\"");
  EXPECT_EQ(Error(small, "medium"), "");
  expect(Error(small, "giant"),
         "joint 'agent_x': limits [-6.000000, 30.000000] do not cover maze giant");
  // A world frame by another name, a missing agent link.
  expect(Error(testing_util::ReplaceOnce(
             testing_util::ReplaceOnce(u, "<link name=\"world\"/>", "<link name=\"map\"/>"),
             "<parent link=\"world\"/>", "<parent link=\"map\"/>")),
         "the root link is 'map', expected the world frame 'world'");
  sim::PointMaze env(sim::PointMazeOptions{});
  EXPECT_THROW(CheckPointRobotUrdf(u, "x", env, "world", "base_link"), std::runtime_error);
  EXPECT_THROW(ReadTextFile("/nonexistent/robot.urdf"), std::runtime_error);
}

}  // namespace
}  // namespace msspr::ros_bridge
