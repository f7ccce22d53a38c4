// Test helpers for robot interface specs: specs as inline YAML, and
// synthetic bags that hold the same episodes twice, as msspr's own topics
// (/msspr/episode, /msspr/observation, /msspr/action, as DatasetBagWriter
// writes them) and as a robot's standard messages (nav_msgs/Odometry on
// /msspr/odom, geometry_msgs/Twist on /msspr/cmd_vel, geometry_msgs/PoseStamped
// on /msspr/goal_pose), the way msspr_sim_node publishes both; optionally with
// camera images (SynthBagOptions::images).
#pragma once

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/Twist.h>
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <iterator>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <string>
#include <vector>

#include "msspr/Action.h"
#include "msspr/EpisodeInfo.h"
#include "msspr/Observation.h"
#include "msspr_bridge/msg_conversion.h"

namespace msspr::test {

inline std::string WriteTextFile(const std::string& path, const std::string& text) {
  std::ofstream(path) << text;
  return path;
}

inline std::string ReadTextFile(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// One synthetic point-maze episode: states [T, 2], actions [T, 2] in [-1, 1], a goal.
struct SynthEpisode {
  std::vector<float> states, actions;
  float goal[2] = {0, 0};
  int length = 0;
};

inline std::vector<SynthEpisode> MakeSynthEpisodes(int episodes, int length, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> u(-1.f, 1.f);
  std::vector<SynthEpisode> out;
  for (int e = 0; e < episodes; ++e) {
    SynthEpisode ep;
    ep.length = length;
    float x = 1.f + 3.f * (u(rng) + 1.f), y = 1.f + 3.f * (u(rng) + 1.f);
    ep.goal[0] = 10.f * u(rng);
    ep.goal[1] = 10.f * u(rng);
    for (int t = 0; t < length; ++t) {
      const float ax = u(rng), ay = u(rng);
      ep.states.push_back(x);
      ep.states.push_back(y);
      ep.actions.push_back(ax);
      ep.actions.push_back(ay);
      x += 0.2f * ax;
      y += 0.2f * ay;
    }
    out.push_back(std::move(ep));
  }
  return out;
}

struct SynthBagOptions {
  bool native = true;      // msspr's own topics
  bool standard = true;    // Odometry / Twist / PoseStamped
  int odom_per_step = 1;   // odometry messages per control step (stamped evenly)
  double drop_odom = 0.0;  // probability of dropping an odometry message (not at a step's stamp 0)
  std::vector<int> drop_cmd_steps;  // steps (counted over the whole bag) whose command is dropped
  bool swap_odom_stamps = false;    // write two odometry messages of episode 0 with swapped stamps
  double dt = 0.1;
  // Camera images (SynthImage): native 64x64 rgb8 on /msspr/camera/image (and
  // /msspr/goal_image at each episode's start), and the same pictures on the
  // standard camera topic /msspr/robot_camera (camera_format "rgb8", "bgr8"
  // or "mono8": sensor_msgs/Image; "png" or "jpeg": sensor_msgs/CompressedImage),
  // camera_scale times larger, each pixel repeated.
  bool images = false;
  std::string camera_format = "bgr8";
  int camera_scale = 2;
  std::vector<int> bad_image_steps;  // steps (over the whole bag) whose standard image is corrupt
  // The standard commands (geometry_msgs/Twist, no stamp) are received `cmd_latency` s
  // after their step's tick, plus a uniform jitter in [-cmd_jitter, cmd_jitter] (seeded).
  double cmd_latency = 0.0, cmd_jitter = 0.0;
  uint64_t jitter_seed = 5;
};

// The synthetic picture of episode e, step t: 64x64 rgb8, smooth (jpeg keeps it close).
inline std::vector<uint8_t> SynthImage(int e, int t, int side = 64) {
  std::vector<uint8_t> px(static_cast<size_t>(side) * side * 3);
  for (int y = 0; y < side; ++y)
    for (int x = 0; x < side; ++x)
      for (int c = 0; c < 3; ++c)
        px[(static_cast<size_t>(y) * side + x) * 3 + c] =
            static_cast<uint8_t>(20 + x + y + (5 * t + 40 * e + 70 * c) % 60);
  return px;
}

inline sensor_msgs::Image RgbImageMsg(const std::vector<uint8_t>& rgb, int side,
                                      const ros::Time& stamp) {
  sensor_msgs::Image m;
  m.header.stamp = stamp;
  m.header.frame_id = "msspr_camera";
  m.height = m.width = static_cast<uint32_t>(side);
  m.encoding = "rgb8";
  m.step = static_cast<uint32_t>(side * 3);
  m.data = rgb;
  return m;
}

// `rgb` (side x side) as the camera sends it: each pixel repeated scale x scale, in `format`.
inline void WriteCameraMsg(rosbag::Bag& bag, const std::string& topic,
                           const std::vector<uint8_t>& rgb, int side, int scale,
                           const std::string& format, const ros::Time& stamp, bool corrupt) {
  const int big = side * scale;
  cv::Mat bgr(big, big, CV_8UC3), gray(big, big, CV_8UC1);
  for (int y = 0; y < big; ++y)
    for (int x = 0; x < big; ++x) {
      const uint8_t* p = &rgb[(static_cast<size_t>(y / scale) * side + x / scale) * 3];
      bgr.at<cv::Vec3b>(y, x) = cv::Vec3b(p[2], p[1], p[0]);
      gray.at<uint8_t>(y, x) = p[1];
    }
  if (format == "png" || format == "jpeg") {
    sensor_msgs::CompressedImage m;
    m.header.stamp = stamp;
    m.format = format;
    cv::imencode(format == "png" ? ".png" : ".jpg", bgr, m.data, {cv::IMWRITE_JPEG_QUALITY, 95});
    if (corrupt) m.data.resize(m.data.size() / 2);  // truncated
    bag.write(topic, stamp, m);
    return;
  }
  sensor_msgs::Image m;
  m.header.stamp = stamp;
  m.header.frame_id = "camera";
  m.height = m.width = static_cast<uint32_t>(big);
  m.encoding = format;
  const cv::Mat& src = format == "mono8" ? gray : bgr;
  m.step = static_cast<uint32_t>(big * src.channels());
  m.data.assign(src.data, src.data + static_cast<size_t>(m.step) * big);
  if (format == "rgb8")
    for (size_t i = 0; i + 2 < m.data.size(); i += 3) std::swap(m.data[i], m.data[i + 2]);
  if (corrupt) m.encoding = "32FC1";  // a wrong encoding
  bag.write(topic, stamp, m);
}

// Writes `eps` back to back with the sim's clock: one tick for each reset,
// one per step (TickToTime), both kinds of topics at the same stamps.
inline void WriteSynthBag(const std::string& path, const std::vector<SynthEpisode>& eps,
                          const SynthBagOptions& o = {}) {
  rosbag::Bag bag(path, rosbag::bagmode::Write);
  std::mt19937_64 rng(7), jitter_rng(o.jitter_seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::uniform_real_distribution<double> jitter(-o.cmd_jitter, o.cmd_jitter);
  uint64_t tick = 0;
  int global_step = 0;
  for (size_t e = 0; e < eps.size(); ++e) {
    const SynthEpisode& ep = eps[e];
    ++tick;
    const ros::Time t0 = ros_bridge::TickToTime(tick, o.dt);
    if (o.native) {
      msspr::EpisodeInfo info;
      info.header.stamp = t0;
      info.episode_id = static_cast<uint32_t>(e);
      info.env = "pointmaze-medium";
      info.split = "train";
      info.start = {ep.states[0], ep.states[1]};
      info.goal = {ep.goal[0], ep.goal[1]};
      bag.write("/msspr/episode", t0, info);
    }
    if (o.standard) {
      geometry_msgs::PoseStamped g;
      g.header.stamp = t0;
      g.header.frame_id = "odom";
      g.pose.position.x = ep.goal[0];
      g.pose.position.y = ep.goal[1];
      g.pose.orientation.w = 1.0;
      bag.write("/msspr/goal_pose", t0, g);
    }
    if (o.images)
      bag.write("/msspr/goal_image", t0,
                RgbImageMsg(SynthImage(static_cast<int>(e), 1000), 64, t0));
    for (int t = 0; t < ep.length; ++t, ++global_step) {
      if (t > 0) ++tick;
      const ros::Time stamp = ros_bridge::TickToTime(tick, o.dt);
      const float x = ep.states[2 * t], y = ep.states[2 * t + 1];
      if (o.native) {
        msspr::Observation obs;
        obs.header.stamp = stamp;
        obs.episode_id = static_cast<uint32_t>(e);
        obs.step = static_cast<uint32_t>(t);
        obs.state = {x, y};
        obs.goal = {ep.goal[0], ep.goal[1]};
        obs.last = t == ep.length - 1;
        bag.write("/msspr/observation", stamp, obs);
        if (o.images)
          bag.write("/msspr/camera/image", stamp,
                    RgbImageMsg(SynthImage(static_cast<int>(e), t), 64, stamp));
        msspr::Action act;
        act.header.stamp = stamp;
        act.episode_id = obs.episode_id;
        act.step = obs.step;
        act.action = {ep.actions[2 * t], ep.actions[2 * t + 1]};
        bag.write("/msspr/action", stamp, act);
      }
      if (o.standard) {
        // Odometry at the step's stamp, then (odom_per_step > 1) in between at
        // the next position linearly interpolated.
        for (int k = 0; k < o.odom_per_step; ++k) {
          if (k > 0 && u(rng) < o.drop_odom) continue;
          const double frac = static_cast<double>(k) / o.odom_per_step;
          nav_msgs::Odometry od;
          od.header.stamp = stamp + ros::Duration(frac * o.dt);
          od.header.frame_id = "odom";
          od.child_frame_id = "base_link";
          od.pose.pose.position.x = x + frac * 0.2 * ep.actions[2 * t];
          od.pose.pose.position.y = y + frac * 0.2 * ep.actions[2 * t + 1];
          od.pose.pose.orientation.w = 1.0;
          if (k == 0) {
            od.pose.pose.position.x = x;
            od.pose.pose.position.y = y;
          }
          ros::Time rec = od.header.stamp;
          if (o.swap_odom_stamps && e == 0 && t == 3 && k == 0)
            od.header.stamp = stamp - ros::Duration(2 * o.dt);
          bag.write("/msspr/odom", rec, od);
        }
        if (o.images) {
          const bool bad = std::find(o.bad_image_steps.begin(), o.bad_image_steps.end(),
                                     global_step) != o.bad_image_steps.end();
          WriteCameraMsg(bag, "/msspr/robot_camera", SynthImage(static_cast<int>(e), t), 64,
                         o.camera_scale, o.camera_format, stamp, bad);
        }
        if (std::find(o.drop_cmd_steps.begin(), o.drop_cmd_steps.end(), global_step) ==
            o.drop_cmd_steps.end()) {
          geometry_msgs::Twist tw;
          tw.linear.x = 2.0 * ep.actions[2 * t];
          tw.linear.y = 2.0 * ep.actions[2 * t + 1];
          const double delay = o.cmd_latency + (o.cmd_jitter > 0 ? jitter(jitter_rng) : 0.0);
          bag.write("/msspr/cmd_vel", stamp + ros::Duration(delay), tw);
        }
      }
    }
  }
  bag.close();
}

// Copies `in` into `outs`, message by message in time order: the messages received
// before splits[i] (and at or after splits[i - 1]) into outs[i] (the last takes the
// rest), as `rosbag record --split` cuts a recording. repeat_latched: each file after
// the first opens with the last message so far on that topic, at the file's first
// time (as `--repeat-latched` does). compression: rosbag's, for every output.
inline void SplitBag(
    const std::string& in, const std::vector<std::string>& outs,
    const std::vector<ros::Time>& splits, const std::string& repeat_latched = "",
    rosbag::compression::CompressionType compression = rosbag::compression::Uncompressed) {
  rosbag::Bag src(in, rosbag::bagmode::Read);
  rosbag::View view(src);
  std::vector<std::unique_ptr<rosbag::Bag>> dst;
  for (const auto& o : outs) {
    dst.push_back(std::make_unique<rosbag::Bag>(o, rosbag::bagmode::Write));
    dst.back()->setCompression(compression);
  }
  size_t k = 0;
  std::unique_ptr<rosbag::MessageInstance> latched;
  for (const rosbag::MessageInstance& m : view) {
    while (k + 1 < outs.size() && k < splits.size() && m.getTime() >= splits[k]) {
      ++k;
      if (latched) dst[k]->write(latched->getTopic(), m.getTime(), *latched);
    }
    dst[k]->write(m.getTopic(), m.getTime(), m);
    if (!repeat_latched.empty() && m.getTopic() == repeat_latched)
      latched = std::make_unique<rosbag::MessageInstance>(m);
  }
  for (auto& d : dst) d->close();
}

}  // namespace msspr::test
