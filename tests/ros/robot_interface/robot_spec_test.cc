// Robot interface specs: the loader, field extraction, and reading
// a robot's bags through a spec (msspr_robot_interface: robot_spec, robot_fields,
// spec_bag.*). No master needed.
#include "msspr_robot_interface/robot_spec.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>

#include "msspr_bags/dataset_bag.h"
#include "msspr_robot_interface/robot_fields.h"
#include "msspr_robot_interface/spec_bag.h"
#include "replace_once.h"
#include "robot_spec_test.h"

namespace msspr::ros_bridge {
namespace {

namespace fs = std::filesystem;

class RobotSpecTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("msspr_robot_spec_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  // Writes `yaml` to a spec file and loads it; returns the error message ("" when it loads).
  std::string LoadError(const std::string& yaml, const std::string& name = "spec.yaml") {
    const std::string path = test::WriteTextFile(Path(name), yaml);
    try {
      LoadRobotSpec(path);
    } catch (const RobotSpecError& e) {
      return e.what();
    }
    return "";
  }
  fs::path dir_;
};

const char kBaseSpec[] = R"(
name: base
control_rate: 10.0
alignment: {tolerance: 0.005, stale_after: 0.25}
episodes: {split_by: topic, topic: goal_pose}
observation:
  - name: position
    topic: odom
    type: nav_msgs/Odometry
    field: pose.pose.position
    components: [x, y]
goal:
  source: pose
  topic: goal_pose
  type: geometry_msgs/PoseStamped
  fields:
    - {observation: position, field: pose.position, components: [x, y]}
action:
  topic: cmd_vel
  type: geometry_msgs/Twist
  fields:
    - {name: velocity, field: linear, components: [x, y], scale: 2.0}
)";

TEST_F(RobotSpecTest, LoadsTheShippedSpecs) {
  for (const auto& entry :
       fs::directory_iterator(std::string(MSSPR_SOURCE_DIR) + "/config/robots")) {
    SCOPED_TRACE(entry.path().string());
    const RobotSpec s = LoadRobotSpec(entry.path().string());
    EXPECT_GT(s.obs_dim(), 0);
    EXPECT_GT(s.action_dim(), 0);
    EXPECT_EQ(CompareRobotSpecs(s, ParseRobotSpec(s.text, "again")), "");
  }
  const RobotSpec s =
      LoadRobotSpec(std::string(MSSPR_SOURCE_DIR) + "/config/robots/pointmaze_base.yaml");
  EXPECT_EQ(s.obs_dim(), 2);
  EXPECT_EQ(s.action_dim(), 2);
  EXPECT_EQ(s.action_type, kTwistType);
  EXPECT_EQ(s.action_stamp, "receipt");
}

TEST_F(RobotSpecTest, RejectsUnknownKeysNamingFileTopicAndField) {
  std::string e = LoadError(testing_util::ReplaceOnce(
      kBaseSpec, "    components: [x, y]\ngoal:", "    components: [x, y]\n    scael: 2\ngoal:"));
  EXPECT_NE(e.find(Path("spec.yaml")), std::string::npos) << e;
  EXPECT_NE(e.find("unknown key 'scael'"), std::string::npos) << e;
  EXPECT_NE(e.find("topic odom"), std::string::npos) << e;
  EXPECT_NE(e.find("'position'"), std::string::npos) << e;
  e = LoadError(std::string(kBaseSpec) + "controll_rate: 5\n");
  EXPECT_NE(e.find("unknown key 'controll_rate'"), std::string::npos) << e;
  e = LoadError(
      testing_util::ReplaceOnce(kBaseSpec, "stale_after: 0.25", "stale_after: 0.25, stale: 1"));
  EXPECT_NE(e.find("alignment"), std::string::npos) << e;
  EXPECT_NE(e.find("unknown key 'stale'"), std::string::npos) << e;
}

TEST_F(RobotSpecTest, RejectsAMissingTopicNamingFileAndField) {
  const std::string e = LoadError(testing_util::ReplaceOnce(kBaseSpec, "    topic: odom\n", ""));
  EXPECT_NE(e.find(Path("spec.yaml")), std::string::npos) << e;
  EXPECT_NE(e.find("'position'"), std::string::npos) << e;
  EXPECT_NE(e.find("no topic"), std::string::npos) << e;
}

TEST_F(RobotSpecTest, RejectsAFieldTheTypeDoesNotHave) {
  std::string e = LoadError(testing_util::ReplaceOnce(kBaseSpec, "field: pose.pose.position\n",
                                                      "field: pose.pose.positon\n"));
  EXPECT_NE(e.find(Path("spec.yaml")), std::string::npos) << e;
  EXPECT_NE(e.find("topic odom"), std::string::npos) << e;
  EXPECT_NE(e.find("nav_msgs/Odometry has no field 'pose.pose.positon'"), std::string::npos) << e;
  e = LoadError(
      testing_util::ReplaceOnce(kBaseSpec, "components: [x, y]\ngoal", "components: [x, q]\ngoal"));
  EXPECT_NE(e.find("no component 'q'"), std::string::npos) << e;
  e = LoadError(testing_util::ReplaceOnce(kBaseSpec, "{name: velocity, field: linear",
                                          "{name: velocity, field: lineer"));
  EXPECT_NE(e.find("topic cmd_vel"), std::string::npos) << e;
  EXPECT_NE(e.find("geometry_msgs/Twist has no field 'lineer'"), std::string::npos) << e;
  e = LoadError(
      testing_util::ReplaceOnce(kBaseSpec, "{observation: position,", "{observation: pos,"));
  EXPECT_NE(e.find("goal (topic goal_pose"), std::string::npos) << e;
  EXPECT_NE(e.find("no observation field named 'pos'"), std::string::npos) << e;
}

TEST_F(RobotSpecTest, JointsByNameAndArraysBySlice) {
  const std::string joints = testing_util::ReplaceOnce(kBaseSpec, R"(    components: [x, y]
goal:)",
                                                       R"(    components: [x, y]
  - name: arm
    topic: joint_states
    type: sensor_msgs/JointState
    field: position
    joints: [elbow, shoulder]
    offset: [0.5, 0.0]
  - name: heading
    topic: odom
    type: nav_msgs/Odometry
    field: pose.pose.orientation
    derive: yaw_cos_sin
  - name: extra
    topic: extra
    type: std_msgs/Float64MultiArray
    field: data[1:3]
goal:)");
  const RobotSpec s = ParseRobotSpec(joints, "joints.yaml");
  EXPECT_EQ(s.obs_dim(), 2 + 2 + 2 + 2);
  // A joint named twice, a JointState field it lacks: load errors naming the field.
  std::string e = LoadError(
      testing_util::ReplaceOnce(joints, "joints: [elbow, shoulder]", "joints: [elbow, elbow]"));
  EXPECT_NE(e.find("topic joint_states"), std::string::npos) << e;
  EXPECT_NE(e.find("joint 'elbow' is empty or named twice"), std::string::npos) << e;
  e = LoadError(testing_util::ReplaceOnce(joints, "field: position\n    joints",
                                          "field: positions\n    joints"));
  EXPECT_NE(e.find("sensor_msgs/JointState has no field 'positions'"), std::string::npos) << e;
  // A message without a joint of the spec: the reading names topic, field and joint.
  sensor_msgs::JointState js;
  js.name = {"shoulder", "wrist"};
  js.position = {0.1, 0.2};
  std::vector<double> v;
  std::string why;
  EXPECT_FALSE(ReadRaw(js, s.observation[1], &v, &why));
  EXPECT_NE(
      why.find("field 'arm' (topic joint_states, position): joint 'elbow' is not in the message"),
      std::string::npos)
      << why;
  js.name = {"shoulder", "wrist", "elbow"};
  js.position = {0.1, 0.2, 0.3};
  ASSERT_TRUE(ReadRaw(js, s.observation[1], &v, &why)) << why;
  EXPECT_EQ(v, (std::vector<double>{0.3, 0.1}));  // spec order, not message order
  nav_msgs::Odometry od;
  od.pose.pose.orientation.z = std::sin(0.3);  // yaw 0.6
  od.pose.pose.orientation.w = std::cos(0.3);
  ASSERT_TRUE(ReadRaw(od, s.observation[2], &v, &why));
  EXPECT_NEAR(v[0], std::cos(0.6), 1e-12);
  EXPECT_NEAR(v[1], std::sin(0.6), 1e-12);
  std_msgs::Float64MultiArray arr;
  arr.data = {1, 2};
  EXPECT_FALSE(ReadRaw(arr, s.observation[3], &v, &why));
  EXPECT_NE(why.find("data has 2 values"), std::string::npos) << why;
}

