// rostest scenarios of msspr_sim_node with ~env puzzle-3x3 (sim_puzzle.test, PuzzleSim.*),
// ~env cube-double (sim_cube_double.test, CubeDoubleSim.*) and ~env scene (sim_scene.test,
// SceneSim.*), as sim.launch starts them: a reset
// to each of the 5 tasks gives the task's start, the goal's observation and the standard
// topics; the task oracle, run on an in-process twin of the sim and sending its actions over
// ROS, solves a task with the sim's observations equal to the twin's at every step (over ROS
// = in process).
#include <geometry_msgs/PoseStamped.h>
#include <gtest/gtest.h>
#include <sensor_msgs/JointState.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <string>
#include <vector>

#include "msspr/Reset.h"
#include "msspr/SetGoal.h"
#include "msspr_sim/cube_double_oracle.h"
#include "msspr_sim/package_files.h"
#include "msspr_sim/puzzle_env.h"
#include "msspr_sim/puzzle_oracle.h"
#include "msspr_sim/scene_oracle.h"
#include "msspr_sim_nodes/arm_task_sim_node.h"
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
  // Task 5 starts with every button on: the markers sent for it draw every cap blue (earlier
  // tasks' arrays may arrive first).
  const auto blue_caps = [&] {
    int blue = 0;
    for (const auto& m : markers->markers)
      if (m.ns == "button_caps" && m.color.b > 0.9f) ++blue;
    return blue;
  };
  EXPECT_TRUE(h.WaitFor([&] { return markers && blue_caps() == 9; }, 5.0))
      << (markers ? std::to_string(blue_caps()) + " blue caps" : "no markers");
  ASSERT_TRUE(markers);
  EXPECT_EQ(markers->markers.size(), 18u);

  msspr::Reset bad;
  bad.request.task_id = 6;
  ros::ServiceClient c = h.nh().serviceClient<msspr::Reset>("reset");
  ASSERT_TRUE(c.call(bad));
  EXPECT_FALSE(bad.response.ok);
  EXPECT_NE(bad.response.message.find("task_id must be 1..5"), std::string::npos);
}

// Resets the sim and an in-process twin to `task`, then lets `oracle` act on the twin and
// sends each action over ROS: every observation of the sim equals the twin's; returns the
// steps to success (-1 without one).
template <class Env, class Oracle>
int RunTwinEpisode(RosTestHelper& h, Env& twin, Oracle& oracle, int task, uint64_t seed) {
  const auto first = twin.ResetToTask(task, seed);
  const auto res = CallReset(h.nh(), task, seed);
  EXPECT_TRUE(res.ok) << res.message;
  if (!res.ok) return -1;
  EXPECT_EQ(res.observation.state, first);
  EXPECT_EQ(res.goal, twin.goal_observation());
  const uint32_t id = res.observation.episode_id;
  msspr::Observation::ConstPtr o = boost::make_shared<msspr::Observation>(res.observation);
  uint32_t step = 0;
  while (!o->success && !o->last) {
    const typename Env::Action raw = oracle.Act(twin);
    std::vector<float> sent(raw.begin(), raw.end());
    typename Env::Action a;
    for (size_t i = 0; i < a.size(); ++i) a[i] = sent[i];
    twin.Step(a);
    h.SendAction(id, step, sent);
    ++step;
    const bool answered = h.WaitFor([&] { return h.latest() && h.latest()->step == step; }, 10.0);
    EXPECT_TRUE(answered) << "stalled at step " << step;
    if (!answered) return -1;
    o = h.latest();
    EXPECT_EQ(o->state, twin.GetObservation()) << "step " << step;
    if (o->state != twin.GetObservation()) return -1;
  }
  EXPECT_EQ(o->success, twin.Success());
  return o->success ? static_cast<int>(step) : -1;
}

TEST(PuzzleSim, TaskOracleOverRosSolvesATaskStepForStepAsInProcess) {
  RosTestHelper h;
  ASSERT_TRUE(h.WaitForSim());
  sim::PuzzleEnv twin(TwinOptions());
  sim::PuzzleTaskOracle oracle(5);
  const int steps = RunTwinEpisode(h, twin, oracle, 1, 5);
  EXPECT_GT(steps, 0);
  EXPECT_LT(steps, 200);  // two presses
}

