// ResolveSpecTopics (topic_names.h): a spec's topics resolved against a
// recording's as ROS resolves names.
#include "msspr_robot_interface/topic_names.h"

#include <gtest/gtest.h>

#include <set>
#include <stdexcept>
#include <string>
#include <vector>

namespace msspr::ros_bridge {
namespace {

using Names = std::vector<std::string>;

TEST(TopicNames, NamesJoinAsRosJoinsThem) {
  EXPECT_EQ(NormalizeNamespace(""), "/");
  EXPECT_EQ(NormalizeNamespace("msspr/"), "/msspr");
  EXPECT_EQ(NormalizeNamespace("//a//b"), "/a/b");
  EXPECT_EQ(ResolveTopicName("/msspr", "gripper/joint_states"), "/msspr/gripper/joint_states");
  EXPECT_EQ(ResolveTopicName("", "odom"), "/odom");
  EXPECT_EQ(ResolveTopicName("/msspr", "/odom"), "/odom");
}

TEST(TopicNames, ANamespacedArmResolvesJointStatesBesideTheGrippers) {
  const std::set<std::string> bag = {"/msspr/joint_states", "/msspr/gripper/joint_states",
                                     "/msspr/cmd_vel", "/tf"};
  const TopicResolution r =
      ResolveSpecTopics({"joint_states", "gripper/joint_states", "cmd_vel"}, bag, "");
  EXPECT_EQ(r.ns, "/msspr");
  EXPECT_TRUE(r.inferred);
  EXPECT_EQ(r.topics,
            (Names{"/msspr/joint_states", "/msspr/gripper/joint_states", "/msspr/cmd_vel"}));
  // Given, the same; and a name that is only a last segment is not a candidate.
  EXPECT_EQ(ResolveSpecTopics({"joint_states"}, bag, "msspr").topics[0], "/msspr/joint_states");
  EXPECT_EQ(ResolveSpecTopics({"joint_states"}, bag, "").topics[0], "/msspr/joint_states");
}

TEST(TopicNames, TheRootWinsWhenItHoldsEveryTopic) {
  const std::set<std::string> bag = {"/odom", "/cmd_vel", "/robot2/odom", "/robot2/cmd_vel"};
  const TopicResolution r = ResolveSpecTopics({"odom", "cmd_vel"}, bag, "");
  EXPECT_EQ(r.ns, "/");
  EXPECT_FALSE(r.inferred);
  EXPECT_EQ(r.topics, (Names{"/odom", "/cmd_vel"}));
  EXPECT_EQ(ResolveSpecTopics({"odom", "cmd_vel"}, bag, "/robot2").topics,
            (Names{"/robot2/odom", "/robot2/cmd_vel"}));
}

TEST(TopicNames, TwoRobotsNeedANamespaceAndAMissingTopicIsNamed) {
  const std::set<std::string> bag = {"/a/odom", "/a/cmd_vel", "/b/odom", "/b/cmd_vel"};
  try {
    ResolveSpecTopics({"odom", "cmd_vel"}, bag, "");
    FAIL() << "two namespaces accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("several namespaces (/a, /b)"), std::string::npos)
        << e.what();
  }
  EXPECT_EQ(ResolveSpecTopics({"odom"}, bag, "b").topics[0], "/b/odom");
  try {
    ResolveSpecTopics({"odom", "joint_states"}, bag, "a");
    FAIL() << "a missing topic accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("no topic /a/joint_states"), std::string::npos)
        << e.what();
  }
  try {
    ResolveSpecTopics({"odom", "joint_states"}, bag, "");
    FAIL() << "a missing topic accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("no topic /a/joint_states (the spec's other topics are "
                                         "under /a"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace msspr::ros_bridge