TEST_F(RobotSpecTest, ImagesAreNoObservationFields) {
  const std::string e = LoadError(testing_util::ReplaceOnce(kBaseSpec, "type: nav_msgs/Odometry",
                                                            "type: sensor_msgs/CompressedImage"));
  EXPECT_NE(e.find("name the camera in the images: section"), std::string::npos) << e;
  EXPECT_NE(e.find("topic odom"), std::string::npos) << e;
}

TEST_F(RobotSpecTest, CompareNamesTheField) {
  const RobotSpec a = ParseRobotSpec(kBaseSpec, "a");
  EXPECT_EQ(CompareRobotSpecs(a, ParseRobotSpec(kBaseSpec, "b")), "");
  const RobotSpec b =
      ParseRobotSpec(testing_util::ReplaceOnce(kBaseSpec, "scale: 2.0", "scale: 1.5"), "b");
  const std::string d = CompareRobotSpecs(a, b);
  EXPECT_NE(d.find("action field 0 'velocity' (topic cmd_vel, linear): scale [2] vs [1.5]"),
            std::string::npos)
      << d;
  const RobotSpec c = ParseRobotSpec(
      testing_util::ReplaceOnce(kBaseSpec, "components: [x, y]\ngoal", "components: [y, x]\ngoal"),
      "c");
  EXPECT_NE(CompareRobotSpecs(a, c).find("observation field 0 'position' (topic odom"),
            std::string::npos);
}

