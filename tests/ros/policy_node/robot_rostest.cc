// rostest scenarios of msspr_policy_node ~robot with the shipped point-maze
// checkpoint and config/robots/pointmaze_base.yaml (standard topics only:
// odom, goal_pose in; cmd_vel out).
// - RobotServing (policy_robot.test): it reaches a goal, stops the robot (zero
//   twist, /diagnostics WARN) when its inputs go stale, and serves again when
//   they return.
// - RobotCameraServing (policy_robot_camera.test): an untrained pixels policy
//   served through config/robots/pointmaze_camera.yaml (camera/image and
//   goal_image in) steps the sim; corrupt images are counted, not fatal.
// - RobotSameActions (policy_robot_same_actions.test): the same states and
//   goals, given to a node serving over the native msspr topics and to one
//   serving through the spec, give the same commands: twist.linear.{x, y} =
//   2.0 * clip(action, -1, 1) within 1e-5.
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/Twist.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/Image.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "msspr/Pause.h"
#include "msspr/Reset.h"
#include "msspr/SetGoal.h"
#include "ros_test_helper.h"

namespace {

using msspr::testing::RosTestHelper;
constexpr char kRobotStatus[] = "robot pointmaze_base";

TEST(RobotServing, ReachesGoalStopsWhenStaleAndResumes) {
  RosTestHelper h;
  uint64_t twists = 0, zero_twists = 0;
  geometry_msgs::Twist last;
  ros::Subscriber cmd = h.nh().subscribe<geometry_msgs::Twist>(
      "cmd_vel", 1000, [&](const geometry_msgs::Twist::ConstPtr& t) {
        ++twists;
        last = *t;
        if (t->linear.x == 0.0 && t->linear.y == 0.0 && t->angular.z == 0.0) ++zero_twists;
      });
  std::string level;
  ros::Subscriber diag = h.nh().subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 10, [&](const diagnostic_msgs::DiagnosticArray::ConstPtr& d) {
        for (const auto& st : d->status)
          if (st.name.find(kRobotStatus) != std::string::npos)
            level = std::to_string(static_cast<int>(st.level)) + " " + st.message;
      });
  ros::ServiceClient reset = h.nh().serviceClient<msspr::Reset>("reset");
  ros::ServiceClient pause = h.nh().serviceClient<msspr::Pause>("pause");
  ros::ServiceClient set_goal = h.nh().serviceClient<msspr::SetGoal>("set_goal");
  ASSERT_TRUE(reset.waitForExistence(ros::Duration(60.0)));
  ASSERT_TRUE(h.WaitFor([&] { return cmd.getNumPublishers() > 0 && !level.empty(); }, 60.0))
      << "policy node not serving cmd_vel (its fatal error, if any, is on its stderr)";
  // Before any episode: no odometry and no goal yet, so the watchdog says stale.
  EXPECT_EQ(level.rfind("1 inputs stale", 0), 0u) << level;

  int reached = 0;
  for (int e = 0; e < 2; ++e) {
    msspr::Reset r;
    r.request.task_id = 1;
    r.request.seed = 500 + e;
    ASSERT_TRUE(reset.call(r));
    ASSERT_TRUE(r.response.ok) << r.response.message;
    const uint32_t id = r.response.observation.episode_id;
    msspr::SetGoal g;  // the sim publishes the new goal on goal_pose
    g.request.goal = {3.0f, 0.0f};
    ASSERT_TRUE(set_goal.call(g));
    ASSERT_TRUE(h.WaitFor(
        [&] {
          const auto& o = h.latest();
          return o && o->episode_id == id && (o->success || o->step >= 300);
        },
        120.0))
        << "episode " << e << " stalled at step " << (h.latest() ? h.latest()->step : 0);
    reached += h.latest()->success;
    std::printf("episode %d: %s at step %u\n", e, h.latest()->success ? "reached" : "not reached",
                h.latest()->step);
  }
  EXPECT_GE(reached, 1);
  EXPECT_TRUE(h.WaitFor([&] { return level.rfind("0 serving", 0) == 0; }, 5.0)) << level;

