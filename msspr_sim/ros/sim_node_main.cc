#include <ros/ros.h>

#include "sim_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "msspr_sim_node");
  ros::NodeHandle nh, pnh("~");
  try {
    const auto options = msspr::ros_bridge::LoadSimNodeOptions(pnh);
    msspr::ros_bridge::SimNode node(nh, pnh, options);
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM("msspr_sim_node: " << e.what());
    return 1;
  }
  return 0;
}