TEST_F(RobotSpecTest, CommandsRoundTripThroughTheSpec) {
  const RobotSpec s = ParseRobotSpec(kBaseSpec, "a");
  const geometry_msgs::Twist t = MakeTwist(s, {0.25, -1.5});  // -1.5 is clipped to -1
  EXPECT_DOUBLE_EQ(t.linear.x, 0.5);
  EXPECT_DOUBLE_EQ(t.linear.y, -2.0);
  EXPECT_DOUBLE_EQ(t.angular.z, 0.0);
  TopicSample out;
  std::string why;
  bool nonfinite = false;
  ASSERT_TRUE(DecodeAction(s, t, ros::Time(5.0), &out, &why, &nonfinite));
  EXPECT_EQ(out.values, (std::vector<double>{0.25, -1.0}));
  EXPECT_EQ(out.stamp, ros::Time(5.0));  // Twist: stamped by receipt
}

// Reads `bag` both ways: msspr's own topics and the spec.
void ReadBoth(const std::string& bag, const RobotSpec& spec, std::vector<BagEpisode>* native,
              std::vector<BagEpisode>* via_spec, SpecBagReport* report) {
  DatasetBagReader nr(bag);
  nr.ForEachEpisode([&](BagEpisode&& ep) { native->push_back(std::move(ep)); });
  SpecBagReader sr(spec, {bag});
  sr.ForEachEpisode([&](BagEpisode&& ep) { via_spec->push_back(std::move(ep)); });
  *report = sr.report();
}

