// msspr_policy_node with ~robot SPEC.yaml: serves a policy over a
// robot's standard topics through its robot interface spec (robot_spec.h). It
// subscribes to the spec's observation and goal topics, assembles the
// observation as training did (robot_fields.h: SampleObservation), and
// publishes the spec's command type(s): in lockstep mode once per stamp of the
// first observation topic, when every observation topic has caught up with it
// (tf2 fields: the tf2 buffer), in rate mode at the spec's control rate (at
// ros::Time::now()). tf2 fields are looked up in a tf2_ros::Buffer. A watchdog sends a stop command
// (zero twist, zero array, or an empty trajectory: hold) at the control rate while inputs are
// stale, as diff_drive_controller's cmd_vel_timeout does, says so on /diagnostics, and serves again
// once they return. A pixels checkpoint is served through a spec with a camera (images:): the
// camera's images and the goal image are decoded and resized by robot_fields.h DecodeImage, as
// training did, and frame-stacked as the checkpoint says; a malformed image is
// rejected and counted (bad_images on /diagnostics), and a silent camera is
// stale like any input. This header does not include torch.
#pragma once

#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "msspr_core/frame_stack.h"
#include "msspr_robot_interface/robot_fields.h"
#include "msspr_robot_interface/robot_spec.h"
#include "policy_node.h"

namespace msspr::ros_bridge {

// "" when `checkpoint` may be served through `spec`; otherwise why not: the
// checkpoint stores another spec (naming the first field that differs), or its
// observation / action sizes are not the spec's. *stored_spec (optional) tells
// whether the checkpoint carries a spec (msspr_train --robot); one without a
// spec (trained on msspr's own topics) is served when the sizes agree.
// Throws std::runtime_error (core::CheckpointError) naming an unreadable file.
std::string CheckCheckpointAgainstSpec(const std::string& checkpoint, const RobotSpec& spec,
                                       int obs_dim, int action_dim, bool* stored_spec = nullptr);

class RobotServer {
 public:
  // Throws std::invalid_argument when the checkpoint disagrees with the spec.
  RobotServer(ros::NodeHandle nh, ros::NodeHandle pnh, const PolicyNodeOptions& options,
              RobotSpec spec, std::shared_ptr<core::Policy> policy);
  ~RobotServer();

  struct Counters {
    uint64_t messages = 0, rejected = 0, commands = 0, stops = 0, stale_events = 0,
             inference_errors = 0;
    uint64_t images = 0,
             bad_images = 0;  // the camera's and goal images; bad ones are also rejected
  };

 private:
  void CheckPolicyAgainstSpec();
  void Subscribe();
  void AdvertiseAndStartTimers();
  void LogServing() const;
  template <class M>
  void SubscribeObservation(int k);
  template <class M>
  void OnObservationMessage(int k, const M& msg);
  template <class M>
  void OnGoalMessage(const M& msg);
  template <class M>
  void OnImageMessage(const M& msg);
  template <class M>
  void OnGoalImage(const M& msg);
  void OnRateTick(const ros::WallTimerEvent&);
  void OnWatchdog(const ros::WallTimerEvent&);
  void OnDiagnostics(const ros::WallTimerEvent&);
  // Samples the observation at t and acts; a stale one sends a stop instead.
  void ActAt(const ros::Time& t);
  // The stamp of a command or stop: lockstep, the observation it answers (the
  // newest of the first topic); rate, ros::Time::now().
  ros::Time CommandStamp() const;
  // tf2 fields: a new sample from the buffer when it has newer transforms.
  void PollTf();
  // Lockstep: acts at the first topic's newest stamp once every topic has caught up.
  void TryActLockstep();
  void PublishCommand(const std::vector<double>& a, const ros::Time& stamp);
  void PublishStop(const std::string& why);

  PolicyNodeOptions options_;
  RobotSpec spec_;
  SpecLayout layout_;
  ros::NodeHandle nh_, pnh_;
  std::shared_ptr<core::Policy> policy_;
  std::vector<ros::Subscriber> subs_;
  ros::Subscriber goal_sub_;
  std::vector<RobotSpec::CommandTopic> cmd_topics_;
  std::vector<ros::Publisher> cmd_pubs_;  // one per command topic
  ros::Publisher diag_pub_;
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  int tf_topic_ = -1;  // layout topic of the tf2 fields, or -1
  uint64_t first_topic_messages_ =
      0;                         // lockstep: messages of the first topic (a re-sent one acts again)
  uint64_t acted_messages_ = 0;  // lockstep: the first topic's messages acted upon
  bool draining_ = false;        // lockstep: handling the callbacks already queued
  ros::WallTimer rate_timer_, watchdog_timer_, diag_timer_;
  std::vector<TopicHistory> histories_;
  std::vector<ros::WallTime> last_receipt_;  // per observation topic (wall clock)
  // Per observation topic: messages rejected since the last one accepted, and why the last was.
  std::vector<uint64_t> rejected_since_accepted_;
  std::vector<std::string> last_rejection_;
  std::vector<float> goal_;  // [obs_dim] (empty: none yet)
  bool stale_ = false;       // the watchdog is stopping the robot
  std::string stale_why_;
  ros::WallTime last_stop_;
  Counters counters_;
  // Pixels policies: the camera (spec_.images[0]), its recent images, the
  // episode's frame history and the goal image (stacked; empty: none yet).
  bool pixels_ = false;
  ros::Subscriber image_sub_;
  TopicHistory image_history_;
  ros::WallTime image_receipt_;
  std::optional<core::FrameStacker> frames_;
  ros::Time frame_stamp_;  // the stamp of the newest frame in frames_
  std::vector<uint8_t> goal_image_;
};

}  // namespace msspr::ros_bridge