  // A new episode, then the sim pauses: odometry stops, the watchdog sends a zero twist.
  msspr::Reset r;
  r.request.task_id = 2;
  r.request.seed = 7;
  ASSERT_TRUE(reset.call(r));
  auto counters = [&] {
    std::string s;
    for (const char* k :
         {"steps", "actions", "stale", "ignored_after_end", "ignored_paused", "republished"})
      s += std::string(k) + "=" + h.DiagValue(": actions", k) + " ";
    for (const char* k : {"messages", "commands", "stop_commands", "stale_events", "rejected"})
      s += std::string(k) + "=" + h.DiagValue(kRobotStatus, k) + " ";
    return s;
  };
  ASSERT_TRUE(h.WaitFor(
      [&] {
        return h.latest() && h.latest()->episode_id == r.response.observation.episode_id &&
               h.latest()->step >= 20;
      },
      30.0))
      << "step " << (h.latest() ? h.latest()->step : 0) << "; " << counters();
  msspr::Pause p;
  p.request.pause = true;
  ASSERT_TRUE(pause.call(p));
  const uint64_t zeros_before = zero_twists;
  EXPECT_TRUE(h.WaitFor([&] { return zero_twists > zeros_before; }, 5.0)) << "no stop command";
  EXPECT_TRUE(h.WaitFor(
      [&] {
        return level.find("inputs stale, stopping: topic odom (field 'position')") !=
               std::string::npos;
      },
      5.0))
      << level;
  EXPECT_EQ(level[0], '1') << level;  // WARN
  // Inputs return: serving again, the episode moves on.
  const uint32_t step = h.latest()->step;
  const uint64_t twists_before = twists;
  p.request.pause = false;
  ASSERT_TRUE(pause.call(p));
  EXPECT_TRUE(h.WaitFor(
      [&] { return h.latest()->step >= step + 10 && twists >= twists_before + 10; }, 20.0))
      << "not serving again after the pause";
  EXPECT_NE(last.linear.x * last.linear.x + last.linear.y * last.linear.y, 0.0);
  EXPECT_TRUE(h.WaitFor([&] { return level.rfind("0 serving", 0) == 0; }, 5.0)) << level;
}

// A pixels policy served through config/robots/pointmaze_camera.yaml
// (policy_robot_camera.test): the sim's camera/image and goal_image in,
// cmd_vel out. The node answers every step; corrupt images on the camera topic
// are rejected and counted (bad_images on /diagnostics) and it keeps serving.
TEST(RobotCameraServing, ServesPixelsAndCountsCorruptImages) {
  RosTestHelper h;
  constexpr char kCameraStatus[] = "robot pointmaze_camera";
  uint64_t twists = 0, moving = 0;
  ros::Subscriber cmd = h.nh().subscribe<geometry_msgs::Twist>(
      "cmd_vel", 1000, [&](const geometry_msgs::Twist::ConstPtr& t) {
        ++twists;
        if (t->linear.x != 0.0 || t->linear.y != 0.0) ++moving;
      });
  ros::Publisher bad_pub = h.nh().advertise<sensor_msgs::Image>("camera/image", 10);
  ros::ServiceClient reset = h.nh().serviceClient<msspr::Reset>("reset");
  ASSERT_TRUE(reset.waitForExistence(ros::Duration(60.0)));
  ASSERT_TRUE(h.WaitFor(
      [&] {
        return cmd.getNumPublishers() > 0 && bad_pub.getNumSubscribers() > 0 &&
               !h.DiagValue(kCameraStatus, "bad_images").empty();
      },
      60.0))
      << "policy node not serving cmd_vel through the camera spec (its fatal error, if any, is on "
         "its stderr)";
  msspr::Reset r;
  r.request.task_id = 1;
  r.request.seed = 3;
  ASSERT_TRUE(reset.call(r));
  ASSERT_TRUE(r.response.ok) << r.response.message;
  const uint32_t id = r.response.observation.episode_id;
  auto counters = [&] {
    std::string s;
    for (const char* k :
         {"messages", "images", "bad_images", "rejected", "commands", "stop_commands"})
      s += std::string(k) + "=" + h.DiagValue(kCameraStatus, k) + " ";
    return s + "twists=" + std::to_string(twists);
  };
  ASSERT_TRUE(h.WaitFor(
      [&] { return h.latest() && h.latest()->episode_id == id && h.latest()->step >= 15; }, 30.0))
      << "the pixels policy does not step the sim: step " << (h.latest() ? h.latest()->step : 0)
      << "; " << counters();
  EXPECT_GT(moving, 0u) << "only stop commands: " << counters();
  EXPECT_EQ(h.DiagValue(kCameraStatus, "bad_images"), "0") << counters();

  // Corrupt images on the camera topic: too little data, a wrong encoding.
  sensor_msgs::Image bad;
  bad.header.stamp = h.latest()->header.stamp;
  bad.height = bad.width = 64;
  bad.encoding = "rgb8";
  bad.step = 64 * 3;
  bad.data.assign(10, 0);
  bad_pub.publish(bad);
  bad.encoding = "32FC1";
  bad.data.assign(64 * 64 * 4, 0);
  bad.step = 64 * 4;
  bad_pub.publish(bad);
  EXPECT_TRUE(h.WaitFor([&] { return h.DiagNumber(kCameraStatus, "bad_images") >= 2; }, 10.0))
      << counters();
  EXPECT_GE(h.DiagNumber(kCameraStatus, "rejected"), 2) << counters();
  // Still serving: the episode moves on.
  const uint32_t step = h.latest()->step;
  EXPECT_TRUE(h.WaitFor(
      [&] { return h.latest()->episode_id == id && h.latest()->step >= step + 10; }, 20.0))
      << "not serving after the corrupt images: step " << h.latest()->step << "; " << counters();
  std::printf("camera spec: %s\n", counters().c_str());
}

