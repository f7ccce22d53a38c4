// Reading node parameters into options structs, logging every value (as
// one Load...Options(ros::NodeHandle&) per node, as ros_controllers do).
#pragma once

#include <ros/console.h>
#include <ros/node_handle.h>

#include <string>

namespace msspr::ros_bridge {

// Returns ~name (or `def` when unset) and logs "  name: value" to `logger`.
template <typename T>
T LoggedParam(const ros::NodeHandle& pnh, const std::string& name, const T& def,
              const char* logger) {
  T v = def;
  pnh.param<T>(name, v, def);
  ROS_INFO_STREAM_NAMED(logger, "  " << name << ": " << v);
  return v;
}

}  // namespace msspr::ros_bridge