TEST_F(RobotSpecTest, SpecEpisodesEqualTheNativeEpisodes) {
  ros::Time::init();
  const auto eps = test::MakeSynthEpisodes(3, 25, 11);
  test::SynthBagOptions o;
  o.odom_per_step = 5;  // odometry at 50 Hz, commands at 10 Hz
  test::WriteSynthBag(Path("both.bag"), eps, o);
  const RobotSpec spec =
      LoadRobotSpec(std::string(MSSPR_SOURCE_DIR) + "/config/robots/pointmaze_base.yaml");
  std::vector<BagEpisode> native, via_spec;
  SpecBagReport report;
  ReadBoth(Path("both.bag"), spec, &native, &via_spec, &report);
  ASSERT_EQ(native.size(), 3u);
  ASSERT_EQ(via_spec.size(), 3u);
  EXPECT_TRUE(report.problems.empty()) << report.problems[0];
  for (size_t e = 0; e < 3; ++e) {
    SCOPED_TRACE(e);
    ASSERT_EQ(via_spec[e].num_steps, native[e].num_steps);
    EXPECT_TRUE(via_spec[e].complete());
    ASSERT_EQ(via_spec[e].observations.size(), native[e].observations.size());
    for (size_t i = 0; i < native[e].observations.size(); ++i)
      ASSERT_NEAR(via_spec[e].observations[i], native[e].observations[i], 1e-5) << i;
    for (size_t i = 0; i < native[e].actions.size(); ++i)
      ASSERT_NEAR(via_spec[e].actions[i], native[e].actions[i], 1e-5) << i;
  }
  // Per field: 50 Hz odometry, 10 Hz commands, every tick covered.
  ASSERT_EQ(report.fields.size(), 2u);
  EXPECT_NEAR(report.fields[0].rate_hz, 50.0, 2.0);
  EXPECT_NEAR(report.fields[1].rate_hz, 10.0, 0.5);
  EXPECT_EQ(report.fields[0].covered_ticks, 75u);
  EXPECT_EQ(report.fields[1].covered_ticks, 75u);
  EXPECT_EQ(report.fields[0].messages, 75u * 5);
}

TEST_F(RobotSpecTest, DroppedCommandsSplitAndStampsOutOfOrderAreReported) {
  ros::Time::init();
  const auto eps = test::MakeSynthEpisodes(2, 20, 12);
  test::SynthBagOptions o;
  o.drop_cmd_steps = {5, 6, 7, 8};  // 0.4 s without commands (stale_after 0.25 s)
  o.swap_odom_stamps = true;
  test::WriteSynthBag(Path("bad.bag"), eps, o);
  const RobotSpec spec =
      LoadRobotSpec(std::string(MSSPR_SOURCE_DIR) + "/config/robots/pointmaze_base.yaml");
  SpecBagReader sr(spec, {Path("bad.bag")});
  std::vector<BagEpisode> got;
  sr.ForEachEpisode([&](BagEpisode&& ep) { got.push_back(std::move(ep)); });
  ASSERT_EQ(got.size(), 2u);
  const SpecBagReport& r = sr.report();
  // Steps 5, 6 hold the command of step 4 (within stale_after); 7 and 8 are stale.
  EXPECT_EQ(r.fields[1].stale_ticks, 2u);
  EXPECT_FALSE(got[0].complete());
  EXPECT_EQ(got[0].Segments(), (std::vector<std::pair<int, int>>{{0, 7}, {9, 20}}));
  EXPECT_EQ(r.fields[0].out_of_order, 1u);
  bool named = false;
  for (const auto& p : r.problems)
    named |=
        p.find(Path("bad.bag") + ": topic odom (field 'position'): 1 messages stamped before") !=
        std::string::npos;
  EXPECT_TRUE(named) << (r.problems.empty() ? "no problems" : r.problems[0]);
}

TEST_F(RobotSpecTest, ABagWithoutTheTopicNamesBagTopicAndField) {
  ros::Time::init();
  const auto eps = test::MakeSynthEpisodes(1, 5, 13);
  test::SynthBagOptions o;
  o.standard = false;
  test::WriteSynthBag(Path("native_only.bag"), eps, o);
  const RobotSpec spec =
      LoadRobotSpec(std::string(MSSPR_SOURCE_DIR) + "/config/robots/pointmaze_base.yaml");
  SpecBagReader sr(spec, {Path("native_only.bag")});
  try {
    sr.ForEachEpisode([](BagEpisode&&) {});
    FAIL() << "no error";
  } catch (const BagError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(Path("native_only.bag") + ": the recording has no topic /odom"),
              std::string::npos)
        << m;
    EXPECT_NE(m.find("(field 'position', the action, the episodes of "), std::string::npos) << m;
    EXPECT_NE(m.find("pointmaze_base.yaml"), std::string::npos) << m;
  }
}

}  // namespace
}  // namespace msspr::ros_bridge
