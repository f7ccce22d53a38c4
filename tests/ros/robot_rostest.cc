// rostest scenario of issue 28: msspr_policy_node ~robot serves the shipped
// point-maze checkpoint through config/robots/pointmaze_base.yaml over
// standard topics only (odom, goal_pose in; cmd_vel out); it reaches a goal,
// stops the robot (zero twist, /diagnostics WARN) when its inputs go stale,
// and serves again when they return.
#include <cmath>
#include <cstdio>

#include <geometry_msgs/Twist.h>
#include <gtest/gtest.h>

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
  ros::Subscriber cmd = h.nh().subscribe<geometry_msgs::Twist>("cmd_vel", 1000, [&](const geometry_msgs::Twist::ConstPtr& t) {
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
    ASSERT_TRUE(h.WaitFor([&] {
      const auto& o = h.latest();
      return o && o->episode_id == id && (o->success || o->step >= 300);
    }, 120.0)) << "episode " << e << " stalled at step " << (h.latest() ? h.latest()->step : 0);
    reached += h.latest()->success;
    std::printf("episode %d: %s at step %u\n", e, h.latest()->success ? "reached" : "not reached", h.latest()->step);
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
    for (const char* k : {"steps", "actions", "stale", "ignored_after_end", "ignored_paused", "republished"})
      s += std::string(k) + "=" + h.DiagValue(": actions", k) + " ";
    for (const char* k : {"messages", "commands", "stop_commands", "stale_events", "rejected"})
      s += std::string(k) + "=" + h.DiagValue(kRobotStatus, k) + " ";
    return s;
  };
  ASSERT_TRUE(h.WaitFor([&] { return h.latest() && h.latest()->episode_id == r.response.observation.episode_id &&
                                     h.latest()->step >= 20; }, 30.0))
      << "step " << (h.latest() ? h.latest()->step : 0) << "; " << counters();
  msspr::Pause p;
  p.request.pause = true;
  ASSERT_TRUE(pause.call(p));
  const uint64_t zeros_before = zero_twists;
  EXPECT_TRUE(h.WaitFor([&] { return zero_twists > zeros_before; }, 5.0)) << "no stop command";
  EXPECT_TRUE(h.WaitFor([&] { return level.find("inputs stale, stopping: topic odom (field 'position')") != std::string::npos; },
                        5.0))
      << level;
  EXPECT_EQ(level[0], '1') << level;  // WARN
  // Inputs return: serving again, the episode moves on.
  const uint32_t step = h.latest()->step;
  const uint64_t twists_before = twists;
  p.request.pause = false;
  ASSERT_TRUE(pause.call(p));
  EXPECT_TRUE(h.WaitFor([&] { return h.latest()->step >= step + 10 && twists >= twists_before + 10; }, 20.0))
      << "not serving again after the pause";
  EXPECT_NE(last.linear.x * last.linear.x + last.linear.y * last.linear.y, 0.0);
  EXPECT_TRUE(h.WaitFor([&] { return level.rfind("0 serving", 0) == 0; }, 5.0)) << level;
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "msspr_robot_rostest", ros::init_options::AnonymousName);
  ros::Time::init();
  return RUN_ALL_TESTS();
}
