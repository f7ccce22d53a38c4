// rostest scenarios of msspr_sim_node with ~env puzzle-3x3 (sim.launch env:=puzzle-3x3): a
// reset to each of the 5 tasks gives the task's start board, the goal's observation and
// the standard topics (joint_states, buttons/joint_states, markers, tf2); the task oracle,
// run on an in-process twin of the sim and sending its actions over ROS, solves a task with
// the sim's observations equal to the twin's at every step (over ROS = in process).
#include <gtest/gtest.h>
#include <sensor_msgs/JointState.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <string>
#include <vector>

#include "msspr/Reset.h"
#include "msspr_sim/package_files.h"
#include "msspr_sim/puzzle_env.h"
#include "msspr_sim/puzzle_oracle.h"
#include "msspr_sim_nodes/puzzle_sim_node.h"
#include "ros_test_helper.h"

namespace msspr::testing {
namespace {

sim::PuzzleEnvOptions TwinOptions() {
  sim::PuzzleEnvOptions o;
  o.urdf_path = sim::DefaultArmUrdf();
  o.side = 3;
  return o;
}

TEST(PuzzleSim, ResetsToEachTaskAndServesTheStandardTopics) {
  RosTestHelper h;
  ASSERT_TRUE(h.WaitForSim());
  sensor_msgs::JointState::ConstPtr joints, buttons;
  visualization_msgs::MarkerArray::ConstPtr markers;
  auto jsub = h.nh().subscribe<sensor_msgs::JointState>(
      "joint_states", 100, [&](const sensor_msgs::JointState::ConstPtr& j) { joints = j; });
  auto bsub = h.nh().subscribe<sensor_msgs::JointState>(
      "buttons/joint_states", 100,
      [&](const sensor_msgs::JointState::ConstPtr& j) { buttons = j; });
  auto msub = h.nh().subscribe<visualization_msgs::MarkerArray>(
      "markers", 10, [&](const visualization_msgs::MarkerArray::ConstPtr& m) { markers = m; });
  tf2_ros::Buffer tf_buffer;
  tf2_ros::TransformListener tf_listener(tf_buffer);
  ASSERT_TRUE(h.WaitFor([&] { return bsub.getNumPublishers() > 0; }, 10.0));
  const auto& tasks = sim::PuzzleTasks(3);
  for (int task = 1; task <= 5; ++task) {
    const auto res = CallReset(h.nh(), task, 40 + task);
    ASSERT_TRUE(res.ok) << res.message;
    ASSERT_EQ(res.observation.state.size(), 55u);
    ASSERT_EQ(res.goal.size(), 55u);
    EXPECT_EQ(ros_bridge::PuzzleGoalStates(res.observation.state, 9), tasks[task - 1].start)
        << "task " << task;
    EXPECT_FALSE(res.observation.success);
    const ros::Time stamp = res.observation.header.stamp;
    ASSERT_TRUE(h.WaitFor([&] { return buttons && buttons->header.stamp == stamp; }, 5.0))
        << "task " << task;
    ASSERT_EQ(buttons->name.size(), 9u);
    EXPECT_EQ(buttons->name[4], "buttonbox_joint_4");
    for (size_t k = 0; k < 9; ++k)
      EXPECT_EQ(buttons->effort[k], tasks[task - 1].start[k]) << "task " << task << " button " << k;
    ASSERT_TRUE(h.WaitFor([&] { return joints && joints->header.stamp == stamp; }, 5.0));
    EXPECT_EQ(joints->name.size(), 8u);  // 6 arm joints and 2 fingers
    EXPECT_TRUE(tf_buffer.canTransform("world", "pinch_controller", stamp, ros::Duration(5.0)));
  }
  // Task 5 starts with every button on: every cap is drawn blue.
  ASSERT_TRUE(h.WaitFor([&] { return markers && markers->markers.size() == 18u; }, 5.0));
  int blue = 0;
  for (const auto& m : markers->markers)
    if (m.ns == "button_caps" && m.color.b > 0.9f) ++blue;
  EXPECT_EQ(blue, 9);

  msspr::Reset bad;
  bad.request.task_id = 6;
  ros::ServiceClient c = h.nh().serviceClient<msspr::Reset>("reset");
  ASSERT_TRUE(c.call(bad));
  EXPECT_FALSE(bad.response.ok);
  EXPECT_NE(bad.response.message.find("task_id must be 1..5"), std::string::npos);
}

TEST(PuzzleSim, TaskOracleOverRosSolvesATaskStepForStepAsInProcess) {
  RosTestHelper h;
  ASSERT_TRUE(h.WaitForSim());
  const int task = 1;
  const uint64_t seed = 5;
  sim::PuzzleEnv twin(TwinOptions());
  const sim::PuzzleEnv::Observation first = twin.ResetToTask(task, seed);
  const auto res = CallReset(h.nh(), task, seed);
  ASSERT_TRUE(res.ok) << res.message;
  EXPECT_EQ(res.observation.state, first);
  EXPECT_EQ(res.goal, twin.goal_observation());
  sim::PuzzleTaskOracle oracle(seed);
  const uint32_t id = res.observation.episode_id;
  msspr::Observation::ConstPtr o = boost::make_shared<msspr::Observation>(res.observation);
  uint32_t step = 0;
  while (!o->success && !o->last) {
    const sim::PuzzleEnv::Action raw = oracle.Act(twin);
    std::vector<float> sent(raw.begin(), raw.end());
    sim::PuzzleEnv::Action a;
    for (size_t i = 0; i < a.size(); ++i) a[i] = sent[i];
    twin.Step(a);
    h.SendAction(id, step, sent);
    ++step;
    ASSERT_TRUE(h.WaitFor([&] { return h.latest() && h.latest()->step == step; }, 10.0))
        << "stalled at step " << step;
    o = h.latest();
    ASSERT_EQ(o->state, twin.GetObservation()) << "step " << step;
  }
  EXPECT_TRUE(o->success) << "after " << step << " steps";
  EXPECT_TRUE(twin.Success());
  EXPECT_LT(step, 200u);  // two presses
}

}  // namespace
}  // namespace msspr::testing

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "msspr_puzzle_rostest", ros::init_options::AnonymousName);
  ros::Time::init();
  return RUN_ALL_TESTS();
}
