// A client of msspr_policy_node for rostests: it talks to the node as a sim
// would (observations and camera images out, actions in) and reads its
// diagnostics.
#pragma once

#include <gtest/gtest.h>
#include <sensor_msgs/Image.h>

#include <cmath>
#include <string>
#include <vector>

#include "msspr/Action.h"
#include "msspr/Observation.h"
#include "msspr_bridge/msg_conversion.h"
#include "ros_test_helper.h"

namespace msspr::testing {

constexpr char kPolicyStatus[] =
    "policy";  // the policy node's diagnostics status name contains this

// Talks to a policy node as a sim would: observations (and camera images) out,
// actions in; reads the node's diagnostics through RosTestHelper.
class PolicyClient {
 public:
  explicit PolicyClient(bool pixels = false) : pixels_(pixels) {
    ros::NodeHandle& nh = h_.nh();
    obs_pub_ = nh.advertise<msspr::Observation>("observation", 100);
    action_sub_ = nh.subscribe<msspr::Action>(
        "action", 100, [this](const msspr::Action::ConstPtr& a) { actions_.push_back(a); });
    if (pixels_) {
      image_pub_ = nh.advertise<sensor_msgs::Image>("camera/image", 100);
      goal_pub_ = nh.advertise<sensor_msgs::Image>("goal_image", 1, /*latch=*/true);
    }
  }

  // Waits until the node is connected both ways and has published diagnostics.
  bool WaitForPolicy(double timeout_s = 60.0) {
    const bool ok = h_.WaitFor(
        [&] {
          return obs_pub_.getNumSubscribers() > 0 && action_sub_.getNumPublishers() > 0 &&
                 (!pixels_ ||
                  (image_pub_.getNumSubscribers() > 0 && goal_pub_.getNumSubscribers() > 0)) &&
                 !h_.DiagValue(kPolicyStatus, "actions").empty();
        },
        timeout_s);
    ros::WallDuration(0.3).sleep();  // first messages on new connections can be lost
    return ok;
  }

  static ros::Time Stamp(uint32_t episode, uint32_t step) {
    return ros::Time(100.0 * episode + 0.1 * step + 1.0);
  }

  void SendObservation(uint32_t episode, uint32_t step, std::vector<float> state,
                       std::vector<float> goal) {
    msspr::Observation o;
    o.header.stamp = Stamp(episode, step);
    o.header.frame_id = "world";
    o.episode_id = episode;
    o.step = step;
    o.state = std::move(state);
    o.goal = std::move(goal);
    obs_pub_.publish(o);
  }

  // An image of size x size with `encoding` (rgb8: 3 bytes a pixel, else as given), constant
  // colour.
  static sensor_msgs::Image Image(int size, const std::string& encoding, uint8_t value,
                                  const ros::Time& stamp) {
    std::vector<uint8_t> rgb(static_cast<size_t>(size) * size * 3, value);
    sensor_msgs::Image img = ros_bridge::ToImageMsg(rgb.data(), size, stamp, "camera");
    img.encoding = encoding;
    return img;
  }
  void SendImage(const sensor_msgs::Image& img) { image_pub_.publish(img); }
  void SendGoalImage(const sensor_msgs::Image& img) { goal_pub_.publish(img); }

  // The action answering (episode, step), or null when none came within timeout_s.
  msspr::Action::ConstPtr WaitForAction(uint32_t episode, uint32_t step, double timeout_s) {
    msspr::Action::ConstPtr found;
    h_.WaitFor(
        [&] {
          for (const auto& a : actions_)
            if (a->episode_id == episode && a->step == step) found = a;
          return found != nullptr;
        },
        timeout_s);
    return found;
  }

  double Diag(const std::string& key) const { return h_.DiagNumber(kPolicyStatus, key); }
  // Waits until the diagnostics counter `key` reaches at least n.
  bool WaitForCounter(const std::string& key, double n, double timeout_s = 10.0) {
    return h_.WaitFor([&] { return Diag(key) >= n; }, timeout_s);
  }

  RosTestHelper& helper() { return h_; }
  size_t num_actions() const { return actions_.size(); }

 private:
  bool pixels_;
  RosTestHelper h_;
  ros::Publisher obs_pub_, image_pub_, goal_pub_;
  ros::Subscriber action_sub_;
  std::vector<msspr::Action::ConstPtr> actions_;
};

inline void ExpectValidAction(const msspr::Action& a) {
  ASSERT_EQ(a.action.size(), 2u);
  for (float v : a.action) {
    EXPECT_TRUE(std::isfinite(v));
    EXPECT_LE(std::abs(v), 1.0f + 1e-6f);
  }
}

}  // namespace msspr::testing
