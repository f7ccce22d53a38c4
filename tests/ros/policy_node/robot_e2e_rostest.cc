// rostest robot_record_train_serve: a robot's whole path through a robot
// interface spec (config/robots/pointmaze_base.yaml), standard messages only.
//
// 1. Record. The point maze (namespace /rec, lockstep) runs four collection
//    episodes driven by the navigate expert. This node stands between them as
//    a robot's driver and a lossy link would: it republishes odometry on
//    /rec/robot/odom at 20 Hz (each step's pose, then the same pose again half
//    a step later: the sim's pose holds between steps), the command on
//    /rec/robot/cmd_vel at 10 Hz and the goal on /rec/robot/goal_pose once per
//    episode, dropping every 7th odometry message and every 5th command.
//    `rosbag record` writes those three topics (no msspr/* types) into a bag.
//    The command reaches the sim through this node, after its copy went to the
//    recorder, so that the recorder stamps it within the step it drove.
// 2. Check and train. msspr_bag_info --robot reads the bag (two rates, the
//    drops); msspr_train --robot trains a tiny network from it for a few
//    hundred steps.
// 3. Serve. The trained policy.pt is served by msspr_policy_node ~robot (same
//    spec, lockstep) against a second point maze (namespace /serve): it
//    publishes geometry_msgs/Twist on cmd_vel, within the spec's clip (2 m/s
//    per axis, nothing else set), and the sim steps on those commands.
//
// A tiny network trained for seconds does not reach goals; that the spec's
// serving reaches goals is checked with the shipped checkpoint in
// policy_robot.test (and demo.launch robot:=pointmaze_base). This test checks
// that the freshly trained checkpoint is served end to end.
#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/Twist.h>
#include <gtest/gtest.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <regex>
#include <string>
#include <vector>

#include "cli_test_util.h"
#include "msspr/Observation.h"
#include "msspr/Reset.h"
#include "ros_test_helper.h"

namespace {

namespace fs = std::filesystem;

constexpr int kEpisodes = 4;
constexpr int kEpisodeLength = 40;  // the launch file's episode_length
const std::string kSpec = std::string(MSSPR_SOURCE_DIR) + "/config/robots/pointmaze_base.yaml";

using msspr::testing::WaitFor;

using Output = msspr::test::ToolOutput;

// Runs a tool to its end (no ROS traffic: a master it tried to reach would be unreachable).
Output RunTool(const std::string& cmd) { return msspr::test::RunTool(cmd, 120); }

// A child process (exec of argv), stopped with SIGINT.
class Child {
 public:
  explicit Child(const std::vector<std::string>& argv) {
    pid_ = fork();
    if (pid_ == 0) {
      std::vector<char*> a;
      for (const auto& s : argv) a.push_back(const_cast<char*>(s.c_str()));
      a.push_back(nullptr);
      execvp(a[0], a.data());
      _exit(127);
    }
  }
  ~Child() { Stop(); }
  bool Running() {
    if (pid_ <= 0) return false;
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) == pid_) {
      pid_ = -1;
      return false;
    }
    return true;
  }
  void Stop() {
    if (pid_ <= 0) return;
    kill(pid_, SIGINT);
    int status = 0;
    for (int i = 0; i < 200 && waitpid(pid_, &status, WNOHANG) == 0; ++i)
      ros::WallDuration(0.05).sleep();
    if (waitpid(pid_, &status, WNOHANG) == 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, &status, 0);
    }
    pid_ = -1;
  }

 private:
  pid_t pid_ = -1;
};