TEST(CubeDoubleSim, ResetsToEachTaskAndServesTheCubes) {
  RosTestHelper h;
  ASSERT_TRUE(h.WaitForSim());
  geometry_msgs::PoseStamped::ConstPtr cube1;
  auto sub = h.nh().subscribe<geometry_msgs::PoseStamped>(
      "cube_1_pose", 100, [&](const geometry_msgs::PoseStamped::ConstPtr& p) { cube1 = p; });
  tf2_ros::Buffer tf_buffer;
  tf2_ros::TransformListener tf_listener(tf_buffer);
  ASSERT_TRUE(h.WaitFor([&] { return sub.getNumPublishers() > 0; }, 10.0));
  sim::CubeDoubleEnvOptions eo;
  eo.urdf_path = sim::DefaultArmUrdf();
  sim::CubeDoubleEnv twin(eo);
  for (int task = 1; task <= 5; ++task) {
    twin.ResetToTask(task, 7);
    const auto res = CallReset(h.nh(), task, 7);
    ASSERT_TRUE(res.ok) << res.message;
    ASSERT_EQ(res.observation.state.size(), 37u);
    EXPECT_EQ(res.goal, twin.goal_observation()) << "task " << task;
    const ros::Time stamp = res.observation.header.stamp;
    ASSERT_TRUE(h.WaitFor([&] { return cube1 && cube1->header.stamp == stamp; }, 5.0));
    EXPECT_NEAR(cube1->pose.position.x, twin.CubePosition(1).x(), 1e-9);
    EXPECT_NEAR(cube1->pose.position.y, twin.CubePosition(1).y(), 1e-9);
    ASSERT_TRUE(tf_buffer.canTransform("world", "cube_0_goal", stamp, ros::Duration(5.0)));
    const auto goal = tf_buffer.lookupTransform("world", "cube_0_goal", stamp);
    EXPECT_NEAR(goal.transform.translation.y, twin.GoalPosition(0).y(), 1e-9);
  }
}

TEST(CubeDoubleSim, TaskOracleOverRosSolvesATaskStepForStepAsInProcess) {
  RosTestHelper h;
  ASSERT_TRUE(h.WaitForSim());
  sim::CubeDoubleEnvOptions eo;
  eo.urdf_path = sim::DefaultArmUrdf();
  sim::CubeDoubleEnv twin(eo);
  sim::CubeDoubleTaskOracle oracle(3);
  const int steps = RunTwinEpisode(h, twin, oracle, 1, 3);
  EXPECT_GT(steps, 0);
  EXPECT_LT(steps, 200);  // one pick and place
}

sim::SceneEnvOptions SceneTwinOptions() {
  sim::SceneEnvOptions o;
  o.urdf_path = sim::DefaultArmUrdf();
  return o;
}

