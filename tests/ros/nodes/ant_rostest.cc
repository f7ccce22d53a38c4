// msspr_sim_node ~env antmaze-medium (sim_ant.test): the ant served with the
// point maze's interface; robot_description, joint_states of the eight hinges
// and tf2 of the torso and legs agree with the observation; services check
// their input.
#include <gtest/gtest.h>
#include <ros/ros.h>
#include <sensor_msgs/JointState.h>
#include <tf2_eigen/tf2_eigen.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <cmath>
#include <string>
#include <vector>

#include "msspr/SetGoal.h"
#include "msspr_sim/ant_model.h"
#include "ros_test_helper.h"

namespace {

using msspr::testing::CallReset;
using msspr::testing::RosTestHelper;
using msspr::testing::WaitFor;

// A task reset gives 29-D observations and goals; actions step the ant; the
// joint states and tf2 describe the observed pose.
TEST(AntSim, ObservationJointStatesAndTf) {
  RosTestHelper h;
  sensor_msgs::JointState::ConstPtr joints;
  ros::Subscriber js_sub = h.nh().subscribe<sensor_msgs::JointState>(
      "joint_states", 100, [&](const sensor_msgs::JointState::ConstPtr& j) { joints = j; });
  tf2_ros::Buffer tf_buffer;
  tf2_ros::TransformListener tf_listener(tf_buffer);
  std::string urdf;
  ASSERT_TRUE(h.nh().getParam("robot_description", urdf));
  EXPECT_NE(urdf.find("msspr_ant"), std::string::npos);
  ASSERT_TRUE(h.WaitForSim());
  ros::WallDuration(1.0).sleep();  // the tf listener's own connection
  const auto res = CallReset(h.nh(), 1, 3);
  ASSERT_TRUE(res.ok) << res.message;
  ASSERT_EQ(res.observation.state.size(), 29u);
  ASSERT_EQ(res.goal.size(), 29u);
  // OGBench's task 1 of antmaze-medium starts near (0, 0), its goal near (28, 24)... within a
  // cell's noise.
  EXPECT_LT(std::hypot(res.observation.state[0], res.observation.state[1]), 1.5);
  ASSERT_TRUE(WaitFor([&] { return h.observations() >= 1; }, 10.0));
  // Step with a constant action: the step count advances and the hinges move.
  for (uint32_t step = 0; step < 10; ++step) {
    const auto before = h.observations();
    h.SendAction(h.latest()->episode_id, h.latest()->step,
                 {0.5f, -0.5f, 0.5f, -0.5f, 0.5f, -0.5f, 0.5f, -0.5f});
    ASSERT_TRUE(WaitFor([&] { return h.observations() > before; }, 10.0)) << "step " << step;
  }
  const auto obs = h.latest();
  EXPECT_EQ(obs->step, 10u);
  ASSERT_TRUE(WaitFor([&] { return joints && joints->header.stamp == obs->header.stamp; }, 10.0));
  ASSERT_EQ(joints->name.size(), 8u);
  for (size_t k = 0; k < 8; ++k) {
    EXPECT_EQ(joints->name[k], msspr::sim::kAntHingeJoints[k]);
    EXPECT_NEAR(joints->position[k], obs->state[7 + k], 1e-6) << joints->name[k];
    EXPECT_NEAR(joints->velocity[k], obs->state[15 + 6 + k], 1e-5) << joints->name[k];
  }
  const ros::Time stamp = obs->header.stamp;
  ASSERT_TRUE(tf_buffer.canTransform("world", "torso", stamp, ros::Duration(5.0)));
  const Eigen::Isometry3d torso =
      tf2::transformToEigen(tf_buffer.lookupTransform("world", "torso", stamp));
  EXPECT_NEAR(torso.translation().x(), obs->state[0], 1e-5);
  EXPECT_NEAR(torso.translation().y(), obs->state[1], 1e-5);
  EXPECT_NEAR(torso.translation().z(), obs->state[2], 1e-5);
  const Eigen::Quaterniond q(torso.rotation());
  EXPECT_NEAR(std::abs(q.w() * obs->state[3] + q.x() * obs->state[4] + q.y() * obs->state[5] +
                       q.z() * obs->state[6]),
              1.0, 1e-5);
  for (int n = 1; n <= 4; ++n) {
    for (const char* link : {"aux_", "foot_"}) {
      const std::string name = link + std::to_string(n);
      EXPECT_TRUE(tf_buffer.canTransform("world", name, stamp, ros::Duration(5.0))) << name;
    }
  }
}

TEST(AntSim, ServicesRejectBadInput) {
  RosTestHelper h;
  EXPECT_FALSE(CallReset(h.nh(), 6, 1).ok);
  const auto a = CallReset(h.nh(), 2, 11), b = CallReset(h.nh(), 2, 11);
  ASSERT_TRUE(a.ok && b.ok);
  EXPECT_EQ(a.observation.state, b.observation.state);  // seeded
  EXPECT_EQ(a.goal, b.goal);
  ros::ServiceClient set_goal = h.nh().serviceClient<msspr::SetGoal>("set_goal");
  ASSERT_TRUE(set_goal.waitForExistence(ros::Duration(10.0)));
  msspr::SetGoal bad;
  bad.request.goal = {1.0f, 2.0f};
  ASSERT_TRUE(set_goal.call(bad));
  EXPECT_FALSE(bad.response.ok);
  EXPECT_NE(bad.response.message.find("29"), std::string::npos) << bad.response.message;
  msspr::SetGoal good;
  good.request.goal = a.goal;
  good.request.goal[0] = 4.0f;
  good.request.goal[1] = 0.0f;
  ASSERT_TRUE(set_goal.call(good));
  EXPECT_TRUE(good.response.ok) << good.response.message;
}

}  // namespace

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "msspr_ant_rostest", ros::init_options::AnonymousName);
  ros::Time::init();
  return RUN_ALL_TESTS();
}