TEST(RobotEndToEnd, RecordTrainServeThroughTheSpec) {
  ros::NodeHandle nh;
  const char* log_dir = std::getenv("ROS_LOG_DIR");
  const fs::path dir =
      fs::path(log_dir ? log_dir : "/tmp") / ("robot_e2e_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string bag = (dir / "robot.bag").string();
  const auto t0 = ros::WallTime::now();

  // --- 1. record -------------------------------------------------------------
  ros::Publisher odom_out = nh.advertise<nav_msgs::Odometry>("/rec/robot/odom", 100);
  ros::Publisher cmd_out = nh.advertise<geometry_msgs::Twist>("/rec/robot/cmd_vel", 100);
  ros::Publisher goal_out = nh.advertise<geometry_msgs::PoseStamped>("/rec/robot/goal_pose", 10);
  ros::Publisher to_sim = nh.advertise<geometry_msgs::Twist>("/rec/cmd_vel", 10);
  Child recorder({"rosbag", "record", "-O", bag, "/rec/robot/odom", "/rec/robot/cmd_vel",
                  "/rec/robot/goal_pose", "__name:=robot_e2e_recorder"});
  ASSERT_TRUE(WaitFor(
      [&] {
        return odom_out.getNumSubscribers() > 0 && cmd_out.getNumSubscribers() > 0 &&
               goal_out.getNumSubscribers() > 0;
      },
      60.0))
      << "rosbag record did not subscribe";

  uint64_t odom_in = 0, odom_sent = 0, odom_index = 0, cmd_in = 0, cmd_sent = 0, goals = 0;
  ros::Subscriber expert_cmd = nh.subscribe<geometry_msgs::Twist>(
      "/rec/expert/cmd_vel", 100,
      [&](const geometry_msgs::Twist::ConstPtr& m) {
        if (++cmd_in % 5 != 0) {
          cmd_out.publish(*m);
          ++cmd_sent;
        }
        ros::WallDuration(0.003).sleep();  // the recorder stamps it before the sim steps on it
        to_sim.publish(*m);
      },
      ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  ASSERT_TRUE(WaitFor(
      [&] { return expert_cmd.getNumPublishers() > 0 && to_sim.getNumSubscribers() > 0; }, 60.0))
      << "expert or sim not connected";
  ros::Subscriber goal_in = nh.subscribe<geometry_msgs::PoseStamped>(
      "/rec/goal_pose", 10, [&](const geometry_msgs::PoseStamped::ConstPtr& m) {
        goal_out.publish(*m);
        ++goals;
      });
  // Subscribing to odom starts the collection (the sim waits for two subscribers: the expert and
  // this).
  ros::Subscriber odom_sub = nh.subscribe<nav_msgs::Odometry>(
      "/rec/odom", 100,
      [&](const nav_msgs::Odometry::ConstPtr& m) {
        ++odom_in;
        nav_msgs::Odometry held = *m;
        held.header.stamp += ros::Duration(0.05);
        for (const nav_msgs::Odometry* o : {m.get(), static_cast<const nav_msgs::Odometry*>(&held)})
          if (++odom_index % 7 != 0) {
            odom_out.publish(*o);
            ++odom_sent;
          }
      },
      ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  ASSERT_TRUE(WaitFor(
      [&] {
        // (goal_pose and odom come on two connections: count odometry in all, not per episode)
        return goals == static_cast<uint64_t>(kEpisodes) &&
               odom_in >= static_cast<uint64_t>(kEpisodes * kEpisodeLength);
      },
      90.0))
      << "recording stalled: " << goals << " episodes, " << odom_in << " odometry messages";
  WaitFor([] { return false; }, 0.5);  // the last messages reach the recorder
  recorder.Stop();
  const std::string active = bag + ".active";
  WaitFor([&] { return fs::exists(bag) && !fs::exists(active); }, 10.0);
  ASSERT_TRUE(fs::exists(bag)) << "no bag " << bag;
  odom_sub.shutdown();
  expert_cmd.shutdown();
  std::printf("recorded %s: %lu odometry (of %lu), %lu commands (of %lu), %lu goals; %.1f s\n",
              bag.c_str(), odom_sent, 2 * odom_in, cmd_sent, cmd_in, goals,
              (ros::WallTime::now() - t0).toSec());

  // --- 2. check and train ----------------------------------------------------
  const Output info = RunTool(std::string(MSSPR_BAG_INFO_EXE) + " --robot " + kSpec + " " + bag);
  std::printf("%s\n", info.text.c_str());
  EXPECT_NE(info.status, 2) << info.text;
  std::smatch m;
  const std::regex row_odom(R"(position\s+odom\s+(\d+)\s+([0-9.]+))"),
      row_cmd(R"(action\s+cmd_vel\s+(\d+)\s+([0-9.]+))");
  ASSERT_TRUE(std::regex_search(info.text, m, row_odom)) << info.text;
  const double odom_hz = std::stod(m[2]);
  ASSERT_TRUE(std::regex_search(info.text, m, row_cmd)) << info.text;
  const double cmd_hz = std::stod(m[2]);
  EXPECT_GT(odom_hz, 1.5 * cmd_hz) << "odometry and commands at different rates";
  EXPECT_LT(cmd_hz, 10.0) << "commands dropped";

  const std::string config = (dir / "tiny.yaml").string();
  std::ofstream(config) << "network:\n  encoder_hidden: 32\n  zsa_hidden: 32\n  goal_hidden: 32\n"
                           "  critic_hidden: 32\n  actor_hidden: 32\n  zs_dim: 24\n  zsa_dim: 24\n"
                           "  za_dim: 16\n  goal_dim: 8\ntrainer:\n  batch_size: 32\n";
  const std::string run = (dir / "run").string();
  const auto t1 = ros::WallTime::now();
  const Output train = RunTool(std::string(MSSPR_TRAIN_EXE) + " --data " + bag + " --robot " +
                               kSpec + " --scale cpu --config " + config +
                               " --steps 300 --eval-every 0 --threads 1 --quiet --out " + run);
  std::printf("msspr_train (%.1f s):\n%s\n", (ros::WallTime::now() - t1).toSec(),
              train.text.c_str());
  ASSERT_EQ(train.status, 0) << train.text;
  const std::regex read_line(
      R"((\d+) bag\(s\): (\d+) episodes read -> (\d+) trajectories, (\d+) steps)");
  ASSERT_TRUE(std::regex_search(train.text, m, read_line)) << train.text;
  EXPECT_EQ(std::stoi(m[2]), kEpisodes) << train.text;
  EXPECT_GE(std::stoi(m[3]), kEpisodes) << train.text;
  EXPECT_GE(std::stoi(m[4]), kEpisodes * kEpisodeLength * 8 / 10) << train.text;
  const std::string policy = run + "/policy.pt";
  ASSERT_TRUE(fs::exists(policy)) << train.text;

  // --- 3. serve --------------------------------------------------------------
  uint64_t twists = 0, nonzero = 0, outside = 0;
  std::string first_outside;
  ros::Subscriber cmd = nh.subscribe<geometry_msgs::Twist>(
      "/serve/cmd_vel", 1000, [&](const geometry_msgs::Twist::ConstPtr& t) {
        ++twists;
        const bool ok = std::isfinite(t->linear.x) && std::isfinite(t->linear.y) &&
                        std::abs(t->linear.x) <= 2.0 + 1e-9 &&
                        std::abs(t->linear.y) <= 2.0 + 1e-9 && t->linear.z == 0.0 &&
                        t->angular.x == 0.0 && t->angular.y == 0.0 && t->angular.z == 0.0;
        if (!ok && outside++ == 0)
          first_outside = std::to_string(t->linear.x) + ", " + std::to_string(t->linear.y) + ", " +
                          std::to_string(t->linear.z) + " / " + std::to_string(t->angular.z);
        if (t->linear.x != 0.0 || t->linear.y != 0.0) ++nonzero;
      });
  msspr::Observation::ConstPtr latest;
  ros::Subscriber obs = nh.subscribe<msspr::Observation>(
      "/serve/observation", 100, [&](const msspr::Observation::ConstPtr& o) { latest = o; });
  Child server({MSSPR_POLICY_NODE_EXE, "__name:=trained_policy", "__ns:=/serve",
                "_checkpoint:=" + policy, "_robot:=" + kSpec, "_mode:=lockstep"});
  ASSERT_TRUE(WaitFor([&] { return cmd.getNumPublishers() > 0 || !server.Running(); }, 60.0));
  ASSERT_TRUE(server.Running())
      << "msspr_policy_node exited (its error is in the test's output above)";
  ros::ServiceClient reset = nh.serviceClient<msspr::Reset>("/serve/reset");
  ASSERT_TRUE(reset.waitForExistence(ros::Duration(30.0)));
  msspr::Reset r;
  r.request.task_id = 1;
  r.request.seed = 3;
  ASSERT_TRUE(reset.call(r));
  ASSERT_TRUE(r.response.ok) << r.response.message;
  const uint32_t id = r.response.observation.episode_id;
  const uint64_t twists_before = twists;
  EXPECT_TRUE(WaitFor(
      [&] {
        return (latest && latest->episode_id == id && latest->step >= 60) || !server.Running();
      },
      60.0))
      << "the sim did not step on the served commands: step " << (latest ? latest->step : 0) << ", "
      << twists << " commands";
  EXPECT_TRUE(server.Running());
  EXPECT_GE(twists - twists_before, 60u);
  EXPECT_GT(nonzero, 0u) << "only stop commands";
  EXPECT_EQ(outside, 0u) << "a command outside the spec's clip or with other fields set: "
                         << first_outside;
  if (latest)
    std::printf("served the trained policy: %lu commands, episode at step %u, %s; %.1f s in all\n",
                twists, latest->step,
                latest->success ? "reached the goal" : "goal not reached (tiny network)",
                (ros::WallTime::now() - t0).toSec());
  server.Stop();
  if (!::testing::Test::HasFailure())
    fs::remove_all(dir);
  else
    std::fprintf(stderr, "kept for inspection: %s\n", dir.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "msspr_robot_e2e_rostest", ros::init_options::AnonymousName);
  ros::Time::init();
  return RUN_ALL_TESTS();
}
