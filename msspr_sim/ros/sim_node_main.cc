#include <ros/ros.h>

#include "cube_sim_node.h"
#include "sim_node.h"

// ~env picks the environment: pointmaze (default; ~maze picks the maze) or
// cube-single (the URDF arm, cube_sim_node.h). Both serve the same topics,
// messages and services.
int main(int argc, char** argv) {
  ros::init(argc, argv, "msspr_sim_node");
  ros::NodeHandle nh, pnh("~");
  try {
    std::string env = "pointmaze";
    pnh.param<std::string>("env", env, env);
    if (env == "cube-single") {
      const auto options = msspr::ros_bridge::LoadCubeSimNodeOptions(pnh);
      msspr::ros_bridge::CubeSimNode node(nh, pnh, options);
      ros::spin();
    } else if (env == "pointmaze") {
      const auto options = msspr::ros_bridge::LoadSimNodeOptions(pnh);
      msspr::ros_bridge::SimNode node(nh, pnh, options);
      ros::spin();
    } else {
      throw std::invalid_argument("~env must be pointmaze or cube-single, got '" + env + "'");
    }
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM("msspr_sim_node: " << e.what());
    return 1;
  }
  return 0;
}
