// config/robots/ur5e_cube.yaml against the cube-single sim: a bag of the
// standard messages msspr_sim_node ~env cube-single publishes (built by the
// same function, MakeCubeStandardMessages: joint_states, gripper/joint_states,
// cube_pose, /tf and /tf_static; cube_spec_bag.h) and of the commands it takes
// (ee_twist, gripper_command), read through the spec, gives the env's
// own 28-D observations and the actions within 1e-5. The play oracle drives,
// so that the gripper closes on the cube (contact) along the way. No master.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "cube_spec_bag.h"
#include "msspr_robot_interface/robot_fields.h"
#include "msspr_robot_interface/robot_spec.h"
#include "msspr_robot_interface/spec_bag.h"
#include "msspr_sim_nodes/cube_sim_node.h"

namespace msspr::ros_bridge {
namespace {

namespace fs = std::filesystem;

TEST(RobotSpecCube, SpecObservationsEqualTheNative28D) {
  ros::Time::init();
  const fs::path dir =
      fs::temp_directory_path() / ("msspr_cube_spec_test_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string bag_path = (dir / "cube.bag").string();
  constexpr int kSteps = 120;
  const spec_bags::CubeSpecBag written = spec_bags::WriteCubeSpecBag(bag_path, kSteps, 11);
  const auto& native = written.observations;
  const auto& actions = written.actions;
  const RobotSpec spec =
      LoadRobotSpec(std::string(MSSPR_SOURCE_DIR) + "/config/robots/ur5e_cube.yaml");
  ASSERT_EQ(spec.obs_dim(), sim::CubeEnv::kObservationSize);
  ASSERT_EQ(spec.action_dim(), sim::CubeEnv::kActionSize);
  SpecBagReader reader(spec, {bag_path});
  std::vector<BagEpisode> episodes;
  reader.ForEachEpisode([&](BagEpisode&& ep) { episodes.push_back(std::move(ep)); });
  for (const auto& p : reader.report().problems) ADD_FAILURE() << p;
  ASSERT_EQ(episodes.size(), 1u);
  const BagEpisode& ep = episodes[0];
  ASSERT_EQ(ep.num_steps, kSteps);
  double worst = 0, contact = 0;
  for (int k = 0; k < kSteps; ++k) {
    ASSERT_TRUE(ep.has_obs[k]) << k;
    ASSERT_TRUE(ep.has_action[k]) << k;
    for (int i = 0; i < sim::CubeEnv::kObservationSize; ++i) {
      const float got = ep.observations[static_cast<size_t>(k) * 28 + i];
      EXPECT_NEAR(got, native[k][i], 1e-5) << "step " << k << " observation[" << i << "]";
      worst = std::max(worst, static_cast<double>(std::abs(got - native[k][i])));
    }
    for (int i = 0; i < sim::CubeEnv::kActionSize; ++i)
      EXPECT_NEAR(ep.actions[static_cast<size_t>(k) * 5 + i], actions[k][i], 1e-6)
          << "step " << k << " action[" << i << "]";
    contact = std::max(contact, static_cast<double>(native[k][18]));
  }
  std::printf("%d steps: largest observation difference %.3g; largest contact %.3f\n", kSteps,
              worst, contact);
  EXPECT_GT(contact, 0.0) << "the oracle never touched the cube: the contact entry went untested";
  if (!::testing::Test::HasFailure()) fs::remove_all(dir);
}

// tf2 fields and commands on two topics: checked when loaded, naming file and field;
// the policy's action splits into the twist and the gripper command.
TEST(RobotSpecCube, Tf2FieldsAndTwoCommandTopics) {
  const std::string path = std::string(MSSPR_SOURCE_DIR) + "/config/robots/ur5e_cube.yaml";
  const RobotSpec spec = LoadRobotSpec(path);
  const auto commands = spec.CommandTopics();
  ASSERT_EQ(commands.size(), 2u);
  EXPECT_EQ(commands[0].topic, "ee_twist");
  EXPECT_EQ(commands[1].topic, "gripper_command");
  const std::vector<double> a = {0.5, -0.25, 2.0, 0.1, -0.75};  // 2.0 is clipped to 1
  const geometry_msgs::Twist t = MakeTwist(spec, a, "ee_twist");
  EXPECT_DOUBLE_EQ(t.linear.x, 0.5);
  EXPECT_DOUBLE_EQ(t.linear.y, -0.25);
  EXPECT_DOUBLE_EQ(t.linear.z, 1.0);
  EXPECT_DOUBLE_EQ(t.angular.z, 0.6);
  EXPECT_EQ(t.angular.x, 0.0);
  const std_msgs::Float64MultiArray g = MakeFloat64MultiArray(spec, a, "gripper_command");
  ASSERT_EQ(g.data.size(), 1u);
  EXPECT_DOUBLE_EQ(g.data[0], -0.75);

  auto error_of = [&](const std::string& from, const std::string& to) {
    std::string text = spec.text;
    const size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    try {
      ParseRobotSpec(text, "arm.yaml");
    } catch (const RobotSpecError& e) {
      return std::string(e.what());
    }
    return std::string("(loaded)");
  };
  std::string e = error_of("    frames: [world, pinch_controller]\n    field: translation",
                           "    field: translation");
  EXPECT_NE(e.find("arm.yaml: observation field 'pinch_position'"), std::string::npos) << e;
  EXPECT_NE(e.find("frames: [parent, child]"), std::string::npos) << e;
  e = error_of("frames: [world, pinch_controller]\n    field: translation",
               "frames: [world, /pinch]\n    field: translation");
  EXPECT_NE(e.find("must not start with '/'"), std::string::npos) << e;
  e = error_of("    field: translation", "    field: velocity");
  EXPECT_NE(e.find("tf2 has no field 'velocity'"), std::string::npos) << e;
  e = error_of("      type: std_msgs/Float64MultiArray\n", "");
  EXPECT_NE(e.find("arm.yaml: action field 'grip' (topic gripper_command, data[0]): a field on its "
                   "own topic needs its type"),
            std::string::npos)
      << e;
  // A checkpoint's stored spec with other frames is told apart, naming the field.
  const RobotSpec other = ParseRobotSpec(
      spec.text.substr(0, spec.text.find("  - name: pinch_heading")) + "  - name: pinch_heading" +
          [&] {
            std::string rest = spec.text.substr(spec.text.find("  - name: pinch_heading") + 23);
            rest.replace(rest.find("pinch_controller"), 16, "pinch");
            return rest;
          }(),
      "other.yaml");
  EXPECT_NE(CompareRobotSpecs(spec, other)
                .find("observation field 3 'pinch_heading' (topic tf, rotation): frames"),
            std::string::npos)
      << CompareRobotSpecs(spec, other);
}

}  // namespace
}  // namespace msspr::ros_bridge