TEST(SceneSim, ResetsToEachTaskAndServesTheObjects) {
  RosTestHelper h;
  ASSERT_TRUE(h.WaitForSim());
  sensor_msgs::JointState::ConstPtr buttons, slides;
  geometry_msgs::PoseStamped::ConstPtr cube;
  visualization_msgs::MarkerArray::ConstPtr markers;
  auto bsub = h.nh().subscribe<sensor_msgs::JointState>(
      "buttons/joint_states", 100,
      [&](const sensor_msgs::JointState::ConstPtr& j) { buttons = j; });
  auto ssub = h.nh().subscribe<sensor_msgs::JointState>(
      "slides/joint_states", 100, [&](const sensor_msgs::JointState::ConstPtr& j) { slides = j; });
  auto csub = h.nh().subscribe<geometry_msgs::PoseStamped>(
      "cube_pose", 100, [&](const geometry_msgs::PoseStamped::ConstPtr& p) { cube = p; });
  auto msub = h.nh().subscribe<visualization_msgs::MarkerArray>(
      "markers", 10, [&](const visualization_msgs::MarkerArray::ConstPtr& m) { markers = m; });
  tf2_ros::Buffer tf_buffer;
  tf2_ros::TransformListener tf_listener(tf_buffer);
  ASSERT_TRUE(h.WaitFor([&] { return ssub.getNumPublishers() > 0; }, 10.0));
  sim::SceneEnv twin(SceneTwinOptions());
  uint32_t episode = 0;
  for (int task = 1; task <= 5; ++task) {
    const auto first = twin.ResetToTask(task, 11);
    const auto res = CallReset(h.nh(), task, 11);
    episode = res.observation.episode_id;
    ASSERT_TRUE(res.ok) << res.message;
    ASSERT_EQ(res.observation.state.size(), 40u);
    EXPECT_EQ(res.observation.state, first) << "task " << task;
    EXPECT_EQ(res.goal, twin.goal_observation()) << "task " << task;
    EXPECT_FALSE(res.observation.success);
    const sim::SceneTask& t = sim::SceneTasks()[static_cast<size_t>(task - 1)];
    const ros::Time stamp = res.observation.header.stamp;
    ASSERT_TRUE(h.WaitFor([&] { return buttons && buttons->header.stamp == stamp; }, 5.0));
    ASSERT_TRUE(h.WaitFor([&] { return slides && slides->header.stamp == stamp; }, 5.0));
    ASSERT_TRUE(h.WaitFor([&] { return cube && cube->header.stamp == stamp; }, 5.0));
    ASSERT_EQ(buttons->name.size(), 2u);
    for (size_t k = 0; k < 2; ++k)
      EXPECT_EQ(buttons->effort[k], t.start.buttons[k]) << "task " << task << " button " << k;
    ASSERT_EQ(slides->name, (std::vector<std::string>{"drawer_slide", "window_slide"}));
    EXPECT_NEAR(slides->position[0], t.start.drawer, 0.0101) << "task " << task;
    EXPECT_NEAR(slides->position[1], t.start.window, 0.0101) << "task " << task;
    EXPECT_EQ(slides->effort[0], t.start.buttons[0] == 0 ? 1.0 : 0.0);  // locked
    EXPECT_NEAR(cube->pose.position.x, twin.CubePosition().x(), 1e-9);
    EXPECT_NEAR(cube->pose.position.y, twin.CubePosition().y(), 1e-9);
    ASSERT_TRUE(tf_buffer.canTransform("world", "drawer", stamp, ros::Duration(5.0)));
    EXPECT_NEAR(tf_buffer.lookupTransform("world", "drawer", stamp).transform.translation.y,
                twin.DrawerPosition().y(), 1e-9);
    ASSERT_TRUE(tf_buffer.canTransform("world", "window", stamp, ros::Duration(5.0)));
    EXPECT_NEAR(tf_buffer.lookupTransform("world", "window", stamp).transform.translation.x,
                twin.WindowPosition().x(), 1e-9);
    ASSERT_TRUE(tf_buffer.canTransform("world", "cube_goal", stamp, ros::Duration(5.0)));
    EXPECT_NEAR(tf_buffer.lookupTransform("world", "cube_goal", stamp).transform.translation.y,
                t.goal.cube.y(), 1e-9);
  }
  // Task 5 starts locked: the markers sent for it draw both caps and both handles red.
  const auto red_parts = [&] {
    int red = 0;
    for (const auto& m : markers->markers)
      if ((m.ns == "button_caps" || m.ns == "drawer_handle" || m.ns == "window_handle") &&
          m.color.r > 0.9f && m.color.g < 0.3f)
        ++red;
    return red;
  };
  EXPECT_TRUE(h.WaitFor([&] { return markers && red_parts() == 4; }, 5.0))
      << (markers ? std::to_string(red_parts()) + " red parts" : "no markers");

  // A goal observation sets the goal: task 1's goal observation on task 5's episode, seen in
  // the next step's observation and tf2.
  twin.ResetToTask(1, 11);
  msspr::SetGoal sg;
  sg.request.goal = twin.goal_observation();
  ros::ServiceClient set_goal = h.nh().serviceClient<msspr::SetGoal>("set_goal");
  ASSERT_TRUE(set_goal.call(sg));
  EXPECT_TRUE(sg.response.ok) << sg.response.message;
  h.SendAction(episode, 0, {0.f, 0.f, 0.f, 0.f, 0.f});
  ASSERT_TRUE(h.WaitFor(
      [&] { return h.latest() && h.latest()->episode_id == episode && h.latest()->step == 1; },
      10.0));
  EXPECT_EQ(h.latest()->goal, twin.goal_observation());
  ASSERT_TRUE(h.WaitFor(
      [&] {
        return tf_buffer.canTransform("world", "cube_goal", ros::Time(0)) &&
               std::abs(tf_buffer.lookupTransform("world", "cube_goal", ros::Time(0))
                            .transform.translation.y -
                        sim::SceneTasks()[0].goal.cube.y()) < 1e-3;
      },
      5.0));
  sg.request.goal[28] = 0.5f;  // button 0's state one-hot broken
  ASSERT_TRUE(set_goal.call(sg));
  EXPECT_FALSE(sg.response.ok);
  EXPECT_NE(sg.response.message.find("button 0"), std::string::npos) << sg.response.message;
}

TEST(SceneSim, TaskOracleOverRosSolvesATaskStepForStepAsInProcess) {
  RosTestHelper h;
  ASSERT_TRUE(h.WaitForSim());
  sim::SceneEnv twin(SceneTwinOptions());
  sim::SceneTaskOracle oracle(4);
  const int steps = RunTwinEpisode(h, twin, oracle, 1, 4);
  EXPECT_GT(steps, 0);
  EXPECT_LT(steps, 200);  // open the drawer and the window
}

}  // namespace
}  // namespace msspr::testing

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "msspr_arm_tasks_rostest", ros::init_options::AnonymousName);
  ros::Time::init();
  return RUN_ALL_TESTS();
}
