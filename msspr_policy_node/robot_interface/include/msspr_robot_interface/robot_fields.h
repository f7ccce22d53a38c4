// Reading a robot spec's fields out of standard ROS messages and writing its
// command messages (robot_spec.h), and sampling the latest values of several
// topics at a control tick. Shared by training from bags (spec_bag.h) and
// serving (msspr_policy_node ~robot), so that both assemble the observation
// the same way.
#pragma once

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <geometry_msgs/Twist.h>
#include <geometry_msgs/TwistStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/time.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/JointState.h>
#include <std_msgs/Float64MultiArray.h>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>
#include <trajectory_msgs/JointTrajectory.h>

#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "msspr_robot_interface/robot_spec.h"

namespace msspr::ros_bridge {

// Raw numbers of `f` in `msg` (after `derive`, before scale and offset), or
// false with `why` (a joint the message does not name, an array too short).
bool ReadRaw(const nav_msgs::Odometry& msg, const SpecField& f, std::vector<double>* out,
             std::string* why);
bool ReadRaw(const geometry_msgs::PoseStamped& msg, const SpecField& f, std::vector<double>* out,
             std::string* why);
bool ReadRaw(const geometry_msgs::Twist& msg, const SpecField& f, std::vector<double>* out,
             std::string* why);
bool ReadRaw(const geometry_msgs::TwistStamped& msg, const SpecField& f, std::vector<double>* out,
             std::string* why);
bool ReadRaw(const sensor_msgs::JointState& msg, const SpecField& f, std::vector<double>* out,
             std::string* why);
bool ReadRaw(const std_msgs::Float64MultiArray& msg, const SpecField& f, std::vector<double>* out,
             std::string* why);
bool ReadRaw(const trajectory_msgs::JointTrajectory& msg, const SpecField& f,
             std::vector<double>* out, std::string* why);
// A tf2 field: the transform's translation / rotation (tf2 lookupTransform(frames[0], frames[1])).
bool ReadRaw(const geometry_msgs::TransformStamped& msg, const SpecField& f,
             std::vector<double>* out, std::string* why);

// The header stamp of a message, or a zero time for the types without one.
ros::Time HeaderStamp(const nav_msgs::Odometry& m);
ros::Time HeaderStamp(const geometry_msgs::PoseStamped& m);
ros::Time HeaderStamp(const geometry_msgs::Twist& m);
ros::Time HeaderStamp(const geometry_msgs::TwistStamped& m);
ros::Time HeaderStamp(const sensor_msgs::JointState& m);
ros::Time HeaderStamp(const std_msgs::Float64MultiArray& m);
ros::Time HeaderStamp(const trajectory_msgs::JointTrajectory& m);
ros::Time HeaderStamp(const geometry_msgs::TransformStamped& m);

// Observation units: scale * (raw - offset), per value (then clipped, when the field has a clip).
void ScaleObservation(const SpecField& f, std::vector<double>* values);
// Training: the policy action of a command's raw numbers, (raw - offset) / scale clipped to f.clip.
void UnscaleAction(const SpecField& f, std::vector<double>* values);

// One decoded message of one topic: the fields of that topic that it feeds,
// back to back in spec order, in observation (or action) units.
struct TopicSample {
  ros::Time stamp;    // header or receipt, as the spec says
  ros::Time receipt;  // when it was received / recorded
  std::vector<double> values;
  std::vector<uint8_t> pixels;  // a camera's samples: [size, size, 3] rgb8 (DecodeImage)
};

// A camera image as the network takes it, for training (spec_bag.h) and
// serving alike; both overloads end in the same conversion. Image: encodings
// rgb8, bgr8 and mono8 (others are rejected); CompressedImage: jpeg or png,
// decoded with cv::imdecode (a jpeg without its end-of-image marker is
// rejected as truncated). The picture is converted to rgb8 and resized to
// size x size with cv::resize INTER_AREA (kept as is when it has that size).
// Fills rgb [size * size * 3] (row-major HWC) or returns false with why.
bool DecodeImage(const sensor_msgs::Image& msg, int size, std::vector<uint8_t>* rgb,
                 std::string* why);
bool DecodeImage(const sensor_msgs::CompressedImage& msg, int size, std::vector<uint8_t>* rgb,
                 std::string* why);
// A sample of camera `im` (stamped by its header); why names the spec's camera and topic.
template <class M>
bool DecodeImageSample(const SpecImage& im, const M& msg, const ros::Time& receipt,
                       TopicSample* out, std::string* why);

// The fields of a spec grouped by topic: which part of the observation each topic feeds.
struct SpecLayout {
  struct Topic {
    std::string name, type;
    bool use_receipt = false;       // stamp by receipt (no header)
    std::vector<int> fields;        // indices into spec.observation
    std::vector<int> field_offset;  // where each field's values start in TopicSample::values
    std::vector<int> obs_offset;    // where each field's values start in the observation
    int size = 0;                   // numbers per sample
  };
  std::vector<Topic> topics;  // observation topics, in order of first use
  explicit SpecLayout(const RobotSpec& spec);
};

// Decodes a message of an observation topic (layout topic `t`) into a sample.
// False with `why` naming the field when a field cannot be read; *nonfinite is
// set (and false returned) when a value is NaN or Inf.
template <class M>
bool DecodeObservation(const RobotSpec& spec, const SpecLayout::Topic& t, const M& msg,
                       const ros::Time& receipt, TopicSample* out, std::string* why,
                       bool* nonfinite);
// The tf2 fields of layout topic `t` (type tf2) from a tf2 buffer: each
// field's frames looked up at the latest time the buffer has for them; the
// sample is stamped with the oldest of those times. False with `why` when a
// lookup fails (frames not connected yet) or a value is NaN / Inf.
bool DecodeTf(const RobotSpec& spec, const SpecLayout::Topic& t, const tf2::BufferCore& buffer,
              const ros::Time& receipt, TopicSample* out, std::string* why, bool* nonfinite);

// Decodes a command message of `topic` ("": the action's own topic) into the
// policy's action units (UnscaleAction): the values of the fields on that topic.
template <class M>
bool DecodeAction(const RobotSpec& spec, const M& msg, const ros::Time& receipt, TopicSample* out,
                  std::string* why, bool* nonfinite, const std::string& topic = "");
// Decodes a goal message into a full goal observation [obs_dim] (pose source:
// the named observation fields, the rest 0; observation source: data as is).
bool DecodeGoal(const RobotSpec& spec, const geometry_msgs::PoseStamped& msg,
                std::vector<double>* goal, std::string* why);
bool DecodeGoal(const RobotSpec& spec, const std_msgs::Float64MultiArray& msg,
                std::vector<double>* goal, std::string* why);

// The command message of a policy action a [action_dim]: each field's values
// clipped, then offset + scale * a. Twist/TwistStamped: the named components,
// the rest 0; Float64MultiArray: data sized to the highest index; JointTrajectory:
// one point with the joints' positions or velocities, time_from_start one control period.
// Of the fields on command topic `topic` ("": the action's own topic).
geometry_msgs::Twist MakeTwist(const RobotSpec& spec, const std::vector<double>& a,
                               const std::string& topic = "");
std_msgs::Float64MultiArray MakeFloat64MultiArray(const RobotSpec& spec,
                                                  const std::vector<double>& a,
                                                  const std::string& topic = "");
trajectory_msgs::JointTrajectory MakeJointTrajectory(const RobotSpec& spec,
                                                     const std::vector<double>& a,
                                                     const std::string& topic = "");

// t - d, or time 0 when d is longer than t (ros::Time cannot be negative).
inline ros::Time Before(const ros::Time& t, const ros::Duration& d) {
  return t.toSec() > d.toSec() ? t - d : ros::Time(0, 0);
}

// Time-ordered samples of one topic, sampled at control ticks.
class TopicHistory {
 public:
  // Appends a sample; false (not added) when it is stamped before the newest one.
  bool Add(TopicSample s);
  // The newest sample stamped at or before `t`, or nullptr.
  const TopicSample* LatestAtOrBefore(const ros::Time& t) const;
  // The newest sample stamped strictly before `t`, or nullptr.
  const TopicSample* LatestBefore(const ros::Time& t) const;
  const std::deque<TopicSample>& samples() const { return samples_; }
  // Keeps at most n samples (serving).
  void Trim(size_t n) {
    while (samples_.size() > n) samples_.pop_front();
  }
  void Clear() { samples_.clear(); }

