// Test helper: a bag of the standard messages msspr_sim_node ~env cube-single
// publishes (MakeCubeStandardMessages: joint_states, gripper/joint_states,
// cube_pose, /tf, /tf_static) and of the commands it takes (ee_twist,
// gripper_command), with the play oracle driving CubeEnv, as
// config/robots/ur5e_cube.yaml reads them. No master needed.
#pragma once

#include <rosbag/bag.h>
#include <tf2_msgs/TFMessage.h>

#include <algorithm>
#include <array>
#include <string>
#include <vector>

#include "msspr_sim/cube_env.h"
#include "msspr_sim/cube_oracle.h"
#include "msspr_sim_nodes/cube_sim_node.h"

namespace msspr::ros_bridge::spec_bags {

// An arm action's commands, as msspr_policy_node publishes them through the arm's specs:
// ee_twist and gripper_command under `ns`, 1 ms after `stamp`.
inline void WriteArmCommands(rosbag::Bag& bag, const std::string& ns, const ros::Time& stamp,
                             const std::array<double, 5>& a) {
  geometry_msgs::TwistStamped twist;
  twist.header.stamp = stamp;
  twist.twist.linear.x = a[0] * kEeSpeed;
  twist.twist.linear.y = a[1] * kEeSpeed;
  twist.twist.linear.z = a[2] * kEeSpeed;
  twist.twist.angular.z = a[3] * kEeYawRate;
  std_msgs::Float64MultiArray grip;
  grip.data = {a[4]};
  bag.write(ns + "/ee_twist", stamp + ros::Duration(0.001), twist);
  bag.write(ns + "/gripper_command", stamp + ros::Duration(0.001), grip);
}

struct CubeSpecBag {
  std::vector<sim::CubeEnv::Observation> observations;  // the env's own, per step
  std::vector<sim::CubeEnv::Action> actions;            // clipped to [-1, 1], per step
};

// Writes `steps` steps (0.05 s apart from t0) of a collection episode seeded `seed`; the
// topics under the namespace `ns` ("/msspr": /msspr/joint_states, ...; /tf stays global).
inline CubeSpecBag WriteCubeSpecBag(const std::string& path, int steps, uint64_t seed,
                                    double t0_s = 20.0, const std::string& ns = "") {
  CubeSpecBag out;
  sim::CubeEnvOptions eo;
  eo.urdf_path = std::string(MSSPR_SOURCE_DIR) + "/msspr_sim/urdf/ur5e_2f85.urdf";
  sim::CubeEnv env(eo);
  env.ResetForCollection(seed);
  sim::CubePlayOracle oracle(seed);
  rosbag::Bag bag(path, rosbag::bagmode::Write);
  const ros::Time t0(t0_s);
  tf2_msgs::TFMessage statics;
  statics.transforms = MakeCubeStaticTransforms(env);
  bag.write("/tf_static", t0, statics);
  for (int k = 0; k < steps; ++k) {
    const ros::Time stamp = t0 + ros::Duration(0.05 * k);
    out.observations.push_back(env.GetObservation());
    const CubeStandardMessages m =
        MakeCubeStandardMessages(env, stamp, "world", "cube", "cube_goal");
    tf2_msgs::TFMessage tf;
    tf.transforms = m.transforms;
    bag.write(ns + "/joint_states", stamp, m.joint_states);
    bag.write(ns + "/gripper/joint_states", stamp, m.gripper_state);
    bag.write(ns + "/cube_pose", stamp, m.cube_pose);
    bag.write("/tf", stamp, tf);
    sim::CubeEnv::Action a = oracle.Act(env);
    for (auto& v : a) v = std::clamp(v, -1.0, 1.0);
    out.actions.push_back(a);
    WriteArmCommands(bag, ns, stamp, a);
    env.Step(a);
  }
  return out;
}

}  // namespace msspr::ros_bridge::spec_bags
