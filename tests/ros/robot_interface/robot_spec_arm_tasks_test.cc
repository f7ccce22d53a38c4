// config/robots/ur5e_scene.yaml, ur5e_cube_double.yaml and ur5e_puzzle_3x3.yaml against their
// sims: a bag of the standard messages msspr_sim_node ~env scene / cube-double / puzzle-3x3
// publishes (built by the same functions: MakeArmStandardMessages, MakeSceneButtonStates,
// MakeSceneSlideStates, MakePuzzleButtonStates, FreeBodyPoseMsg), with the play oracle
// driving, read through the spec, gives the env's own observations (40 / 37 / 55 numbers)
// within 1e-5 and the actions sent. No master.
#include <gtest/gtest.h>
#include <rosbag/bag.h>
#include <std_msgs/Float64MultiArray.h>
#include <tf2_msgs/TFMessage.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "cube_spec_bag.h"
#include "msspr_robot_interface/robot_spec.h"
#include "msspr_robot_interface/spec_bag.h"
#include "msspr_sim/cube_double_oracle.h"
#include "msspr_sim/puzzle_oracle.h"
#include "msspr_sim/scene_oracle.h"
#include "msspr_sim_nodes/arm_messages.h"
#include "msspr_sim_nodes/arm_task_sim_node.h"