 private:
  std::deque<TopicSample> samples_;
};

// The observation at tick `t` from the histories of the layout's topics (index
// = layout topic): per topic the newest sample stamped at or before t +
// tolerance and not before `not_before`. Returns "" and fills obs [obs_dim], or
// names the first topic and field that is missing or stale (older than t - stale_after).
std::string SampleObservation(const RobotSpec& spec, const SpecLayout& layout,
                              const std::vector<TopicHistory>& histories, const ros::Time& t,
                              const ros::Time& not_before, std::vector<float>* obs,
                              std::vector<int>* stale_topics = nullptr);
// The image at tick `t` from a camera's history, with the rules of
// SampleObservation. Returns "" and sets *out, or why not (naming the camera).
std::string SampleImage(const RobotSpec& spec, const SpecImage& im, const TopicHistory& images,
                        const ros::Time& t, const ros::Time& not_before, const TopicSample** out);
// The action at tick t from the command history: the newest command stamped
// before t + period - tolerance, not older than t - stale_after nor before
// not_before. Returns "" and fills a [action_dim], or why not.
std::string SampleAction(const RobotSpec& spec, const TopicHistory& commands, const ros::Time& t,
                         const ros::Time& not_before, std::vector<float>* a);
// The newest command of `topic` in `commands` for tick t (as SampleAction), or why none.
std::string NewestCommand(const RobotSpec& spec, const std::string& topic,
                          const TopicHistory& commands, const ros::Time& t,
                          const ros::Time& not_before, const TopicSample** out);
// The same over every command topic (spec.CommandTopics(), one history each):
// the action [action_dim] from each topic's newest command, or why not.
std::string SampleCommands(const RobotSpec& spec,
                           const std::vector<RobotSpec::CommandTopic>& topics,
                           const std::vector<TopicHistory>& commands, const ros::Time& t,
                           const ros::Time& not_before, std::vector<float>* a);
// Writes one command topic's sample (decoded by DecodeAction) into the action `a`
// [action_dim] at the offsets of that topic's fields.
void PutCommand(const RobotSpec& spec, const RobotSpec::CommandTopic& topic, const TopicSample& s,
                std::vector<float>* a);

}  // namespace msspr::ros_bridge
