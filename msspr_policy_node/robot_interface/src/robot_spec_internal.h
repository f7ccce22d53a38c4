// Internal to msspr_robot_interface: what the spec's reader (robot_spec_parse.cc) and
// the rest of the spec (robot_spec.cc) share.
#pragma once

#include <string>

#include "msspr_robot_interface/robot_spec.h"

namespace msspr::ros_bridge::spec_internal {

// "SPEC: observation field 'position' (topic odom, pose.pose.position): "
std::string Where(const std::string& source, const std::string& kind, const SpecField& f);

}  // namespace msspr::ros_bridge::spec_internal