// Feeds states and goals to both nodes one at a time and compares their answers.
TEST(RobotSameActions, NativeAndSpecServingGiveTheSameCommands) {
  RosTestHelper h;
  ros::NodeHandle nh;
  ros::Publisher obs_pub = nh.advertise<msspr::Observation>("/native/observation", 10);
  ros::Publisher odom_pub = nh.advertise<nav_msgs::Odometry>("/robot/odom", 10);
  ros::Publisher goal_pub =
      nh.advertise<geometry_msgs::PoseStamped>("/robot/goal_pose", 1, /*latch=*/true);
  std::vector<std::vector<float>> actions;
  std::vector<geometry_msgs::Twist> twists;
  uint64_t stops = 0;
  ros::Subscriber act_sub = nh.subscribe<msspr::Action>(
      "/native/action", 100,
      [&](const msspr::Action::ConstPtr& a) { actions.push_back(a->action); });
  ros::Subscriber cmd_sub = nh.subscribe<geometry_msgs::Twist>(
      "/robot/cmd_vel", 100, [&](const geometry_msgs::Twist::ConstPtr& t) {
        // The watchdog's stop (before the first goal, or when odometry pauses) is an exact zero.
        if (t->linear.x == 0.0 && t->linear.y == 0.0 && t->linear.z == 0.0 && t->angular.z == 0.0)
          ++stops;
        else
          twists.push_back(*t);
      });
  ASSERT_TRUE(h.WaitFor(
      [&] {
        return obs_pub.getNumSubscribers() > 0 && act_sub.getNumPublishers() > 0 &&
               odom_pub.getNumSubscribers() > 0 && goal_pub.getNumSubscribers() > 0 &&
               cmd_sub.getNumPublishers() > 0;
      },
      90.0))
      << "the two policy nodes are not up (their fatal error, if any, is on their stderr)";

  std::mt19937 rng(28);
  std::uniform_real_distribution<float> coord(0.0f, 20.0f);  // the medium maze spans about 0..20 m
  constexpr int kGoals = 4, kStates = 6;
  uint32_t step = 0;
  double worst = 0.0;
  for (int g = 0; g < kGoals; ++g) {
    const std::vector<float> goal = {coord(rng), coord(rng)};
    geometry_msgs::PoseStamped gp;
    gp.header.stamp = ros::Time(100.0 + g);
    gp.header.frame_id = "odom";
    gp.pose.position.x = goal[0];
    gp.pose.position.y = goal[1];
    gp.pose.orientation.w = 1.0;
    goal_pub.publish(gp);
    h.WaitFor([] { return false; }, 0.2);  // the goal reaches the node before the next odometry
    for (int k = 0; k < kStates; ++k, ++step) {
      const std::vector<float> state = {coord(rng), coord(rng)};
      msspr::Observation o;
      o.header.stamp = ros::Time(100.0 + 0.1 * step);
      o.episode_id = 1;
      o.step = step;
      o.state = state;
      o.goal = goal;
      nav_msgs::Odometry od;
      od.header = o.header;
      od.header.frame_id = "odom";
      od.child_frame_id = "base_link";
      od.pose.pose.position.x = state[0];
      od.pose.pose.position.y = state[1];
      od.pose.pose.orientation.w = 1.0;
      const size_t n = step + 1;
      obs_pub.publish(o);
      odom_pub.publish(od);
      ASSERT_TRUE(h.WaitFor([&] { return actions.size() >= n && twists.size() >= n; }, 20.0))
          << "no answer to state " << step << ": " << actions.size() << " actions, "
          << twists.size() << " commands, " << stops << " stops";
      const auto& a = actions[n - 1];
      const auto& t = twists[n - 1];
      ASSERT_EQ(a.size(), 2u);
      const double ex = 2.0 * std::clamp<double>(a[0], -1.0, 1.0),
                   ey = 2.0 * std::clamp<double>(a[1], -1.0, 1.0);
      EXPECT_NEAR(t.linear.x, ex, 1e-5) << "state " << step;
      EXPECT_NEAR(t.linear.y, ey, 1e-5) << "state " << step;
      EXPECT_EQ(t.linear.z, 0.0);
      EXPECT_EQ(t.angular.z, 0.0);
      worst = std::max({worst, std::abs(t.linear.x - ex), std::abs(t.linear.y - ey)});
    }
  }
  std::printf("%u states, %d goals: largest difference %.3g m/s (%lu stop commands, ignored)\n",
              step, kGoals, worst, stops);
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "msspr_robot_rostest", ros::init_options::AnonymousName);
  ros::Time::init();
  return RUN_ALL_TESTS();
}
