// rostest scenarios of msspr_sim_node with ~env cube-single: the
// play oracle, as a client that sees only the ROS observations
// (CubeGoalOracle), reaches the goals of the 5 evaluation tasks; the node
// serves robot_description, joint_states and tf2 for every URDF link, the
// cube and the goal, consistent with the observations; reset / set_goal /
// pause and malformed actions.
#include <gtest/gtest.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/JointState.h>
#include <sys/wait.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <regex>
#include <set>
#include <string>

#include "cli_test_util.h"
#include "msspr/Pause.h"
#include "msspr/Reset.h"
#include "msspr/SetGoal.h"
#include "msspr_bags/dataset_bag.h"
#include "msspr_sim/arm_model.h"
#include "msspr_sim/cube_dataset.h"
#include "msspr_sim/package_files.h"
#include "msspr_sim_nodes/cube_goal_oracle.h"
#include "msspr_sim_nodes/cube_sim_node.h"
#include "ros_test_helper.h"

namespace msspr::testing {
namespace {

std::vector<float> ToVec(const sim::CubeEnv::Action& a) {
  return std::vector<float>(a.begin(), a.end());
}

// Drives one episode in lockstep with the oracle; returns the last observation.
msspr::Observation::ConstPtr RunEpisode(RosTestHelper& h, ros_bridge::CubeGoalOracle& oracle,
                                        int task, uint64_t seed) {
  const auto res = CallReset(h.nh(), task, seed);
  EXPECT_TRUE(res.ok) << res.message;
  if (!res.ok) return nullptr;
  EXPECT_EQ(res.observation.state.size(), 28u);
  EXPECT_EQ(res.goal.size(), 28u);
  oracle.Reset(seed);
  const uint32_t id = res.observation.episode_id;
  uint32_t step = 0;
  msspr::Observation::ConstPtr o = boost::make_shared<msspr::Observation>(res.observation);
  while (ros::ok()) {
    if (o->success || o->last) return o;
    h.SendAction(id, step, ToVec(oracle.Act(o->state.data(), res.goal.data())));
    ++step;
    const bool ok = h.WaitFor(
        [&] { return h.latest() && h.latest()->episode_id == id && h.latest()->step == step; },
        10.0);
    EXPECT_TRUE(ok) << "task " << task << " seed " << seed << " stalled at step " << step;
    if (!ok) return nullptr;
    o = h.latest();
  }
  return nullptr;
}

// The oracle over ROS reaches each task's goal in >= 90% of ~episodes episodes.
TEST(CubeSimOracle, ReachesTaskGoals) {
  RosTestHelper h;
  ros::NodeHandle pnh("~");
  const int episodes = pnh.param("episodes", 3);
  ASSERT_TRUE(h.WaitForSim());
  ros_bridge::CubeGoalOracle oracle(sim::DefaultArmUrdf(), 0);
  for (int task = 1; task <= 5; ++task) {
    int reached = 0;
    double steps = 0;
    for (int e = 0; e < episodes; ++e) {
      const auto last = RunEpisode(h, oracle, task, 1000 * task + e);
      ASSERT_TRUE(last);
      if (last->success) {
        ++reached;
        steps += last->step;
        EXPECT_GT(last->step, 20u);  // it really carried the cube there
      }
    }
    std::printf("[cube oracle over ROS] task %d: %d / %d reached, mean %.0f steps\n", task, reached,
                episodes, reached > 0 ? steps / reached : 0.0);
    EXPECT_GE(reached, std::ceil(0.9 * episodes)) << "task " << task;
  }
}

// robot_description, joint_states and tf2 (every link, the cube, the goal),
// consistent with the observation; images when asked for.
TEST(CubeSimOracle, RobotDescriptionJointStatesTf) {
  RosTestHelper h;
  ASSERT_TRUE(h.WaitForSim());
  std::string xml;
  ASSERT_TRUE(h.nh().getParam("robot_description", xml))
      << "no robot_description in " << h.nh().getNamespace();
  const sim::ArmModel arm = sim::ArmModel::FromString(xml, "robot_description");
  std::set<std::string> moving;
  for (const auto& l : arm.links())
    if (l.type != sim::ArmModel::JointType::kFixed && l.parent >= 0) moving.insert(l.joint);
  EXPECT_EQ(moving.size(), 8u);  // 6 arm joints and 2 fingers

  sensor_msgs::JointState::ConstPtr joints;
  auto jsub = h.nh().subscribe<sensor_msgs::JointState>(
      "joint_states", 100, [&](const sensor_msgs::JointState::ConstPtr& j) { joints = j; });
  tf2_ros::Buffer tf_buffer;
  tf2_ros::TransformListener tf_listener(tf_buffer);
  ASSERT_TRUE(h.WaitFor([&] { return jsub.getNumPublishers() > 0; }, 10.0));
  ros::WallDuration(1.0).sleep();  // the tf listener's own connection
  const auto res = CallReset(h.nh(), 3, 7);
  ASSERT_TRUE(res.ok) << res.message;
  ros_bridge::CubeGoalOracle oracle(sim::DefaultArmUrdf(), 7);
  uint32_t step = 0;
  msspr::Observation::ConstPtr o = boost::make_shared<msspr::Observation>(res.observation);
  for (; step < 40; ++step) {  // the arm moves toward the cube
    h.SendAction(res.observation.episode_id, step,
                 ToVec(oracle.Act(o->state.data(), res.goal.data())));
    ASSERT_TRUE(h.WaitFor([&] { return h.latest() && h.latest()->step == step + 1; }, 10.0));
    o = h.latest();
  }
  ASSERT_TRUE(h.WaitFor([&] { return joints && joints->header.stamp == o->header.stamp; }, 5.0));
  ASSERT_EQ(joints->name.size(), joints->position.size());
  EXPECT_EQ(std::set<std::string>(joints->name.begin(), joints->name.end()), moving);
  for (size_t i = 0; i < joints->name.size() && i < 6;
       ++i)  // the arm joints come first, as in the state
    EXPECT_NEAR(joints->position[i], o->state[i], 1e-5) << joints->name[i];

  // tf2: every link, the cube and the goal, at the observation's stamp.
  const ros::Time stamp = o->header.stamp;
  for (const auto& l : arm.links()) {
    if (l.parent < 0) continue;
    EXPECT_TRUE(tf_buffer.canTransform("world", l.name, stamp, ros::Duration(5.0))) << l.name;
  }
  ASSERT_TRUE(tf_buffer.canTransform("world", "cube", stamp, ros::Duration(5.0)));
  ASSERT_TRUE(tf_buffer.canTransform("world", "cube_goal", stamp, ros::Duration(5.0)));
  const Eigen::Isometry3d pinch =
      tf2::transformToEigen(tf_buffer.lookupTransform("world", "pinch", stamp));
  const Eigen::Vector3d pinch_obs =
      Eigen::Vector3d(0.425, 0, 0) +
      Eigen::Vector3d(o->state[12], o->state[13], o->state[14]) / 10.0;
  // The observation reads MuJoCo's site / body positions after mj_step, which
  // computes them before the last 2 ms integration (OGBench's reading too);
  // tf2 poses the links at the final qpos: a moving arm differs by ~1 mm.
  EXPECT_LT((pinch.translation() - pinch_obs).norm(), 3e-3);
  const Eigen::Isometry3d cube =
      tf2::transformToEigen(tf_buffer.lookupTransform("world", "cube", stamp));
  EXPECT_LT((cube.translation() - ros_bridge::CubePositionFromObservation(o->state.data())).norm(),
            3e-3);
  const Eigen::Isometry3d goal =
      tf2::transformToEigen(tf_buffer.lookupTransform("world", "cube_goal", stamp));
  EXPECT_LT((goal.translation().head<2>() -
             ros_bridge::CubePositionFromObservation(res.goal.data()).head<2>())
                .norm(),
            1e-4);
}

// reset / set_goal / pause and malformed actions, as for the maze.
TEST(CubeSimOracle, ServicesAndBadInput) {
  RosTestHelper h;
  ASSERT_TRUE(h.WaitForSim());
  EXPECT_FALSE(CallReset(h.nh(), 0, 1).ok);
  EXPECT_FALSE(CallReset(h.nh(), 6, 1).ok);
  const auto a = CallReset(h.nh(), 2, 11), b = CallReset(h.nh(), 2, 11);
  ASSERT_TRUE(a.ok && b.ok);
  EXPECT_EQ(a.observation.state, b.observation.state);  // seeded
  EXPECT_EQ(a.goal, b.goal);
  // set_goal: the goal of a later task; success and the published goal follow it.
  ros::ServiceClient sg = h.nh().serviceClient<msspr::SetGoal>("set_goal");
  msspr::SetGoal g;
  g.request.goal = {1.0f, 2.0f};
  ASSERT_TRUE(sg.call(g));
  EXPECT_FALSE(g.response.ok);
  const auto other = CallReset(h.nh(), 5, 3);
  const auto cur = CallReset(h.nh(), 2, 11);
  g.request.goal = other.goal;
  ASSERT_TRUE(sg.call(g));
  EXPECT_TRUE(g.response.ok) << g.response.message;
  const uint32_t id = cur.observation.episode_id;
  h.SendAction(id, 0, {0, 0, 0, 0, 0});
  ASSERT_TRUE(h.WaitFor(
      [&] { return h.latest() && h.latest()->episode_id == id && h.latest()->step == 1; }, 10));
  EXPECT_EQ(h.latest()->goal, other.goal);
  // pause: lockstep does not step
  ros::ServiceClient pc = h.nh().serviceClient<msspr::Pause>("pause");
  msspr::Pause p;
  p.request.pause = true;
  ASSERT_TRUE(pc.call(p));
  h.SendAction(id, 1, {0, 0, 0, 0, 0});
  ros::WallDuration(0.5).sleep();
  ros::spinOnce();
  EXPECT_EQ(h.latest()->step, 1u);
  p.request.pause = false;
  ASSERT_TRUE(pc.call(p));
  // bad actions: wrong length, NaN; then a good one steps
  h.SendAction(id, 1, {0, 0});
  h.SendAction(id, 1, {0, 0, NAN, 0, 0});
  h.SendAction(id, 1, {0, 0, 0.5f, 0, 0});
  ASSERT_TRUE(h.WaitFor([&] { return h.latest()->step == 2; }, 10));
  EXPECT_TRUE(h.WaitFor(
      [&] {
        return h.Counter("rejected_wrong_length") >= 1 && h.Counter("rejected_nonfinite") >= 1;
      },
      5.0));
}

// Runs msspr_eval in this node's namespace with ARGS and --out JSON (removed
// first), prints its output (kept in *output if given), asserts it exits 0 and
// reads the results JSON into *j.
void RunEval(const std::string& args, const std::string& json, std::string* j,
             std::string* output = nullptr) {
  std::remove(json.c_str());
  const std::string cmd = std::string(MSSPR_EVAL_EXE) + " __ns:=" + ros::this_node::getNamespace() +
                          " " + args + " --out " + json + " 2>&1";
  FILE* p = popen(cmd.c_str(), "r");
  ASSERT_NE(p, nullptr);
  std::string out;
  char buf[4096];
  size_t n;
  while ((n = fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  const int status = pclose(p);
  std::printf("%s\n", out.c_str());
  if (output) *output = out;
  ASSERT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << out;
  std::ifstream in(json);
  j->assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// msspr_eval --env cube-single against msspr_cube_oracle_node (eval_cube_oracle.test):
// OGBench's protocol over ROS, the oracle at >= 90% on each task, the results JSON.
TEST(CubeEvalOracle, FiveTasks) {
  ros::NodeHandle pnh("~");
  const int episodes = pnh.param("episodes", 5);
  const std::string json = "/tmp/msspr_cube_eval_" + std::to_string(getpid()) + ".json";
  std::string j, out;
  ASSERT_NO_FATAL_FAILURE(RunEval(
      "--env cube-single --episodes " + std::to_string(episodes) + " --seed 3 --agent cube-oracle",
      json, &j, &out));
  EXPECT_NE(j.find("\"env\": \"cube-single\""), std::string::npos) << j;
  EXPECT_NE(j.find("\"max_steps\": 200"), std::string::npos) << j;
  EXPECT_NE(j.find("\"stalled_episodes\": 0"), std::string::npos) << j;
  int tasks = 0;
  for (size_t at = j.find("\"success\": "); at != std::string::npos;
       at = j.find("\"success\": ", at + 1)) {
    const double success = std::stod(j.substr(at + 11));
    EXPECT_GE(success, 0.9) << j;
    ++tasks;
  }
  EXPECT_EQ(tasks, 5) << j;
  // How the failed episodes failed, counted over every episode from the sim's observations.
  std::smatch m;
  ASSERT_TRUE(std::regex_search(out, m, std::regex(R"(failures: (\d+) of (\d+) episodes)"))) << out;
  EXPECT_EQ(std::stoi(m[2]), 5 * episodes) << out;
  EXPECT_LE(std::stoi(m[1]), 5 * episodes / 10) << out;  // the oracle succeeds in >= 90%
  std::remove(json.c_str());
}

// msspr_eval --env cube-single against the shipped cube checkpoint served by
// msspr_policy_node through config/robots/ur5e_cube.yaml (policy_robot_cube.test):
// standard messages only between the policy and the sim (joint_states, tf2,
// gripper/joint_states, cube_pose, goal_observation in; ee_twist and
// gripper_command out). Every episode runs to its end (none stalls), the results
// name the robot, and it reaches goals: at least 2 of 20 episodes (it reached
// 6 of 20 here, as over the native topics).
TEST(CubeEvalRobot, ServedThroughTheSpecReachesGoals) {
  ros::NodeHandle pnh("~");
  const int episodes = pnh.param("episodes", 4);
  const std::string json = "/tmp/msspr_cube_robot_eval_" + std::to_string(getpid()) + ".json";
  std::string j;
  ASSERT_NO_FATAL_FAILURE(RunEval("--env cube-single --episodes " + std::to_string(episodes) +
                                      " --agent msspr-cube-state --robot ur5e_cube",
                                  json, &j));
  EXPECT_NE(j.find("\"robot\": \"ur5e_cube\""), std::string::npos) << j;
  EXPECT_NE(j.find("\"stalled_episodes\": 0"), std::string::npos) << j;
  const size_t at = j.find("\"mean_success\": ");
  ASSERT_NE(at, std::string::npos) << j;
  EXPECT_GE(std::stod(j.substr(at + 16)) * 5 * episodes, 2.0 - 1e-9) << j;
  std::remove(json.c_str());
}

// The same in real time (policy_robot_cube_realtime.test: the sim steps at 20 Hz of wall
// time, the policy node acts on its own clock, as on a robot): the pinch point comes from
// tf2 (world -> pinch_controller) at each tick, and the node serves it fresh. Over one
// episode of task 2 the policy's own commands (not stop commands for stale inputs) cover
// at least 80% of the episode's ticks, and the episode ends (by success or the step
// limit) without a stall.
TEST(CubeEvalRobot, RealtimeServesTf2FieldsFresh) {
  RosTestHelper h;
  const char* kStatus = ": robot ur5e_cube";
  ASSERT_TRUE(h.WaitFor([&] { return !std::isnan(h.DiagNumber(kStatus, "commands")); }, 30.0))
      << "no /diagnostics from the policy node";
  const double commands0 = h.DiagNumber(kStatus, "commands");
  const double stops0 = h.DiagNumber(kStatus, "stop_commands");
  const std::string json = "/tmp/msspr_cube_robot_rt_" + std::to_string(getpid()) + ".json";
  std::string j;
  ASSERT_NO_FATAL_FAILURE(
      RunEval("--env cube-single --episodes 1 --tasks 2 --agent msspr-cube-state --robot ur5e_cube",
              json, &j));
  std::remove(json.c_str());
  EXPECT_NE(j.find("\"stalled_episodes\": 0"), std::string::npos) << j;
  // The episode's ticks: to its success, or the 200-step limit.
  const size_t s_at = j.find("\"success\": "), m_at = j.find("\"mean_steps_successful\": ");
  ASSERT_TRUE(s_at != std::string::npos && m_at != std::string::npos) << j;
  const double ticks =
      std::stod(j.substr(s_at + 11)) > 0.5 ? std::stod(j.substr(m_at + 25)) : 200.0;
  const double before = ros::WallTime::now().toSec();
  ASSERT_TRUE(h.WaitFor([&] { return ros::WallTime::now().toSec() - before > 1.5; }, 5.0));
  // The policy's own commands (not stops); once the episode ends the inputs go stale and
  // the node sends only stop commands.
  const double commands = h.DiagNumber(kStatus, "commands") - commands0;
  const double stops = h.DiagNumber(kStatus, "stop_commands") - stops0;
  std::printf("real time through ur5e_cube: %.0f ticks, %.0f commands, %.0f stop commands\n", ticks,
              commands, stops);
  EXPECT_GE(commands - stops, 0.8 * ticks) << "stops " << stops;
}

#if defined(MSSPR_BAG_INFO_EXE) && defined(MSSPR_TRAIN_EXE)
// A robot under a namespace: the arm's standard topics (/msspr/joint_states beside
// /msspr/gripper/joint_states, the cube's pose, tf, the goal and both commands), recorded
// with `rosbag record` while the shipped checkpoint drives the arm through
// config/robots/ur5e_cube.yaml (msspr_eval, one episode of two tasks), read by
// msspr_bag_info --robot ur5e_cube.yaml and trained on by msspr_train --robot.
TEST(CubeRobotRecording, NamespacedStandardTopicsReadAndTrainThroughTheSpec) {
  LiveRecording rec(
      "msspr_cube_robot",
      {"/msspr/joint_states", "/msspr/gripper/joint_states", "/msspr/cube_pose", "/tf",
       "/tf_static", "/msspr/goal_observation", "/msspr/ee_twist", "/msspr/gripper_command"});
  ASSERT_TRUE(rec.started());
  ros::WallDuration(3.0).sleep();  // the recorder subscribes
  const std::string json = "/tmp/msspr_cube_robot_rec_" + std::to_string(getpid()) + ".json";
  std::string j;
  ASSERT_NO_FATAL_FAILURE(RunEval(
      "--env cube-single --episodes 1 --tasks 1,2 --agent msspr-cube-state --robot ur5e_cube", json,
      &j));
  std::remove(json.c_str());
  rec.Stop();
  const std::string spec = std::string(MSSPR_SOURCE_DIR) + "/config/robots/ur5e_cube.yaml";
  const test::ToolOutput info =
      test::RunTool(std::string(MSSPR_BAG_INFO_EXE) + " --robot " + spec + " " + rec.bag(), 120);
  std::printf("%s\n", info.text.c_str());
  EXPECT_NE(info.status, 2) << info.text;  // problems (e.g. a stale tick at a reset) may exit 1
  const size_t at = info.text.find("with observation and action -> ");
  ASSERT_NE(at, std::string::npos) << info.text;
  const size_t steps_at = info.text.find("trajectories, ", at);
  ASSERT_NE(steps_at, std::string::npos) << info.text;
  EXPECT_GE(std::stoi(info.text.substr(steps_at + 14)), 50) << info.text;
  const std::string out = "/tmp/msspr_cube_robot_run_" + std::to_string(getpid());
  const test::ToolOutput t = test::RunTool(
      std::string(MSSPR_TRAIN_EXE) + " --data " + rec.bag() + " --robot " + spec +
          " --scale cpu --steps 2 --batch 16 --eval-every 0 --threads 1 --quiet --out " + out,
      180);
  std::printf("%s\n", t.text.c_str());
  EXPECT_EQ(t.status, 0) << t.text;
  EXPECT_NE(t.text.find("steps"), std::string::npos) << t.text;
  std::system(("rm -rf " + out).c_str());
  if (!std::getenv("MSSPR_KEEP_BAG")) rec.Cleanup();
}
#endif

// Live collection (the sim's collection mode + msspr_cube_oracle_node in play
// mode, recorded by rosbag record) writes msspr_collect --env cube-single's
// layout: the same resets (seeds, splits, first observations), no goal, a
// recorded action for every step, and play that moves the cube. The numbers
// after the first step differ from the direct writer's: the ROS oracle plans
// on a mirror posed from float32 observations and draws its own first target.
TEST(CubeLiveRecording, PlayDataInTheCollectLayout) {
  LiveRecording rec("msspr_cube_live");
  ASSERT_TRUE(rec.started());
  RosTestHelper h;  // with the recorder and the oracle: 3 observation subscribers start the sim
  const int kEpisodes = 3, kLength = 150;
  ASSERT_TRUE(rec.Finish(h, kEpisodes, kLength)) << "live collection did not finish";
  const std::string& bag = rec.bag();

  sim::CubeEnvOptions eo;
  eo.urdf_path = sim::DefaultArmUrdf();
  sim::CubeEnv env(eo);
  sim::CubeCollectOptions co;
  co.episode_length = 2;  // the reset and one step suffice for the comparison
  co.seed = 11;
  ros_bridge::DatasetBagReader reader(bag);
  int k = 0;
  double moved = 0;  // the largest cube displacement in an episode (m)
  reader.ForEachEpisode([&](ros_bridge::BagEpisode&& ep) {
    ASSERT_LT(k, kEpisodes);
    const sim::CubeEpisode direct = sim::CollectCubeEpisode(env, co, static_cast<uint64_t>(k));
    EXPECT_TRUE(ep.complete()) << (ep.problems.empty() ? "" : ep.problems[0]);
    EXPECT_EQ(ep.meta.env, "cube-single");
    EXPECT_EQ(ep.meta.split, k == kEpisodes - 1 ? "val" : "train");
    EXPECT_EQ(ep.meta.seed, direct.seed);
    EXPECT_TRUE(ep.meta.goal.empty()) << "play data has no goal";
    ASSERT_EQ(ep.num_steps, kLength);
    ASSERT_EQ(ep.obs_dim, 28);
    ASSERT_EQ(ep.act_dim, 5);
    for (int i = 0; i < 28; ++i)
      EXPECT_EQ(ep.observations[i], direct.observations[i]) << "episode " << k << " [" << i << "]";
    for (float a : ep.actions) {
      EXPECT_GE(a, -1.0f);
      EXPECT_LE(a, 1.0f);
    }
    const Eigen::Vector3d c0 = sim::CubePositionFromObservation(ep.observations.data());
    for (int t = 1; t < ep.num_steps; ++t)
      moved =
          std::max(moved, (sim::CubePositionFromObservation(&ep.observations[t * 28]) - c0).norm());
    ++k;
  });
  EXPECT_EQ(k, kEpisodes);
  EXPECT_GT(moved, 0.03) << "the play oracle never moved the cube";
  rec.Cleanup();
}

}  // namespace
}  // namespace msspr::testing

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "msspr_cube_rostest", ros::init_options::AnonymousName);
  ros::Time::init();
  return RUN_ALL_TESTS();
}
