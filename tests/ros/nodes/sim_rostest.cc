// rostest scenarios of the sim node (one suite per .test file, see tests/ros/nodes/*.test).
#include <gtest/gtest.h>
#include <sensor_msgs/JointState.h>
#include <signal.h>
#include <sys/wait.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <unistd.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>

#include "msspr/Pause.h"
#include "msspr/Reset.h"
#include "msspr/SetGoal.h"
#include "msspr_bags/dataset_bag.h"
#include "msspr_sim/dataset_gen.h"
#include "msspr_sim/maze_map.h"
#include "msspr_sim/point_maze.h"
#include "msspr_sim_nodes/robot_model.h"
#include "ros_test_helper.h"

namespace msspr::testing {
namespace {

// sim + expert (goal mode) in lockstep reach the goal of every task of the maze
// (~maze) in >= 95% of ~episodes episodes per task, within 1000 steps.
TEST(SimExpertLockstep, ReachesGoals) {
  RosTestHelper h;
  ros::NodeHandle pnh("~");
  const int episodes = pnh.param("episodes", 4);
  ASSERT_TRUE(h.WaitForSim());
  for (int task = 1; task <= 5; ++task) {
    int reached = 0;
    for (int e = 0; e < episodes; ++e) {
      const auto res = CallReset(h.nh(), task, 100 * task + e);
      ASSERT_TRUE(res.ok) << res.message;
      const uint32_t id = res.observation.episode_id;
      const bool ok = h.WaitFor(
          [&] {
            return h.latest() && h.latest()->episode_id == id &&
                   (h.latest()->success || h.latest()->last);
          },
          60.0);
      ASSERT_TRUE(ok) << "task " << task << " episode " << e << " stalled";
      if (h.latest()->success) {
        ++reached;
        EXPECT_GT(h.latest()->step, 5u);  // it really drove there
      }
    }
    EXPECT_GE(reached, std::ceil(0.95 * episodes)) << "task " << task;
  }
}

// Malformed actions are rejected and counted; the node keeps serving.
TEST(SimBadInput, RejectsAndKeepsServing) {
  RosTestHelper h;
  ASSERT_TRUE(h.WaitForSim());
  const auto res = CallReset(h.nh(), 2, 7);
  ASSERT_TRUE(res.ok);
  const uint32_t id = res.observation.episode_id;
  const float x0 = res.observation.state[0], y0 = res.observation.state[1];
  h.SendAction(id, 0, {0.1f});              // wrong length
  h.SendAction(id, 0, {0.1f, 0.2f, 0.3f});  // wrong length
  h.SendAction(id, 0, {NAN, 0.f});          // NaN
  h.SendAction(id, 0, {0.f, INFINITY});     // Inf
  ASSERT_TRUE(h.WaitFor(
      [&] {
        return h.Counter("rejected_wrong_length") >= 2 && h.Counter("rejected_nonfinite") >= 2;
      },
      10.0))
      << "wrong_length=" << h.Counter("rejected_wrong_length")
      << " nonfinite=" << h.Counter("rejected_nonfinite");
  EXPECT_EQ(h.Counter("steps"), 0u);  // none of them stepped the sim
  // A stale action (wrong step) is ignored, a good one (out of range: clipped) steps.
  h.SendAction(id, 5, {1.f, 0.f});
  h.SendAction(id, 0, {0.f, 5.f});
  ASSERT_TRUE(h.WaitFor(
      [&] { return h.latest() && h.latest()->episode_id == id && h.latest()->step == 1; }, 10.0));
  const double moved = std::hypot(h.latest()->state[0] - x0, h.latest()->state[1] - y0);
  EXPECT_LE(moved, 0.2 + 1e-4);  // clipped to 1, times 0.2
  EXPECT_GT(moved, 0.0);
  EXPECT_TRUE(h.WaitFor([&] { return h.Counter("clipped") >= 1 && h.Counter("stale") >= 1; }, 5.0));
}

// Sim time frozen (/use_sim_time, no /clock): diagnostics still arrive.
TEST(SimFrozenClock, DiagnosticsKeepFlowing) {
  RosTestHelper h;
  ASSERT_TRUE(h.WaitForSim());
  int arrays = 0;
  ros::Subscriber sub = h.nh().subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 10, [&](const diagnostic_msgs::DiagnosticArray::ConstPtr&) { ++arrays; });
  EXPECT_TRUE(h.WaitFor([&] { return arrays >= 3; }, 30.0)) << arrays << " diagnostics arrays";
  EXPECT_EQ(ros::Time::now().toSec(), 0.0);  // the clock really is frozen
}

// The reset, set_goal and pause services.
TEST(SimServices, ResetSetGoalPause) {
  RosTestHelper h;
  ASSERT_TRUE(h.WaitForSim());
  const auto map = sim::MazeMap::FromName("medium");
  for (int task = 1; task <= 5; ++task) {
    const auto res = CallReset(h.nh(), task, 3);
    ASSERT_TRUE(res.ok) << res.message;
    const auto& t = map.Tasks()[task - 1];
    const auto s = map.CellCenter(t.start), g = map.CellCenter(t.goal);
    EXPECT_LE(std::abs(res.observation.state[0] - s.x()), 1.1 + 1e-5);
    EXPECT_LE(std::abs(res.observation.state[1] - s.y()), 1.1 + 1e-5);
    EXPECT_LE(std::abs(res.goal[0] - g.x()), 1.0 + 1e-5);
    EXPECT_LE(std::abs(res.goal[1] - g.y()), 1.0 + 1e-5);
    EXPECT_EQ(res.observation.step, 0u);
  }
  // Same seed, same start.
  const auto a = CallReset(h.nh(), 3, 42), b = CallReset(h.nh(), 3, 42);
  EXPECT_EQ(a.observation.state, b.observation.state);
  EXPECT_EQ(a.goal, b.goal);
  EXPECT_EQ(b.observation.episode_id, a.observation.episode_id + 1);
  // A bad task id is refused with a message.
  const auto bad = CallReset(h.nh(), 9, 0);
  EXPECT_FALSE(bad.ok);
  EXPECT_NE(bad.message.find("task_id"), std::string::npos);
  // set_goal
  ros::ServiceClient sg = h.nh().serviceClient<msspr::SetGoal>("set_goal");
  msspr::SetGoal g;
  g.request.goal = {8.f, 0.f};
  ASSERT_TRUE(sg.call(g));
  EXPECT_TRUE(g.response.ok);
  g.request.goal = {1.f};
  ASSERT_TRUE(sg.call(g));
  EXPECT_FALSE(g.response.ok);
  // pause: actions are ignored until resumed.
  ros::ServiceClient pc = h.nh().serviceClient<msspr::Pause>("pause");
  msspr::Pause p;
  p.request.pause = true;
  ASSERT_TRUE(pc.call(p));
  EXPECT_TRUE(p.response.paused);
  const uint32_t id = b.observation.episode_id;  // the refused reset started nothing
  h.SendAction(id, 0, {1.f, 0.f});
  ASSERT_TRUE(h.WaitFor([&] { return h.Counter("ignored_paused") >= 1; }, 5.0));
  p.request.pause = false;
  ASSERT_TRUE(pc.call(p));
  h.SendAction(id, 0, {1.f, 0.f});
  ASSERT_TRUE(h.WaitFor(
      [&] { return h.latest() && h.latest()->episode_id == id && h.latest()->step == 1; }, 5.0));
  EXPECT_FLOAT_EQ(h.latest()->goal[0], 8.f);  // the goal set above holds
}

// sim.launch's robot_description, joint_states, tf2 and markers agree with the maze
// and with the observations.
TEST(SimRobotAndMarkers, AgreeWithTheMaze) {
  RosTestHelper h;
  ASSERT_TRUE(h.WaitForSim());
  const auto map = sim::MazeMap::FromName("medium");
  // robot_description: present, parsed by urdfdom, and consistent with the simulation.
  std::string xml;
  ASSERT_TRUE(h.nh().getParam("robot_description", xml))
      << "no robot_description in " << h.nh().getNamespace();
  sim::PointMaze env(sim::PointMazeOptions{});
  const auto robot =
      ros_bridge::CheckPointRobotUrdf(xml, "robot_description", env, "world", "agent");
  EXPECT_EQ(robot.chain.size(), 2u);

  visualization_msgs::MarkerArray::ConstPtr markers;
  sensor_msgs::JointState::ConstPtr joints;
  auto msub = h.nh().subscribe<visualization_msgs::MarkerArray>(
      "markers", 10, [&](const visualization_msgs::MarkerArray::ConstPtr& m) { markers = m; });
  auto jsub = h.nh().subscribe<sensor_msgs::JointState>(
      "joint_states", 100, [&](const sensor_msgs::JointState::ConstPtr& j) { joints = j; });
  tf2_ros::Buffer tf_buffer;
  tf2_ros::TransformListener tf_listener(tf_buffer);
  // joint_states and /tf are not latched: connect before the steps that publish them.
  ASSERT_TRUE(
      h.WaitFor([&] { return jsub.getNumPublishers() > 0 && msub.getNumPublishers() > 0; }, 10.0));
  ros::WallDuration(1.0).sleep();  // the tf listener's own connection
  const auto res = CallReset(h.nh(), 2, 5);
  ASSERT_TRUE(res.ok) << res.message;
  // Walk a few steps east so that the path has points.
  const uint32_t id = res.observation.episode_id;
  for (uint32_t k = 0; k < 5; ++k) {
    h.SendAction(id, k, {0.5f, 0.f});
    ASSERT_TRUE(h.WaitFor(
        [&] { return h.latest() && h.latest()->episode_id == id && h.latest()->step == k + 1; },
        10.0));
  }
  const auto obs = *h.latest();
  auto find = [&](const std::string& ns) -> const visualization_msgs::Marker* {
    if (!markers) return nullptr;
    for (const auto& m : markers->markers)
      if (m.ns == ns) return &m;
    return nullptr;
  };
  // The path marker is refreshed at 5 Hz of wall time: wait for one that ends at the current state.
  ASSERT_TRUE(h.WaitFor(
      [&] {
        const auto* p = find("path");
        return p && !p->points.empty() && std::abs(p->points.back().x - obs.state[0]) < 1e-4 &&
               std::abs(p->points.back().y - obs.state[1]) < 1e-4;
      },
      10.0))
      << "no path marker up to the current state";
  const auto* walls = find("walls");
  ASSERT_NE(walls, nullptr);
  EXPECT_EQ(walls->header.frame_id, "world");
  size_t n_walls = 0;
  for (int i = 0; i < map.rows(); ++i)
    for (int j = 0; j < map.cols(); ++j) n_walls += map.IsWall({i, j}) ? 1 : 0;
  ASSERT_EQ(walls->points.size(), n_walls);
  for (const auto& p : walls->points) {
    const sim::Cell c = map.XYToCell({p.x, p.y});
    EXPECT_TRUE(map.IsWall(c)) << p.x << ", " << p.y;
    EXPECT_NEAR(p.x, map.CellCenter(c).x(), 1e-9);
    EXPECT_NEAR(p.y, map.CellCenter(c).y(), 1e-9);
  }
  EXPECT_DOUBLE_EQ(walls->scale.x, sim::kCellSize);
  const auto* goal = find("goal");
  ASSERT_NE(goal, nullptr);
  EXPECT_NEAR(goal->pose.position.x, res.goal[0], 1e-5);
  EXPECT_NEAR(goal->pose.position.y, res.goal[1], 1e-5);
  EXPECT_DOUBLE_EQ(goal->scale.x, 2.0);  // the success radius, 1 m
  const auto* path = find("path");
  EXPECT_EQ(path->points.size(), 6u);  // the start and five steps
  EXPECT_NEAR(path->points.front().x, res.observation.state[0], 1e-5);
  // joint_states and tf2 follow the state.
  ASSERT_TRUE(h.WaitFor(
      [&] { return joints && std::abs(joints->position[0] - obs.state[0]) < 1e-5; }, 10.0));
  ASSERT_EQ(joints->name, (std::vector<std::string>{"agent_x", "agent_y"}));
  EXPECT_NEAR(joints->position[1], obs.state[1], 1e-5);
  geometry_msgs::TransformStamped tf;
  ASSERT_TRUE(h.WaitFor(
      [&] {
        try {
          tf = tf_buffer.lookupTransform("world", "agent", ros::Time(0));
          return std::abs(tf.transform.translation.x - obs.state[0]) < 1e-5;
        } catch (const tf2::TransformException&) {
          return false;
        }
      },
      10.0));
  EXPECT_NEAR(tf.transform.translation.y, obs.state[1], 1e-5);
  EXPECT_NEAR(tf.transform.translation.z, sim::kAgentRadius, 1e-9);
}

// A live recording (rosbag record of sim + navigate expert) equals msspr_collect's writer.
TEST(LiveRecording, EqualsDirectWriter) {
  LiveRecording rec("msspr_live", "/msspr/camera/image");
  ASSERT_TRUE(rec.started());
  RosTestHelper h;  // with the recorder and the expert: 3 observation subscribers start the sim
  const int kEpisodes = 4, kLength = 40;
  ASSERT_TRUE(rec.Finish(h, kEpisodes, kLength)) << "live collection did not finish";
  const std::string& bag = rec.bag();

  sim::PointMazeOptions eo;
  eo.enable_rendering = true;
  sim::PointMaze env(eo);
  sim::CollectOptions co;
  co.episode_length = kLength;
  co.seed = 11;
  co.images = true;
  ros_bridge::DatasetBagReader reader(bag);
  int k = 0;
  reader.ForEachEpisode([&](ros_bridge::BagEpisode&& ep) {
    ASSERT_LT(k, kEpisodes);
    const sim::Episode direct = sim::CollectEpisode(env, co, static_cast<uint64_t>(k));
    EXPECT_TRUE(ep.complete()) << (ep.problems.empty() ? "" : ep.problems[0]);
    EXPECT_EQ(ep.meta.split, k == kEpisodes - 1 ? "val" : "train");
    EXPECT_EQ(ep.meta.seed, direct.seed);
    ASSERT_EQ(ep.num_steps, kLength);
    // The ROS path and the in-process writer compute the expert's action in
    // different binaries; GCC's optimiser can keep or drop the float32 rounding of
    // the state there, so values may differ in the last bit (seen: 1 ULP). They
    // must agree to well within sensor precision, step for step.
    ASSERT_EQ(ep.observations.size(), direct.observations.size());
    ASSERT_EQ(ep.actions.size(), direct.actions.size());
    double max_obs = 0, max_act = 0;
    for (size_t i = 0; i < ep.observations.size(); ++i)
      max_obs = std::max(max_obs, std::abs(double(ep.observations[i]) - direct.observations[i]));
    for (size_t i = 0; i < ep.actions.size(); ++i)
      max_act = std::max(max_act, std::abs(double(ep.actions[i]) - direct.actions[i]));
    EXPECT_LT(max_obs, 1e-4) << "episode " << k;
    EXPECT_LT(max_act, 1e-4) << "episode " << k;
    ASSERT_EQ(ep.images.size(), direct.images.size());
    size_t differing = 0;
    for (size_t i = 0; i < ep.images.size(); ++i) differing += ep.images[i] != direct.images[i];
    EXPECT_LT(differing, ep.images.size() / 1000) << "episode " << k;  // < 0.1% of the bytes
    ++k;
  });
  EXPECT_EQ(k, kEpisodes);
  rec.Cleanup();
}

}  // namespace
}  // namespace msspr::testing

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "msspr_rostest", ros::init_options::AnonymousName);
  ros::Time::init();
  return RUN_ALL_TESTS();
}
