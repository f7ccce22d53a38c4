#include <ros/ros.h>

#include <exception>

#include "msspr_core/process_env.h"
#include "policy_node.h"
#include "robot_server.h"

int main(int argc, char** argv) {
  // As the tools: OpenMP threads that sleep while they wait, and OpenBLAS's
  // kernels for this CPU, so that a policy acts here exactly as it does in
  // msspr_eval_inprocess (process_env.h).
  msspr::core::ReexecWithToolEnvironment(argv);
  ros::init(argc, argv, "msspr_policy_node");
  ros::NodeHandle nh, pnh("~");
  try {
    const auto options = msspr::ros_bridge::LoadPolicyNodeOptions(pnh);
    if (!options.robot.empty()) {
      // Over the robot's standard topics, through its spec.
      auto spec = msspr::ros_bridge::LoadRobotSpec(options.robot);
      msspr::ros_bridge::RobotServer server(nh, pnh, options, std::move(spec),
                                            msspr::ros_bridge::LoadPolicyForNode(options));
      ros::spin();
      return 0;
    }
    msspr::ros_bridge::PolicyNode node(nh, pnh, options,
                                       msspr::ros_bridge::LoadPolicyForNode(options));
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM("msspr_policy_node: " << e.what());
    return 1;
  }
  return 0;
}
