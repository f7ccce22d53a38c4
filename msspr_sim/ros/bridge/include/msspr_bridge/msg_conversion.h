// Conversions between msspr messages and plain C++/Eigen types: the one place
// where ROS types meet the ROS-free libraries (msspr_core stays ROS-free).
#pragma once

#include <geometry_msgs/TransformStamped.h>
#include <ros/time.h>
#include <sensor_msgs/Image.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

#include "msspr/Action.h"
#include "msspr/Observation.h"

namespace msspr::ros_bridge {

// Copies an Eigen vector into a float32[] message field.
std::vector<float> ToFloatVector(const Eigen::VectorXd& v);
// Returns the vector held by a float32[] message field.
Eigen::VectorXd ToEigen(const std::vector<float>& v);

// A tf2 transform parent -> child holding `pose` (the child's pose in the parent's frame).
geometry_msgs::TransformStamped ToTf(const Eigen::Isometry3d& pose, const ros::Time& stamp,
                                     const std::string& parent, const std::string& child);

// True when every value is finite (no NaN, no Inf).
bool AllFinite(const std::vector<float>& v);

// Builds an rgb8 image message from an [size, size, 3] HWC buffer (row 0 = top).
sensor_msgs::Image ToImageMsg(const uint8_t* rgb, int size, const ros::Time& stamp,
                              const std::string& frame_id);

// Why an image is unusable as a [size, size, 3] rgb8 image, or "" if it is fine.
std::string CheckRgbImage(const sensor_msgs::Image& img, int size);

// Stamps of the simulation clock: tick k is k control periods after time 0.
// The sim node and the direct bag writer advance one tick per reset and per step,
// which is why a live recording and a written dataset carry the same stamps.
ros::Time TickToTime(uint64_t tick, double control_dt);

}  // namespace msspr::ros_bridge