namespace msspr::ros_bridge {
namespace {

namespace fs = std::filesystem;

std::string Urdf() { return std::string(MSSPR_SOURCE_DIR) + "/msspr_sim/urdf/ur5e_2f85.urdf"; }

// Writes `steps` steps of `env` driven by `act` (the arm's messages, then write_objects'),
// reads the bag through the spec `spec_name` and checks every observation and action.
template <class Env>
void ExpectSpecReadsTheSim(
    Env& env, const std::string& spec_name, int steps,
    const std::function<typename Env::Action(Env&)>& act,
    const std::function<void(rosbag::Bag&, const Env&, const ros::Time&)>& write_objects) {
  ros::Time::init();
  const fs::path dir = fs::temp_directory_path() /
                       ("msspr_arm_spec_test_" + spec_name + "_" + std::to_string(getpid()));
  fs::create_directories(dir);
  const std::string bag_path = (dir / "arm.bag").string();
  std::vector<typename Env::Observation> native;
  std::vector<typename Env::Action> actions;
  {
    rosbag::Bag bag(bag_path, rosbag::bagmode::Write);
    const ros::Time t0(20.0);
    tf2_msgs::TFMessage statics;
    statics.transforms = MakeArmStaticTransforms(env.arm());
    bag.write("/tf_static", t0, statics);
    for (int k = 0; k < steps; ++k) {
      const ros::Time stamp = t0 + ros::Duration(0.05 * k);
      native.push_back(env.GetObservation());
      const ArmStandardMessages m = MakeArmStandardMessages(
          env.arm(), env.Qpos(), env.Qvel(), static_cast<double>(native.back()[18]),
          env.PinchPosition(), env.PinchRotation(), stamp, "world");
      tf2_msgs::TFMessage tf;
      tf.transforms = m.transforms;
      bag.write("/joint_states", stamp, m.joint_states);
      bag.write("/gripper/joint_states", stamp, m.gripper_state);
      bag.write("/tf", stamp, tf);
      write_objects(bag, env, stamp);
      typename Env::Action a = act(env);
      for (auto& v : a) v = std::clamp(v, -1.0, 1.0);
      actions.push_back(a);
      spec_bags::WriteArmCommands(bag, "", stamp, a);
      env.Step(a);
    }
  }
  const RobotSpec spec =
      LoadRobotSpec(std::string(MSSPR_SOURCE_DIR) + "/config/robots/" + spec_name + ".yaml");
  const int n = env.observation_size();
  ASSERT_EQ(spec.obs_dim(), n);
  ASSERT_EQ(spec.action_dim(), 5);
  SpecBagReader reader(spec, {bag_path});
  std::vector<BagEpisode> episodes;
  reader.ForEachEpisode([&](BagEpisode&& ep) { episodes.push_back(std::move(ep)); });
  for (const auto& p : reader.report().problems) ADD_FAILURE() << p;
  ASSERT_EQ(episodes.size(), 1u);
  const BagEpisode& ep = episodes[0];
  ASSERT_EQ(ep.num_steps, steps);
  for (int k = 0; k < steps; ++k) {
    ASSERT_TRUE(ep.has_obs[k]) << k;
    ASSERT_TRUE(ep.has_action[k]) << k;
    for (int i = 0; i < n; ++i)
      ASSERT_NEAR(ep.observations[static_cast<size_t>(k) * n + i], native[k][i], 1e-5)
          << spec_name << " step " << k << " observation[" << i << "]";
    for (int i = 0; i < 5; ++i)
      ASSERT_NEAR(ep.actions[static_cast<size_t>(k) * 5 + i], actions[k][i], 1e-6)
          << spec_name << " step " << k << " action[" << i << "]";
  }
  if (!::testing::Test::HasFailure()) fs::remove_all(dir);
}

// The scene's play data from a reset with button 0 in state 1 and button 1 in state 0, long
// enough for presses (the one-hot entries change) and slides to move.
TEST(RobotSpecArmTasks, SceneSpecObservationsEqualTheNative40D) {
  sim::SceneEnvOptions eo;
  eo.urdf_path = Urdf();
  sim::SceneEnv env(eo);
  env.ResetForCollection(4);
  sim::ScenePlayOracle oracle(4);
  std::vector<std::array<int, 2>> seen;
  ExpectSpecReadsTheSim<sim::SceneEnv>(
      env, "ur5e_scene", 400, [&](sim::SceneEnv& e) { return oracle.Act(e); },
      [&](rosbag::Bag& bag, const sim::SceneEnv& e, const ros::Time& stamp) {
        bag.write("/buttons/joint_states", stamp, MakeSceneButtonStates(e, stamp));
        bag.write("/slides/joint_states", stamp, MakeSceneSlideStates(e, stamp));
        bag.write("/cube_pose", stamp, FreeBodyPoseMsg(e.CubeQpos(), stamp, "world"));
        if (seen.empty() || seen.back() != e.button_states()) seen.push_back(e.button_states());
      });
  EXPECT_GE(seen.size(), 2u) << "no button changed state: the one-hot entries went untested";
}

TEST(RobotSpecArmTasks, CubeDoubleSpecObservationsEqualTheNative37D) {
  sim::CubeDoubleEnvOptions eo;
  eo.urdf_path = Urdf();
  sim::CubeDoubleEnv env(eo);
  env.ResetForCollection(6);
  sim::CubeDoublePlayOracle oracle(6);
  ExpectSpecReadsTheSim<sim::CubeDoubleEnv>(
      env, "ur5e_cube_double", 120, [&](sim::CubeDoubleEnv& e) { return oracle.Act(e); },
      [&](rosbag::Bag& bag, const sim::CubeDoubleEnv& e, const ros::Time& stamp) {
        const std::vector<double> q = e.Qpos();
        for (int i = 0; i < 2; ++i)
          bag.write("/cube_" + std::to_string(i) + "_pose", stamp,
                    FreeBodyPoseMsg(q.data() + 8 + 7 * i, stamp, "world"));
      });
}

TEST(RobotSpecArmTasks, Puzzle3x3SpecObservationsEqualTheNative55D) {
  sim::PuzzleEnvOptions eo;
  eo.urdf_path = Urdf();
  eo.side = 3;
  sim::PuzzleEnv env(eo);
  env.ResetForCollection(2);
  sim::PuzzlePlayOracle oracle(2);
  std::vector<sim::LightsOutState> seen;
  ExpectSpecReadsTheSim<sim::PuzzleEnv>(
      env, "ur5e_puzzle_3x3", 200, [&](sim::PuzzleEnv& e) { return oracle.Act(e); },
      [&](rosbag::Bag& bag, const sim::PuzzleEnv& e, const ros::Time& stamp) {
        bag.write("/buttons/joint_states", stamp, MakePuzzleButtonStates(e, stamp));
        if (seen.empty() || seen.back() != e.button_states()) seen.push_back(e.button_states());
      });
  EXPECT_GE(seen.size(), 2u) << "no button changed state: the one-hot entries went untested";
}

}  // namespace
}  // namespace msspr::ros_bridge
