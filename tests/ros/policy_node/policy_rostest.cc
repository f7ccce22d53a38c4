// rostest scenarios of msspr_policy_node (one suite per .test file, see
// tests/ros/policy_node/policy_*.test).
#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/image_encodings.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "msspr/Reset.h"
#include "msspr/SetGoal.h"
#include "msspr_bridge/msg_conversion.h"
#include "msspr_core/policy.h"
#include "msspr_sim/maze_map.h"
#include "policy_client.h"
#include "ros_test_helper.h"

namespace msspr::testing {
namespace {

bool CallSetGoal(ros::NodeHandle& nh, const std::string& service, std::vector<float> goal,
                 msspr::SetGoal::Response* res) {
  ros::ServiceClient c = nh.serviceClient<msspr::SetGoal>(service);
  if (!c.waitForExistence(ros::Duration(30.0))) return false;
  msspr::SetGoal srv;
  srv.request.goal = std::move(goal);
  if (!c.call(srv)) return false;
  *res = srv.response;
  return true;
}

// State input: NaN / Inf, wrong dimension and missing goal are rejected and
// counted per reason; good input afterwards is answered with the same
// (episode_id, step); ~set_goal and goal_state override the observation's goal
// until cleared.
TEST(PolicyBadInput, RejectsCountsAndKeepsServing) {
  PolicyClient c;
  ASSERT_TRUE(c.WaitForPolicy()) << "policy node not up";
  EXPECT_EQ(c.helper().DiagValue(kPolicyStatus, "goal_source"), "observation");
  c.SendObservation(3, 0, {NAN, 0.f}, {1.f, 1.f});       // NaN state
  c.SendObservation(3, 1, {0.f, 0.f, 0.f}, {1.f, 1.f});  // wrong state dimension
  c.SendObservation(3, 2, {0.f, 0.f}, {});               // no goal anywhere
  c.SendObservation(3, 3, {0.f, 0.f}, {1.f, INFINITY});  // Inf goal
  c.SendObservation(3, 4, {0.f, 0.f}, {1.f});            // wrong goal dimension
  ASSERT_TRUE(c.helper().WaitFor(
      [&] {
        return c.Diag("rejected_nonfinite") >= 2 && c.Diag("rejected_wrong_dim") >= 2 &&
               c.Diag("rejected_no_goal") >= 1;
      },
      10.0))
      << "nonfinite=" << c.Diag("rejected_nonfinite")
      << " wrong_dim=" << c.Diag("rejected_wrong_dim") << " no_goal=" << c.Diag("rejected_no_goal");
  EXPECT_EQ(c.Diag("rejected_nonfinite"), 2);
  EXPECT_EQ(c.Diag("rejected_wrong_dim"), 2);
  EXPECT_EQ(c.Diag("rejected_no_goal"), 1);
  EXPECT_EQ(c.Diag("rejected_bad_image"), 0);
  EXPECT_EQ(c.num_actions(), 0u) << "a rejected observation was answered";

  // Good input is served again, answering the same (episode_id, step).
  const std::vector<float> goal = {4.f, 0.f};
  const std::vector<std::vector<float>> states = {{0.5f, 0.5f}, {0.6f, 0.5f}};
  c.SendObservation(7, 5, states[0], goal);
  auto a = c.WaitForAction(7, 5, 10.0);
  ASSERT_TRUE(a) << "no action for a good observation after bad ones";
  ExpectValidAction(*a);
  c.SendObservation(7, 6, states[1], goal);
  auto a6 = c.WaitForAction(7, 6, 10.0);
  ASSERT_TRUE(a6);
  EXPECT_EQ(c.num_actions(), 2u);
  // Diagnostics: actions, latency percentiles and the value estimate: the
  // smaller of the critic's twin Q values of a served observation, its goal and
  // the action sent, here computed from the same checkpoint in process. The node
  // computes it for the first action of each diagnostics period: step 5 or 6.
  ASSERT_TRUE(c.WaitForCounter("actions", 2));
  ASSERT_TRUE(c.helper().WaitFor([&] { return std::isfinite(c.Diag("value_estimate")); }, 10.0))
      << "value_estimate " << c.helper().DiagValue(kPolicyStatus, "value_estimate");
  std::string checkpoint;
  ASSERT_TRUE(c.helper().nh().getParam("policy/checkpoint", checkpoint));
  core::Policy reference = core::Policy::Load(checkpoint);
  ASSERT_TRUE(reference.has_value());
  std::vector<double> expected;
  for (int k = 0; k < 2; ++k) {
    const auto& sent = k == 0 ? a->action : a6->action;
    auto tensor = [](const std::vector<float>& v) { return torch::tensor(v, torch::kFloat32); };
    const torch::Tensor q = reference.Q(tensor(states[k]), tensor(sent), tensor(goal));
    ASSERT_EQ(q.numel(), 2) << "twin Q values";
    expected.push_back(q.min().item<double>());
  }
  // The diagnostics print 4 decimals.
  const double reported = c.Diag("value_estimate");
  const double tolerance = 5e-5 + 1e-5;
  EXPECT_TRUE(std::abs(reported - expected[0]) <= tolerance ||
              std::abs(reported - expected[1]) <= tolerance)
      << "value_estimate " << reported << ", the critic's min twin Q of step 5 is " << expected[0]
      << " and of step 6 is " << expected[1];
  EXPECT_GE(c.Diag("latency_p50_ms"), 0.0);
  EXPECT_GE(c.Diag("latency_p99_ms"), c.Diag("latency_p50_ms"));

  // ~set_goal overrides the observation's (here missing) goal until cleared.
  ros::NodeHandle& nh = c.helper().nh();
  msspr::SetGoal::Response res;
  ASSERT_TRUE(CallSetGoal(nh, "policy/set_goal", {1.f}, &res));
  EXPECT_FALSE(res.ok);
  EXPECT_NE(res.message.find("2 finite numbers"), std::string::npos) << res.message;
  ASSERT_TRUE(CallSetGoal(nh, "policy/set_goal", {4.f, 0.f}, &res));
  EXPECT_TRUE(res.ok) << res.message;
  c.SendObservation(8, 0, {0.f, 0.f}, {});
  a = c.WaitForAction(8, 0, 10.0);
  ASSERT_TRUE(a) << "no action with the goal from ~set_goal";
  ExpectValidAction(*a);
  ASSERT_TRUE(c.helper().WaitFor(
      [&] { return c.helper().DiagValue(kPolicyStatus, "goal_source") == "set_goal"; }, 5.0));
  ASSERT_TRUE(CallSetGoal(nh, "policy/set_goal", {}, &res));  // clear
  EXPECT_TRUE(res.ok);
  c.SendObservation(8, 1, {0.f, 0.f}, {});
  ASSERT_TRUE(c.WaitForCounter("rejected_no_goal", 2))
      << "an empty goal after clearing was not rejected";
  EXPECT_FALSE(c.WaitForAction(8, 1, 0.5));

  // The goal_state topic (an Observation's state field) overrides as well.
  ros::Publisher goal_pub = nh.advertise<msspr::Observation>("goal_state", 1, /*latch=*/true);
  msspr::Observation g;
  g.state = {0.f, 4.f};
  goal_pub.publish(g);
  ASSERT_TRUE(c.helper().WaitFor(
      [&] { return c.helper().DiagValue(kPolicyStatus, "goal_source") == "goal_state"; }, 10.0));
  c.SendObservation(8, 2, {0.f, 0.f}, {});
  ASSERT_TRUE(c.WaitForAction(8, 2, 10.0)) << "no action with the goal from goal_state";
}

// Pixels input: a wrong image size or encoding is rejected (rejected_bad_image),
// an observation before any goal image is rejected (rejected_no_goal); a good
// image + observation pair is then answered with the same (episode_id, step).
TEST(PolicyBadInputPixels, RejectsCountsAndKeepsServing) {
  PolicyClient c(/*pixels=*/true);
  ASSERT_TRUE(c.WaitForPolicy()) << "policy node not up";
  // No goal image yet.
  c.SendImage(PolicyClient::Image(64, "rgb8", 120, PolicyClient::Stamp(2, 0)));
  c.SendObservation(2, 0, {0.f, 0.f}, {1.f, 1.f});
  ASSERT_TRUE(c.WaitForCounter("rejected_no_goal", 1)) << "no_goal=" << c.Diag("rejected_no_goal");
  // Wrong size, wrong encoding.
  c.SendImage(PolicyClient::Image(32, "rgb8", 120, PolicyClient::Stamp(2, 1)));
  c.SendObservation(2, 1, {0.f, 0.f}, {1.f, 1.f});
  c.SendImage(PolicyClient::Image(64, "bgr8", 120, PolicyClient::Stamp(2, 2)));
  c.SendObservation(2, 2, {0.f, 0.f}, {1.f, 1.f});
  sensor_msgs::Image mono = PolicyClient::Image(64, "mono8", 120, PolicyClient::Stamp(2, 3));
  mono.step = 64;
  mono.data.resize(64 * 64);
  c.SendImage(mono);
  ASSERT_TRUE(c.WaitForCounter("rejected_bad_image", 3))
      << "bad_image=" << c.Diag("rejected_bad_image");
  EXPECT_EQ(c.num_actions(), 0u);
  // A bad goal image does not replace the goal either.
  c.SendGoalImage(PolicyClient::Image(48, "rgb8", 10, PolicyClient::Stamp(2, 3)));
  ASSERT_TRUE(c.WaitForCounter("rejected_bad_image", 4));
  // With a goal image, a good pair is answered.
  c.SendGoalImage(PolicyClient::Image(64, "rgb8", 10, PolicyClient::Stamp(4, 0)));
  ros::WallDuration(0.2).sleep();
  c.SendImage(PolicyClient::Image(64, "rgb8", 200, PolicyClient::Stamp(4, 2)));
  c.SendObservation(4, 2, {0.f, 0.f}, {1.f, 1.f});
  auto a = c.WaitForAction(4, 2, 10.0);
  ASSERT_TRUE(a) << "no action for a good image + observation pair";
  ExpectValidAction(*a);
  // The observation may come first; the pair is matched by stamp.
  c.SendObservation(4, 3, {0.f, 0.f}, {1.f, 1.f});
  ros::WallDuration(0.05).sleep();
  c.SendImage(PolicyClient::Image(64, "rgb8", 201, PolicyClient::Stamp(4, 3)));
  ASSERT_TRUE(c.WaitForAction(4, 3, 10.0));
  EXPECT_EQ(c.Diag("rejected_no_goal"), 1);
  EXPECT_EQ(c.Diag("rejected_wrong_dim"), 0);
  EXPECT_EQ(c.helper().DiagValue(kPolicyStatus, "observation_mode"), "pixels");
  // ~set_goal takes states; in pixels mode it refuses with a message.
  msspr::SetGoal::Response res;
  ASSERT_TRUE(CallSetGoal(c.helper().nh(), "policy/set_goal", {1.f, 1.f}, &res));
  EXPECT_FALSE(res.ok);
  EXPECT_NE(res.message.find("goal_image"), std::string::npos) << res.message;
}

// Rate mode: the node acts at ~rate Hz on the latest observation (answering its
// episode_id / step), switches to a newer one, and stops acting once the latest
// observation is older than ~observation_timeout.
TEST(PolicyRate, ActsAtRateOnLatestObservation) {
  PolicyClient c;
  ASSERT_TRUE(c.WaitForPolicy()) << "policy node not up";
  ros::NodeHandle pnh("~");
  const double rate = pnh.param("rate", 20.0), timeout = pnh.param("observation_timeout", 0.5);
  // Given as the deprecated ~mode rate: reported as the stepping it means.
  EXPECT_EQ(c.helper().DiagValue(kPolicyStatus, "stepping"), "realtime");
  // Keep one observation fresh for ~1 s: about `rate` actions, all answering it.
  const ros::WallTime begin = ros::WallTime::now();
  while ((ros::WallTime::now() - begin).toSec() < 1.0) {
    c.SendObservation(5, 0, {0.f, 0.f}, {4.f, 0.f});
    c.helper().WaitFor([] { return false; }, 0.1);
  }
  const size_t n0 = c.num_actions();
  EXPECT_GE(n0, static_cast<size_t>(0.5 * rate))
      << "rate mode published " << n0 << " actions in 1 s";
  EXPECT_LE(n0, static_cast<size_t>(1.5 * rate + 2));
  ASSERT_TRUE(c.WaitForAction(5, 0, 1.0));
  // A newer observation is the one answered from then on.
  c.SendObservation(5, 1, {0.2f, 0.f}, {4.f, 0.f});
  ASSERT_TRUE(c.WaitForAction(5, 1, 2.0));
  // Without new observations the node stops acting after observation_timeout.
  c.helper().WaitFor([] { return false; }, timeout + 2.0 / rate + 0.2);
  const size_t n1 = c.num_actions();
  c.helper().WaitFor([] { return false; }, 0.5);
  EXPECT_EQ(c.num_actions(), n1) << "acted on an observation older than ~observation_timeout";
  ASSERT_TRUE(c.helper().WaitFor([&] { return c.Diag("action_rate_hz") >= 0.0; }, 5.0));
}

// The sim and the policy node in lockstep reach an easy goal: task 1 of
// pointmaze-medium (start in cell (1,1), around (0, 0)) with the goal moved by
// the sim's set_goal to (3, 0), along the free corridor toward cell (1,2).
TEST(PolicyReachesGoal, EasyGoalInLockstep) {
  RosTestHelper h;
  ros::NodeHandle pnh("~");
  const int episodes = pnh.param("episodes", 3);
  const int max_steps = pnh.param("max_steps", 300);
  const double gx = pnh.param("goal_x", 3.0), gy = pnh.param("goal_y", 0.0);
  const std::string checkpoint = pnh.param<std::string>("checkpoint", "");
  ASSERT_TRUE(checkpoint.empty() || std::ifstream(checkpoint).good())
      << "the trained checkpoint is missing: " << checkpoint;
  ASSERT_TRUE(h.WaitForSim());
  ASSERT_TRUE(h.WaitFor([&] { return !h.DiagValue(kPolicyStatus, "actions").empty(); }, 60.0))
      << "policy node not up (its fatal error, if any, is on its stderr)";
  ros::ServiceClient reset = h.nh().serviceClient<msspr::Reset>("reset");
  ASSERT_TRUE(reset.waitForExistence(ros::Duration(30.0)));
  int reached = 0;
  for (int e = 0; e < episodes; ++e) {
    msspr::Reset r;
    r.request.task_id = 1;
    r.request.seed = 500 + e;
    ASSERT_TRUE(reset.call(r));
    ASSERT_TRUE(r.response.ok) << r.response.message;
    const uint32_t id = r.response.observation.episode_id;
    msspr::SetGoal::Response res;
    ASSERT_TRUE(
        CallSetGoal(h.nh(), "set_goal", {static_cast<float>(gx), static_cast<float>(gy)}, &res));
    ASSERT_TRUE(res.ok) << res.message;
    const bool ended = h.WaitFor(
        [&] {
          const auto& o = h.latest();
          return o && o->episode_id == id &&
                 (o->success || o->last || o->step >= static_cast<uint32_t>(max_steps));
        },
        120.0);
    ASSERT_TRUE(ended) << "episode " << e << " stalled at step "
                       << (h.latest() ? h.latest()->step : 0);
    const auto o = h.latest();
    const bool ok = o->success && o->step <= static_cast<uint32_t>(max_steps);
    std::printf(
        "episode %d: start (%.2f, %.2f) goal (%.2f, %.2f): %s at step %u, at (%.2f, %.2f)\n", e,
        r.response.observation.state[0], r.response.observation.state[1], gx, gy,
        ok ? "reached" : "not reached", o->step, o->state[0], o->state[1]);
    reached += ok;
  }
  EXPECT_GE(reached, std::min(2, episodes))
      << reached << " of " << episodes << " episodes reached the goal";
  // The value estimate is taken once per diagnostics period (1 s).
  EXPECT_TRUE(
      h.WaitFor([&] { return std::isfinite(h.DiagNumber(kPolicyStatus, "value_estimate")); }, 5.0));
  EXPECT_EQ(h.DiagNumber(kPolicyStatus, "rejected_no_goal"), 0);
  // Value markers (~value_marker_maze medium, 2 x 2 points per free cell) for the goal
  // set above: the point next to the goal is valued above the one farthest from it by
  // the maze's paths (viridis: the green channel rises with the value).
  visualization_msgs::MarkerArray::ConstPtr values;
  auto vsub = h.nh().subscribe<visualization_msgs::MarkerArray>(
      "value_markers", 1, [&](const visualization_msgs::MarkerArray::ConstPtr& m) { values = m; });
  ASSERT_TRUE(h.WaitFor([&] { return values != nullptr; }, 10.0)) << "no value_markers";
  const auto map = sim::MazeMap::FromName("medium");
  const auto& cubes = values->markers.at(0);
  ASSERT_EQ(cubes.points.size(), 4 * map.FreeCells().size());
  ASSERT_EQ(cubes.colors.size(), cubes.points.size());
  const sim::Cell goal_cell = map.XYToCell({gx, gy});
  size_t near = 0, far = 0;
  double best = 1e9;
  int worst = -1;
  for (size_t k = 0; k < cubes.points.size(); ++k) {
    const Eigen::Vector2d p(cubes.points[k].x, cubes.points[k].y);
    const double d = (p - Eigen::Vector2d(gx, gy)).norm();
    if (d < best) best = d, near = k;
    const int moves = map.BfsDistance(map.XYToCell(p), goal_cell);
    if (moves > worst) worst = moves, far = k;
  }
  EXPECT_GT(cubes.colors[near].g, cubes.colors[far].g)
      << "V near the goal should exceed V " << worst << " cells away";
}

// The sim (pixels) and the policy node (pixels) in lockstep: camera images and
// observations are paired by stamp, every step is answered, nothing is rejected.
// Any pixel checkpoint will do (the test does not ask for success).
TEST(PolicySimPixels, LockstepLoopRuns) {
  RosTestHelper h;
  ros::NodeHandle pnh("~");
  const int steps = pnh.param("steps", 100);
  ASSERT_TRUE(h.WaitForSim());
  ASSERT_TRUE(h.WaitFor([&] { return !h.DiagValue(kPolicyStatus, "actions").empty(); }, 60.0))
      << "policy node not up";
  ros::WallDuration(0.5).sleep();
  // The reset publishes the goal image while the policy is subscribed.
  ros::ServiceClient reset = h.nh().serviceClient<msspr::Reset>("reset");
  ASSERT_TRUE(reset.waitForExistence(ros::Duration(30.0)));
  msspr::Reset r;
  r.request.task_id = 1;
  r.request.seed = 1;
  ASSERT_TRUE(reset.call(r));
  ASSERT_TRUE(r.response.ok) << r.response.message;
  const uint32_t id = r.response.observation.episode_id;
  const ros::WallTime t0 = ros::WallTime::now();
  ASSERT_TRUE(h.WaitFor(
      [&] {
        return h.latest() && h.latest()->episode_id == id &&
               h.latest()->step >= static_cast<uint32_t>(steps);
      },
      120.0))
      << "stalled at step " << (h.latest() ? h.latest()->step : 0);
  const double s = (ros::WallTime::now() - t0).toSec();
  std::printf("%d pixel lockstep steps in %.2f s (%.1f steps/s)\n", steps, s, steps / s);
  ASSERT_TRUE(h.WaitFor([&] { return h.DiagNumber(kPolicyStatus, "actions") >= steps; }, 5.0));
  for (const char* k : {"rejected_wrong_dim", "rejected_nonfinite", "rejected_no_goal",
                        "rejected_bad_image", "inference_errors"})
    EXPECT_EQ(h.DiagNumber(kPolicyStatus, k), 0) << k;
  EXPECT_TRUE(
      h.WaitFor([&] { return std::isfinite(h.DiagNumber(kPolicyStatus, "value_estimate")); }, 5.0));
}

// Runs `rosrun msspr <args...>` and returns its exit status (-1: did not exit
// within timeout_s and was stopped); output gets its stdout and stderr.
int RunRosrun(const std::vector<std::string>& args, std::string* output, double timeout_s) {
  int fds[2];
  if (pipe(fds) != 0) return -2;
  const pid_t pid = fork();
  if (pid == 0) {
    dup2(fds[1], STDOUT_FILENO);
    dup2(fds[1], STDERR_FILENO);
    close(fds[0]);
    std::vector<std::string> all = {"rosrun", "msspr"};
    all.insert(all.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : all) argv.push_back(a.data());
    argv.push_back(nullptr);
    execvp("rosrun", argv.data());
    _exit(127);
  }
  close(fds[1]);
  const auto end = ros::WallTime::now() + ros::WallDuration(timeout_s);
  char buf[4096];
  bool timed_out = false;
  for (;;) {
    const int left_ms = static_cast<int>((end - ros::WallTime::now()).toSec() * 1000);
    if (left_ms <= 0) {
      timed_out = true;
      kill(pid, SIGINT);
      break;
    }
    pollfd p{fds[0], POLLIN, 0};
    if (poll(&p, 1, left_ms) <= 0) continue;
    const ssize_t n = read(fds[0], buf, sizeof buf);
    if (n <= 0) break;
    output->append(buf, static_cast<size_t>(n));
  }
  close(fds[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (timed_out) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

// Runs the policy node with private params (`_name:=value`); see RunRosrun.
int RunPolicyNode(const std::vector<std::string>& params, std::string* output,
                  double timeout_s = 60.0) {
  static int run = 0;  // a fresh node name per run: private params stay on the server
  std::vector<std::string> args = {"msspr_policy_node",
                                   "__name:=policy_startup_check_" + std::to_string(run++)};
  args.insert(args.end(), params.begin(), params.end());
  return RunRosrun(args, output, timeout_s);
}

std::string TempPath(const std::string& name) {
  const char* dir = std::getenv("ROS_LOG_DIR");
  return std::string(dir ? dir : "/tmp") + "/" + name + "_" + std::to_string(getpid());
}

// A missing, corrupt or truncated checkpoint, a missing ~checkpoint and a
// ~observation_mode that does not match the checkpoint stop the node at start
// with an error naming the file (or the parameter) and a non-zero exit.
TEST(PolicyStartup, RefusesBadCheckpointsAndModeMismatch) {
  ros::NodeHandle pnh("~");
  std::string state_ckpt;
  ASSERT_TRUE(pnh.getParam("state_checkpoint", state_ckpt));
  ASSERT_TRUE(std::ifstream(state_ckpt).good()) << state_ckpt;

  std::string out;
  EXPECT_EQ(RunPolicyNode({}, &out), 1) << out;
  EXPECT_NE(out.find("~checkpoint is required"), std::string::npos) << out;

  out.clear();
  const std::string missing = TempPath("no_such_policy") + ".pt";
  EXPECT_EQ(RunPolicyNode({"_checkpoint:=" + missing}, &out), 1) << out;
  EXPECT_NE(out.find(missing), std::string::npos) << out;

  out.clear();
  const std::string corrupt = TempPath("corrupt_policy") + ".pt";
  std::ofstream(corrupt) << "this is not a checkpoint\n";
  EXPECT_EQ(RunPolicyNode({"_checkpoint:=" + corrupt}, &out), 1) << out;
  EXPECT_NE(out.find(corrupt), std::string::npos) << out;

  out.clear();
  const std::string truncated = TempPath("truncated_policy") + ".pt";
  {
    std::ifstream in(state_ckpt, std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(truncated, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  EXPECT_EQ(RunPolicyNode({"_checkpoint:=" + truncated}, &out), 1) << out;
  EXPECT_NE(out.find(truncated), std::string::npos) << out;

  out.clear();
  EXPECT_EQ(RunPolicyNode({"_checkpoint:=" + state_ckpt, "_observation_mode:=pixels"}, &out), 1)
      << out;
  EXPECT_NE(out.find("~observation_mode is 'pixels'"), std::string::npos) << out;
  EXPECT_NE(out.find(state_ckpt), std::string::npos) << out;

  out.clear();
  EXPECT_EQ(RunPolicyNode({"_checkpoint:=" + state_ckpt, "_mode:=sometimes"}, &out), 1) << out;
  EXPECT_NE(out.find("~mode"), std::string::npos) << out;
  EXPECT_EQ(RunPolicyNode({"_checkpoint:=" + state_ckpt, "_stepping:=sometimes"}, &out), 1) << out;
  EXPECT_NE(out.find("~stepping must be lockstep or realtime"), std::string::npos) << out;
  // The old and the new spelling given apart.
  EXPECT_EQ(
      RunPolicyNode({"_checkpoint:=" + state_ckpt, "_stepping:=lockstep", "_mode:=rate"}, &out), 1)
      << out;
  EXPECT_NE(out.find("disagree"), std::string::npos) << out;

  std::remove(corrupt.c_str());
  std::remove(truncated.c_str());
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

// The results JSON without its "wall_time_s" line (the one field that differs between runs).
std::string WithoutWallTime(const std::string& json) {
  std::istringstream in(json);
  std::string line, out;
  while (std::getline(in, line))
    if (line.find("\"wall_time_s\"") == std::string::npos) out += line + "\n";
  return out;
}

// msspr_eval --sims 2 over two sim + policy pairs (eval_parallel.test: msspr_0 and
// msspr_1) writes the same results JSON as the serial run against msspr_0 alone for
// the same seed (but wall_time_s), and both sims run episodes. A sim whose reset
// service never appears is named in the error.
TEST(EvalParallel, TwoSimsGiveTheSerialResults) {
  ros::NodeHandle pnh("~");
  const std::string tasks = pnh.param<std::string>("tasks", "1,2");
  const int episodes = pnh.param("episodes", 3);
  const int seed = pnh.param("seed", 0);
  const double timeout_s = pnh.param("run_timeout", 90.0);
  const std::vector<std::string> common = {"--maze",     "medium",
                                           "--tasks",    tasks,
                                           "--episodes", std::to_string(episodes),
                                           "--seed",     std::to_string(seed),
                                           "--agent",    "eval-parallel-test"};
  const std::string serial_json = TempPath("eval_serial") + ".json";
  const std::string parallel_json = TempPath("eval_parallel") + ".json";
  std::remove(serial_json.c_str());
  std::remove(parallel_json.c_str());

  // Serial: msspr_eval as today, in the first pair's namespace (its own relative names).
  std::vector<std::string> serial = {"msspr_eval", "__ns:=/msspr_0", "--out", serial_json};
  serial.insert(serial.end(), common.begin(), common.end());
  std::string out;
  ASSERT_EQ(RunRosrun(serial, &out, timeout_s), 0) << out;
  std::printf("serial run:\n%s\n", out.c_str());

  std::vector<std::string> parallel = {"msspr_eval", "--sims", "2",          "--sim-ns",
                                       "/msspr_",    "--out",  parallel_json};
  parallel.insert(parallel.end(), common.begin(), common.end());
  out.clear();
  ASSERT_EQ(RunRosrun(parallel, &out, timeout_s), 0) << out;
  std::printf("parallel run:\n%s\n", out.c_str());
  // Both sims ran episodes, all of them between them.
  int n0 = -1, n1 = -1;
  const auto at = out.find("episodes per sim:");
  ASSERT_NE(at, std::string::npos) << out;
  ASSERT_EQ(std::sscanf(out.c_str() + at, "episodes per sim: /msspr_0 %d /msspr_1 %d", &n0, &n1), 2)
      << out;
  const int n_tasks = static_cast<int>(std::count(tasks.begin(), tasks.end(), ',')) + 1;
  EXPECT_EQ(n0 + n1, n_tasks * episodes) << out;
  EXPECT_GE(n0, 1) << out;
  EXPECT_GE(n1, 1) << out;

  const std::string a = ReadFile(serial_json), b = ReadFile(parallel_json);
  ASSERT_FALSE(a.empty()) << "no results in " << serial_json;
  ASSERT_FALSE(b.empty()) << "no results in " << parallel_json;
  EXPECT_NE(a.find("\"wall_time_s\""), std::string::npos) << a;
  EXPECT_NE(a.find("\"episodes\": " + std::to_string(episodes)), std::string::npos) << a;
  EXPECT_EQ(WithoutWallTime(a), WithoutWallTime(b)) << "serial:\n"
                                                    << a << "\nparallel (--sims 2):\n"
                                                    << b;

  // A third sim that is not running: named in the error, exit 1.
  std::vector<std::string> missing = {"msspr_eval", "--sims", "3", "--sim-ns",
                                      "/msspr_",    "--wait", "1"};
  missing.insert(missing.end(), common.begin(), common.end());
  out.clear();
  EXPECT_EQ(RunRosrun(missing, &out, 30.0), 1) << out;
  EXPECT_NE(out.find("no reset service /msspr_2/reset"), std::string::npos) << out;
  EXPECT_EQ(out.find("/msspr_1/reset after"), std::string::npos) << out;
  std::remove(serial_json.c_str());
  std::remove(parallel_json.c_str());
}

}  // namespace
}  // namespace msspr::testing

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "msspr_policy_rostest", ros::init_options::AnonymousName);
  ros::Time::init();
  return RUN_ALL_TESTS();
}
