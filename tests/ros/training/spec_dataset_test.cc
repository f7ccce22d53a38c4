// Training from a robot's own bags through a robot interface spec:
// the spec-built dataset equals the native-topic dataset of the same
// episodes; msspr_train --robot trains from such bags and stores the spec in
// its checkpoints; msspr_bag_info --robot reports per field. No master needed.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "bag_dataset.h"
#include "cli_test_util.h"
#include "cube_spec_bag.h"
#include "msspr_core/checkpoint.h"
#include "msspr_core/npz.h"
#include "msspr_core/options.h"
#include "msspr_robot_interface/robot_spec.h"
#include "msspr_robot_interface/spec_bag.h"
#include "robot_server.h"
#include "robot_spec_test.h"
#include "torch_test_util.h"

namespace msspr {
namespace {

namespace fs = std::filesystem;

using Output = test::ToolOutput;

Output RunTool(const std::string& cmd) { return test::RunTool(cmd, 300); }

class SpecDatasetTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ros::Time::init();
    dir_ = fs::temp_directory_path() /
           ("msspr_spec_dataset_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    spec_path_ = std::string(MSSPR_SOURCE_DIR) + "/config/robots/pointmaze_base.yaml";
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  fs::path dir_;
  std::string spec_path_;
};

TEST_F(SpecDatasetTest, SpecDatasetEqualsTheNativeDataset) {
  test::SynthBagOptions o;
  o.odom_per_step = 3;  // 30 Hz odometry beside 10 Hz commands
  test::WriteSynthBag(Path("a.bag"), test::MakeSynthEpisodes(3, 30, 21), o);
  test::WriteSynthBag(Path("b.bag"), test::MakeSynthEpisodes(2, 17, 22), o);
  const ros_bridge::RobotSpec spec = ros_bridge::LoadRobotSpec(spec_path_);
  agent::BagLoadOptions native_opt, spec_opt;
  spec_opt.robot = &spec;
  agent::BagLoadReport nr, sr;
  const core::Dataset native =
      agent::LoadBagDataset({Path("a.bag"), Path("b.bag")}, native_opt, &nr);
  const core::Dataset via_spec =
      agent::LoadBagDataset({Path("a.bag"), Path("b.bag")}, spec_opt, &sr);
  ASSERT_EQ(native.size(), 3 * 30 + 2 * 17);
  ASSERT_EQ(via_spec.size(), native.size());
  EXPECT_EQ(via_spec.trajectory_starts(), native.trajectory_starts());
  EXPECT_EQ(via_spec.trajectory_ends(), native.trajectory_ends());
  ASSERT_EQ(via_spec.obs_dim(), 2);
  ASSERT_EQ(via_spec.action_dim(), 2);
  for (size_t i = 0; i < native.states().size(); ++i)
    ASSERT_NEAR(via_spec.states()[i], native.states()[i], 1e-5) << i;
  for (size_t i = 0; i < native.actions().size(); ++i)
    ASSERT_NEAR(via_spec.actions()[i], native.actions()[i], 1e-5) << i;
  EXPECT_EQ(sr.incomplete_episodes, 0u) << sr.Summary();
}

TEST_F(SpecDatasetTest, TrainWithRobotStoresTheSpecAndBagInfoReports) {
  test::SynthBagOptions o;
  o.native = false;  // standard topics only, as a robot records them
  o.odom_per_step = 2;
  test::WriteSynthBag(Path("a.bag"), test::MakeSynthEpisodes(4, 30, 31), o);
  test::WriteSynthBag(Path("b.bag"), test::MakeSynthEpisodes(4, 30, 32), o);
  const std::string config = Path("tiny.yaml");
  std::ofstream(config) << core::OptionsToYaml(core::testing_util::TinyOptions());
  const std::string out = Path("run");
  const Output t = RunTool(std::string(MSSPR_TRAIN_EXE) + " --data " + Path("a.bag") + " " +
                           Path("b.bag") + " --robot " + spec_path_ + " --config " + config +
                           " --steps 6 --batch 16 --eval-every 0 --threads 1 --quiet --out " + out);
  ASSERT_EQ(t.status, 0) << t.text;
  EXPECT_NE(t.text.find("2 bag(s): 8 episodes read -> 8 trajectories, 240 steps"),
            std::string::npos)
      << t.text;
  const ros_bridge::RobotSpec spec = ros_bridge::LoadRobotSpec(spec_path_);
  for (const char* file : {"/policy.pt", "/checkpoint.ckpt"}) {
    const core::CheckpointFile f = core::ReadCheckpointFile(out + file);
    const core::CheckpointHeader h = core::ParseCheckpointHeader(f.header, out + file);
    ASSERT_TRUE(h.metadata.count(ros_bridge::kRobotSpecCheckpointKey)) << file;
    const std::string stored = h.metadata.at(ros_bridge::kRobotSpecCheckpointKey);
    EXPECT_EQ(stored, spec.text) << file;
    EXPECT_EQ(ros_bridge::CompareRobotSpecs(ros_bridge::ParseRobotSpec(stored, "stored"), spec),
              "");
  }

  // The policy node refuses to serve it through a spec that disagrees, naming the field.
  bool stored = false;
  EXPECT_EQ(ros_bridge::CheckCheckpointAgainstSpec(out + "/policy.pt", spec, 2, 2, &stored), "");
  EXPECT_TRUE(stored);
  std::string changed = spec.text;
  changed.replace(changed.find("scale: 2.0"), 10, "scale: 1.0");
  const ros_bridge::RobotSpec other_scale = ros_bridge::ParseRobotSpec(changed, "robot.yaml");
  const std::string refusal =
      ros_bridge::CheckCheckpointAgainstSpec(out + "/policy.pt", other_scale, 2, 2);
  EXPECT_NE(refusal.find("action field 0 'velocity' (topic cmd_vel, linear): scale [2] vs [1]"),
            std::string::npos)
      << refusal;
  EXPECT_NE(refusal.find("robot.yaml"), std::string::npos) << refusal;

  // msspr_bag_info --robot: per field, and a whole bag exits 0.
  Output info =
      RunTool(std::string(MSSPR_BAG_INFO_EXE) + " --robot " + spec_path_ + " " + Path("a.bag"));
  EXPECT_EQ(info.status, 0) << info.text;
  EXPECT_NE(info.text.find(
                "episodes:     4 (split by topic), 120 ticks, 120 with observation and action"),
            std::string::npos)
      << info.text;
  EXPECT_NE(info.text.find("position"), std::string::npos) << info.text;
  EXPECT_NE(info.text.find("100.0%"), std::string::npos) << info.text;

  // Stamps out of order and stale commands: reported, naming the topic and field; exit 1.
  o.swap_odom_stamps = true;
  o.drop_cmd_steps = {10, 11, 12, 13};
  test::WriteSynthBag(Path("bad.bag"), test::MakeSynthEpisodes(2, 30, 33), o);
  info =
      RunTool(std::string(MSSPR_BAG_INFO_EXE) + " --robot " + spec_path_ + " " + Path("bad.bag"));
  EXPECT_EQ(info.status, 1) << info.text;
  EXPECT_NE(
      info.text.find(
          "topic odom (field 'position'): 1 messages stamped before the one received before them"),
      std::string::npos)
      << info.text;
  EXPECT_NE(info.text.find("ticks without a fresh command"), std::string::npos) << info.text;
  EXPECT_NE(info.text.find(")) [" + spec_path_ + "]\n"), std::string::npos) << info.text;

  // A spec naming a topic the bag lacks: an error naming bag, topic and field; exit 2.
  std::string text = spec.text;
  text.replace(text.find("topic: odom"), 11, "topic: wheel_odom");
  const std::string other = test::WriteTextFile(Path("other.yaml"), text);
  info = RunTool(std::string(MSSPR_BAG_INFO_EXE) + " --robot " + other + " " + Path("a.bag"));
  EXPECT_EQ(info.status, 2) << info.text;
  EXPECT_NE(info.text.find(Path("a.bag") + ": the recording has no topic /msspr/wheel_odom (the "
                                           "spec's other topics are under /msspr"),
            std::string::npos)
      << info.text;
  EXPECT_NE(info.text.find("(field 'position' of " + other), std::string::npos) << info.text;
}

// A camera: bags with sensor_msgs/Image through config/robots/pointmaze_camera.yaml
// (its camera on the bag's standard camera topic) give the native image dataset
// of the same episodes; msspr_train --robot trains a pixels policy from them,
// which the policy node's check accepts; msspr_bag_info --robot reports the camera.
TEST_F(SpecDatasetTest, CameraBagsGiveTheNativeImageDatasetAndTrainPixels) {
  test::SynthBagOptions o;
  o.images = true;
  o.camera_format = "bgr8";  // 128x128 bgr8, resized to 64x64 rgb8
  test::WriteSynthBag(Path("a.bag"), test::MakeSynthEpisodes(3, 20, 51), o);
  test::WriteSynthBag(Path("b.bag"), test::MakeSynthEpisodes(2, 15, 52), o);
  std::string text =
      test::ReadTextFile(std::string(MSSPR_SOURCE_DIR) + "/config/robots/pointmaze_camera.yaml");
  text.replace(text.find("topic: camera/image"), 19, "topic: robot_camera");
  const std::string cam_spec = test::WriteTextFile(Path("camera.yaml"), text);
  const ros_bridge::RobotSpec spec = ros_bridge::LoadRobotSpec(cam_spec);
  agent::BagLoadOptions native_opt, spec_opt;
  native_opt.images = spec_opt.images = true;
  spec_opt.robot = &spec;
  agent::BagLoadReport nr, sr;
  const core::Dataset native =
      agent::LoadBagDataset({Path("a.bag"), Path("b.bag")}, native_opt, &nr);
  const core::Dataset via_spec =
      agent::LoadBagDataset({Path("a.bag"), Path("b.bag")}, spec_opt, &sr);
  ASSERT_EQ(native.size(), 3 * 20 + 2 * 15);
  ASSERT_EQ(via_spec.size(), native.size());
  ASSERT_TRUE(native.has_images());
  ASSERT_TRUE(via_spec.has_images());
  EXPECT_EQ(via_spec.image_shape().height, 64);
  EXPECT_EQ(via_spec.image_shape().width, 64);
  EXPECT_EQ(via_spec.image_shape().channels, 3);
  EXPECT_EQ(via_spec.trajectory_starts(), native.trajectory_starts());
  const size_t bytes = static_cast<size_t>(native.image_shape().numel());
  for (int64_t i = 0; i < native.size(); ++i)
    ASSERT_EQ(std::memcmp(via_spec.image(i), native.image(i), bytes), 0) << "image " << i;
  for (size_t i = 0; i < native.states().size(); ++i)
    ASSERT_NEAR(via_spec.states()[i], native.states()[i], 1e-5) << i;
  for (size_t i = 0; i < native.actions().size(); ++i)
    ASSERT_NEAR(via_spec.actions()[i], native.actions()[i], 1e-5) << i;
  EXPECT_EQ(sr.incomplete_episodes, 0u) << sr.Summary();

  core::MsprOptions opt = core::testing_util::TinyOptions();
  opt.network.obs_mode = "pixels";
  opt.network.cnn = "light";
  const std::string config = Path("tiny_pixels.yaml");
  std::ofstream(config) << core::OptionsToYaml(opt);
  const std::string out = Path("run");
  const Output t = RunTool(std::string(MSSPR_TRAIN_EXE) + " --data " + Path("a.bag") + " " +
                           Path("b.bag") + " --robot " + cam_spec + " --config " + config +
                           " --steps 2 --batch 8 --eval-every 0 --threads 1 --quiet --out " + out);
  ASSERT_EQ(t.status, 0) << t.text;
  EXPECT_NE(t.text.find("2 bag(s): 5 episodes read -> 5 trajectories, 90 steps"), std::string::npos)
      << t.text;
  const core::CheckpointFile f = core::ReadCheckpointFile(out + "/policy.pt");
  const core::CheckpointHeader h = core::ParseCheckpointHeader(f.header, out + "/policy.pt");
  ASSERT_TRUE(h.metadata.count(ros_bridge::kRobotSpecCheckpointKey));
  EXPECT_EQ(h.metadata.at(ros_bridge::kRobotSpecCheckpointKey), spec.text);
  bool stored = false;
  EXPECT_EQ(ros_bridge::CheckCheckpointAgainstSpec(out + "/policy.pt", spec, 2, 2, &stored), "");
  EXPECT_TRUE(stored);
  std::string other = text;
  other.replace(other.find("size: 64"), 8, "size: 32");
  const std::string refusal = ros_bridge::CheckCheckpointAgainstSpec(
      out + "/policy.pt", ros_bridge::ParseRobotSpec(other, "small.yaml"), 2, 2);
  EXPECT_NE(refusal.find("image 0 'camera' (topic robot_camera): size 64 vs 32"), std::string::npos)
      << refusal;
  // A state spec cannot train pixels.
  const Output bad =
      RunTool(std::string(MSSPR_TRAIN_EXE) + " --data " + Path("a.bag") + " --robot " + spec_path_ +
              " --config " + config +
              " --steps 2 --batch 8 --eval-every 0 --threads 1 --quiet --out " + Path("run2"));
  EXPECT_NE(bad.status, 0) << bad.text;
  EXPECT_NE(bad.text.find("names no camera (images:)"), std::string::npos) << bad.text;

  // msspr_bag_info --robot: the camera's row and its bad images, counted and not fatal.
  Output info =
      RunTool(std::string(MSSPR_BAG_INFO_EXE) + " --robot " + cam_spec + " " + Path("a.bag"));
  EXPECT_EQ(info.status, 0) << info.text;
  EXPECT_NE(info.text.find("60 ticks, 60 with observation, image and action"), std::string::npos)
      << info.text;
  EXPECT_NE(
      info.text.find(
          "image:        camera (topic robot_camera, sensor_msgs/Image -> 64x64 rgb8): 60 images"),
      std::string::npos)
      << info.text;
  o.bad_image_steps = {4, 30};
  test::WriteSynthBag(Path("bad.bag"), test::MakeSynthEpisodes(2, 20, 53), o);
  info = RunTool(std::string(MSSPR_BAG_INFO_EXE) + " --robot " + cam_spec + " " + Path("bad.bag"));
  EXPECT_EQ(info.status, 1) << info.text;
  EXPECT_NE(info.text.find("38 images at"), std::string::npos) << info.text;
  EXPECT_NE(info.text.find("2 bad images (undecodable, wrong encoding or size) rejected"),
            std::string::npos)
      << info.text;
  EXPECT_NE(info.text.find(
                "topic robot_camera (image 'camera'): 2 bad images rejected (first: image 'camera' "
                "(topic robot_camera, sensor_msgs/Image): encoding '32FC1'"),
            std::string::npos)
      << info.text;
}

// The arm: bags of the cube sim's standard messages (tf2, two command topics)
// check with msspr_bag_info --robot ur5e_cube.yaml and train with msspr_train --robot.
TEST_F(SpecDatasetTest, ArmBagsTrainThroughTheUr5eSpec) {
  const std::string arm_spec = std::string(MSSPR_SOURCE_DIR) + "/config/robots/ur5e_cube.yaml";
  ros_bridge::spec_bags::WriteCubeSpecBag(Path("a.bag"), 60, 3);
  ros_bridge::spec_bags::WriteCubeSpecBag(Path("b.bag"), 60, 4);
  Output info =
      RunTool(std::string(MSSPR_BAG_INFO_EXE) + " --robot " + arm_spec + " " + Path("a.bag"));
  std::printf("%s\n", info.text.c_str());
  EXPECT_EQ(info.status, 0) << info.text;
  for (const char* s : {"episodes:     1 (split by gap), 60 ticks, 60 with observation and action",
                        "pinch_position", "action:ee_twist", "action:gripper_command"})
    EXPECT_NE(info.text.find(s), std::string::npos) << s << "\n" << info.text;
  const std::string config = Path("tiny.yaml");
  std::ofstream(config) << core::OptionsToYaml(core::testing_util::TinyOptions());
  const std::string out = Path("run");
  const Output t = RunTool(std::string(MSSPR_TRAIN_EXE) + " --data " + Path("a.bag") + " " +
                           Path("b.bag") + " --robot " + arm_spec + " --config " + config +
                           " --steps 6 --batch 16 --eval-every 0 --threads 1 --quiet --out " + out);
  ASSERT_EQ(t.status, 0) << t.text;
  EXPECT_NE(t.text.find("2 bag(s): 2 episodes read -> 2 trajectories, 120 steps"),
            std::string::npos)
      << t.text;
  const ros_bridge::RobotSpec spec = ros_bridge::LoadRobotSpec(arm_spec);
  bool stored = false;
  EXPECT_EQ(ros_bridge::CheckCheckpointAgainstSpec(out + "/policy.pt", spec, 28, 5, &stored), "");
  EXPECT_TRUE(stored);
}

// Counts ticks whose action differs from the one the synthetic episodes sent for them
// (episodes split by goal_pose, in order; ticks without an action count as wrong).
int WrongActions(const std::vector<test::SynthEpisode>& eps, const std::string& spec_path,
                 const std::vector<std::string>& bags, int* ticks) {
  const ros_bridge::RobotSpec spec = ros_bridge::LoadRobotSpec(spec_path);
  ros_bridge::SpecBagReader reader(spec, bags);
  int wrong = 0;
  *ticks = 0;
  reader.ForEachEpisode([&](ros_bridge::BagEpisode&& ep) {
    const test::SynthEpisode& want = eps.at(ep.meta.episode_id);
    EXPECT_EQ(ep.num_steps, want.length);
    for (int t = 0; t < ep.num_steps; ++t) {
      ++*ticks;
      if (!ep.has_action[t] || std::fabs(ep.actions[2 * t] - want.actions[2 * t]) > 1e-6 ||
          std::fabs(ep.actions[2 * t + 1] - want.actions[2 * t + 1]) > 1e-6)
        ++wrong;
    }
  });
  return wrong;
}

// Commands without stamps (Twist) at 10 Hz, received 10 ms after their tick with
// +-20 ms jitter: each tick keeps its own command, in the reader and in the export.
TEST_F(SpecDatasetTest, UnstampedCommandsUnderLatencyAndJitterKeepTheirTicks) {
  const auto eps = test::MakeSynthEpisodes(25, 40, 61);
  for (double latency : {0.0, 0.01}) {
    test::SynthBagOptions o;
    o.cmd_latency = latency;
    o.cmd_jitter = 0.02;
    test::WriteSynthBag(Path("j.bag"), eps, o);
    int ticks = 0;
    const int wrong = WrongActions(eps, spec_path_, {Path("j.bag")}, &ticks);
    EXPECT_EQ(ticks, 1000);
    EXPECT_LE(wrong, ticks / 100) << "latency " << latency;
    std::printf("latency %.0f ms, jitter +-20 ms: %d of %d ticks with another command\n",
                1e3 * latency, wrong, ticks);
  }
  // msspr_bag_info times the commands and exports the per-tick dataset.
  const Output info = RunTool(std::string(MSSPR_BAG_INFO_EXE) + " --robot " + spec_path_ +
                              " --export " + Path("j.npz") + " " + Path("j.bag"));
  EXPECT_EQ(info.status, 0) << info.text;
  EXPECT_NE(info.text.find("1000 commands arrive +"), std::string::npos) << info.text;
  EXPECT_NE(info.text.find("0 ambiguous"), std::string::npos) << info.text;
  EXPECT_NE(info.text.find("export:       " + Path("j.npz") + ": 1000 steps, 25 trajectories"),
            std::string::npos)
      << info.text;
  core::NpyInfo ai, ti;
  const std::vector<float> actions = core::ReadNpzFloat(Path("j.npz"), "actions", &ai);
  const std::vector<float> terminals = core::ReadNpzFloat(Path("j.npz"), "terminals", &ti);
  ASSERT_EQ(ai.shape, (std::vector<int64_t>{1000, 2}));
  int wrong = 0, row = 0;
  for (const auto& ep : eps)
    for (int t = 0; t < ep.length; ++t, ++row)
      if (std::fabs(actions[2 * row] - ep.actions[2 * t]) > 1e-6 ||
          std::fabs(actions[2 * row + 1] - ep.actions[2 * t + 1]) > 1e-6)
        ++wrong;
  EXPECT_LE(wrong, 10) << "of 1000 exported ticks with another command";
  EXPECT_EQ(std::count(terminals.begin(), terminals.end(), 1.f), 25);
  EXPECT_EQ(
      core::ListNpzKeys(Path("j.npz")),
      (std::vector<std::string>{"observations", "actions", "terminals", "timestamps", "goals"}));
  // The goal in effect at each tick: its episode's goal_pose (x, y in observation units).
  core::NpyInfo gi;
  const std::vector<float> goals = core::ReadNpzFloat(Path("j.npz"), "goals", &gi);
  ASSERT_EQ(gi.shape, (std::vector<int64_t>{1000, 2}));
  row = 0;
  int wrong_goals = 0;
  for (const auto& ep : eps)
    for (int t = 0; t < ep.length; ++t, ++row)
      if (goals[2 * row] != ep.goal[0] || goals[2 * row + 1] != ep.goal[1]) ++wrong_goals;
  EXPECT_EQ(wrong_goals, 0) << "of 1000 exported ticks with another goal";
  // msspr_train trains on the export with the same steps as on the bag.
  const std::string config = Path("tiny.yaml");
  std::ofstream(config) << core::OptionsToYaml(core::testing_util::TinyOptions());
  const Output t =
      RunTool(std::string(MSSPR_TRAIN_EXE) + " --data " + Path("j.npz") + " --config " + config +
              " --steps 2 --batch 8 --eval-every 0 --threads 1 --quiet --out " + Path("run"));
  EXPECT_EQ(t.status, 0) << t.text;
  EXPECT_NE(t.text.find(Path("j.npz") + ": 1000 steps, 25 trajectories"), std::string::npos)
      << t.text;
}

// `rosbag record --split --repeat-latched`: one recording cut mid-episode into two files,
// the second opening with the goal again, reads as the same episodes and steps as one bag,
// in either order; and a bz2-compressed bag reads and trains.
TEST_F(SpecDatasetTest, ARecordingSplitOverBagsOrCompressedReadsAsOne) {
  const auto eps = test::MakeSynthEpisodes(4, 30, 71);
  test::WriteSynthBag(Path("whole.bag"), eps);
  // Episode 1 runs over ticks 31..60 (a reset tick before each episode): cut in its middle.
  test::SplitBag(Path("whole.bag"), {Path("part_0.bag"), Path("part_1.bag")},
                 {ros_bridge::TickToTime(45, 0.1)}, "/msspr/goal_pose");
  int ticks = 0;
  EXPECT_EQ(WrongActions(eps, spec_path_, {Path("part_0.bag"), Path("part_1.bag")}, &ticks), 0);
  EXPECT_EQ(ticks, 120);
  EXPECT_EQ(WrongActions(eps, spec_path_, {Path("part_1.bag"), Path("part_0.bag")}, &ticks), 0);
  EXPECT_EQ(ticks, 120);
  const std::string whole_line =
      "episodes:     4 (split by topic), 120 ticks, 120 with observation and action -> 4 "
      "trajectories, 120 steps";
  Output info = RunTool(std::string(MSSPR_BAG_INFO_EXE) + " --robot " + spec_path_ + " " +
                        Path("part_1.bag") + " " + Path("part_0.bag"));
  EXPECT_EQ(info.status, 0) << info.text;
  EXPECT_NE(info.text.find(whole_line), std::string::npos) << info.text;
  EXPECT_NE(info.text.find("2 bags read as one in time order; 1 repeated latched episode"),
            std::string::npos)
      << info.text;
  EXPECT_NE(info.text.find(Path("part_0.bag") + ": 44 ticks in episodes, 44 complete"),
            std::string::npos)
      << info.text;
  // The export of the two parts has the rows of the whole bag's export.
  for (const std::string& bags :
       {Path("whole.bag"), Path("part_0.bag") + " " + Path("part_1.bag")}) {
    info = RunTool(std::string(MSSPR_BAG_INFO_EXE) + " --robot " + spec_path_ + " --export " +
                   Path("x.npz") + " " + bags);
    EXPECT_EQ(info.status, 0) << info.text;
    core::NpyInfo oi;
    core::ReadNpzFloat(Path("x.npz"), "observations", &oi);
    EXPECT_EQ(oi.shape, (std::vector<int64_t>{120, 2})) << bags;
  }

  test::SplitBag(Path("whole.bag"), {Path("bz2.bag")}, {}, "", rosbag::compression::BZ2);
  info =
      RunTool(std::string(MSSPR_BAG_INFO_EXE) + " --robot " + spec_path_ + " " + Path("bz2.bag"));
  EXPECT_EQ(info.status, 0) << info.text;
  EXPECT_NE(info.text.find(whole_line), std::string::npos) << info.text;
  const std::string config = Path("tiny.yaml");
  std::ofstream(config) << core::OptionsToYaml(core::testing_util::TinyOptions());
  const Output t =
      RunTool(std::string(MSSPR_TRAIN_EXE) + " --data " + Path("bz2.bag") + " --robot " +
              spec_path_ + " --config " + config +
              " --steps 2 --batch 8 --eval-every 0 --threads 1 --quiet --out " + Path("run"));
  EXPECT_EQ(t.status, 0) << t.text;
  EXPECT_NE(t.text.find("4 episodes read -> 4 trajectories, 120 steps"), std::string::npos)
      << t.text;
}

// A robot under a namespace: the arm's topics recorded as /msspr/joint_states beside
// /msspr/gripper/joint_states read through config/robots/ur5e_cube.yaml, inferred or
// given with --ns, and train.
TEST_F(SpecDatasetTest, ANamespacedArmRecordingReadsAndTrainsThroughTheUr5eSpec) {
  const std::string arm_spec = std::string(MSSPR_SOURCE_DIR) + "/config/robots/ur5e_cube.yaml";
  ros_bridge::spec_bags::WriteCubeSpecBag(Path("ns.bag"), 60, 3, 20.0, "/msspr");
  for (const std::string ns : {"", " --ns /msspr", " --ns msspr"}) {
    const Output info = RunTool(std::string(MSSPR_BAG_INFO_EXE) + " --robot " + arm_spec + ns +
                                " " + Path("ns.bag"));
    EXPECT_EQ(info.status, 0) << ns << "\n" << info.text;
    EXPECT_NE(info.text.find("60 ticks, 60 with observation and action"), std::string::npos)
        << ns << "\n"
        << info.text;
  }
  const Output wrong = RunTool(std::string(MSSPR_BAG_INFO_EXE) + " --robot " + arm_spec +
                               " --ns /other " + Path("ns.bag"));
  EXPECT_EQ(wrong.status, 2) << wrong.text;
  EXPECT_NE(wrong.text.find("the recording has no topic /other/joint_states"), std::string::npos)
      << wrong.text;
  const std::string config = Path("tiny.yaml");
  std::ofstream(config) << core::OptionsToYaml(core::testing_util::TinyOptions());
  const Output t =
      RunTool(std::string(MSSPR_TRAIN_EXE) + " --data " + Path("ns.bag") + " --robot " + arm_spec +
              " --ns /msspr --config " + config +
              " --steps 2 --batch 8 --eval-every 0 --threads 1 --quiet --out " + Path("run"));
  ASSERT_EQ(t.status, 0) << t.text;
  EXPECT_NE(t.text.find("1 episodes read -> 1 trajectories, 60 steps"), std::string::npos)
      << t.text;
}

}  // namespace
}  // namespace msspr
