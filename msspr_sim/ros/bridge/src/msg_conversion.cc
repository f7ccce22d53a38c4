#include "msspr_bridge/msg_conversion.h"

#include <sensor_msgs/image_encodings.h>

#include <cmath>
#include <cstring>

namespace msspr::ros_bridge {

std::vector<float> ToFloatVector(const Eigen::VectorXd& v) {
  std::vector<float> out(static_cast<size_t>(v.size()));
  for (Eigen::Index i = 0; i < v.size(); ++i)
    out[static_cast<size_t>(i)] = static_cast<float>(v[i]);
  return out;
}

Eigen::VectorXd ToEigen(const std::vector<float>& v) {
  Eigen::VectorXd out(static_cast<Eigen::Index>(v.size()));
  for (size_t i = 0; i < v.size(); ++i) out[static_cast<Eigen::Index>(i)] = v[i];
  return out;
}

geometry_msgs::TransformStamped ToTf(const Eigen::Isometry3d& pose, const ros::Time& stamp,
                                     const std::string& parent, const std::string& child) {
  geometry_msgs::TransformStamped tf;
  tf.header.stamp = stamp;
  tf.header.frame_id = parent;
  tf.child_frame_id = child;
  tf.transform.translation.x = pose.translation().x();
  tf.transform.translation.y = pose.translation().y();
  tf.transform.translation.z = pose.translation().z();
  const Eigen::Quaterniond q(pose.rotation());
  tf.transform.rotation.w = q.w();
  tf.transform.rotation.x = q.x();
  tf.transform.rotation.y = q.y();
  tf.transform.rotation.z = q.z();
  return tf;
}

bool AllFinite(const std::vector<float>& v) {
  for (float x : v)
    if (!std::isfinite(x)) return false;
  return true;
}

sensor_msgs::Image ToImageMsg(const uint8_t* rgb, int size, const ros::Time& stamp,
                              const std::string& frame_id) {
  sensor_msgs::Image img;
  img.header.stamp = stamp;
  img.header.frame_id = frame_id;
  img.height = static_cast<uint32_t>(size);
  img.width = static_cast<uint32_t>(size);
  img.encoding = sensor_msgs::image_encodings::RGB8;
  img.is_bigendian = 0;
  img.step = static_cast<uint32_t>(size * 3);
  img.data.resize(static_cast<size_t>(size) * size * 3);
  std::memcpy(img.data.data(), rgb, img.data.size());
  return img;
}

std::string CheckRgbImage(const sensor_msgs::Image& img, int size) {
  if (img.encoding != sensor_msgs::image_encodings::RGB8)
    return "encoding '" + img.encoding + "', expected rgb8";
  if (static_cast<int>(img.width) != size || static_cast<int>(img.height) != size)
    return "size " + std::to_string(img.width) + "x" + std::to_string(img.height) + ", expected " +
           std::to_string(size) + "x" + std::to_string(size);
  if (uint64_t{img.step} != uint64_t{img.width} * 3 ||
      img.data.size() != uint64_t{img.step} * img.height)
    return "data of " + std::to_string(img.data.size()) + " bytes with step " +
           std::to_string(img.step) + " does not match " + std::to_string(size) + "x" +
           std::to_string(size) + "x3";
  return "";
}

ros::Time TickToTime(uint64_t tick, double control_dt) {
  return ros::Time(static_cast<double>(tick) * control_dt);
}

}  // namespace msspr::ros_bridge
