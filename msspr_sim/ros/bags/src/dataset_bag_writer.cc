// The writer of dataset bags (dataset_bag.h): episodes written through the
// rosbag C++ API into a temporary file that Close() renames into place.
#include <rosbag/bag.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "msspr/Action.h"
#include "msspr/EpisodeInfo.h"
#include "msspr/Observation.h"
#include "msspr_bags/dataset_bag.h"
#include "msspr_bridge/msg_conversion.h"

namespace msspr::ros_bridge {

DatasetBagWriter::DatasetBagWriter(const std::string& path, double control_dt, bool lz4)
    : path_(path),
      tmp_path_(path + ".tmp." + std::to_string(::getpid())),
      control_dt_(control_dt),
      bag_(std::make_unique<rosbag::Bag>()) {
  try {
    bag_->open(tmp_path_, rosbag::bagmode::Write);
  } catch (const rosbag::BagException& e) {
    throw BagError(path + ": cannot open " + tmp_path_ + " for writing: " + e.what());
  }
  if (lz4) bag_->setCompression(rosbag::compression::LZ4);
}

DatasetBagWriter::~DatasetBagWriter() {
  // Not closed: the writing failed or was abandoned; an existing bag at path_ stays.
  try {
    if (bag_ && bag_->isOpen()) bag_->close();
  } catch (...) {
  }
  if (!closed_) std::remove(tmp_path_.c_str());
}

void DatasetBagWriter::Close() {
  if (closed_) return;
  try {
    if (bag_ && bag_->isOpen()) bag_->close();
  } catch (const rosbag::BagException& e) {
    throw BagError(tmp_path_ + ": cannot finish writing: " + e.what());
  }
  if (std::rename(tmp_path_.c_str(), path_.c_str()) != 0)
    throw BagError(path_ + ": cannot rename " + tmp_path_ + " to it: " + std::strerror(errno));
  closed_ = true;
}

void DatasetBagWriter::WriteEpisode(const EpisodeMeta& meta, int length, int obs_dim, int act_dim,
                                    const float* observations, const float* actions,
                                    const uint8_t* images, int image_size, double success_radius,
                                    int success_dims) {
  if (closed_ || !bag_->isOpen()) throw BagError(path_ + ": writer already closed");
  ++tick_;  // the reset
  const ros::Time t0 = TickToTime(tick_, control_dt_);
  msspr::EpisodeInfo info;
  info.header.stamp = t0;
  info.episode_id = static_cast<uint32_t>(meta.episode_id);
  info.env = meta.env;
  info.split = meta.split;
  info.task_id = meta.task_id;
  info.seed = meta.seed;
  info.start = meta.start;
  info.goal = meta.goal;
  bag_->write(kEpisodeTopic, t0, info);
  ++messages_;

  msspr::Observation obs;
  obs.episode_id = info.episode_id;
  obs.goal = meta.goal;
  obs.header.frame_id = "world";
  msspr::Action act;
  act.episode_id = info.episode_id;
  const size_t image_bytes = static_cast<size_t>(image_size) * image_size * 3;
  for (int t = 0; t < length; ++t) {
    if (t > 0) ++tick_;
    const ros::Time stamp = TickToTime(tick_, control_dt_);
    obs.header.stamp = stamp;
    obs.step = static_cast<uint32_t>(t);
    obs.state.assign(observations + static_cast<size_t>(t) * obs_dim,
                     observations + static_cast<size_t>(t + 1) * obs_dim);
    double d2 = 0.0;
    const int dims = success_dims > 0 ? std::min(success_dims, obs_dim) : obs_dim;
    for (int k = 0; k < dims && k < static_cast<int>(meta.goal.size()); ++k) {
      const double d = static_cast<double>(obs.state[k]) - meta.goal[k];
      d2 += d * d;
    }
    obs.success = !meta.goal.empty() && std::sqrt(d2) <= success_radius;
    obs.last = (t == length - 1);
    bag_->write(kObservationTopic, stamp, obs);
    if (images != nullptr) {
      bag_->write(kImageTopic, stamp,
                  ToImageMsg(images + static_cast<size_t>(t) * image_bytes, image_size, stamp,
                             kCameraFrame));
      ++messages_;
    }
    act.header.stamp = stamp;
    act.step = obs.step;
    act.action.assign(actions + static_cast<size_t>(t) * act_dim,
                      actions + static_cast<size_t>(t + 1) * act_dim);
    bag_->write(kActionTopic, stamp, act);
    messages_ += 2;
  }
}

}  // namespace msspr::ros_bridge
