#include "robot_server.h"

#include <diagnostic_msgs/DiagnosticArray.h>
#include <ros/callback_queue.h>
#include <torch/torch.h>

#include <algorithm>
#include <cmath>
#include <sstream>

#include "msspr_core/checkpoint.h"
#include "msspr_core/policy.h"

namespace msspr::ros_bridge {

std::string CheckCheckpointAgainstSpec(const std::string& checkpoint, const RobotSpec& spec,
                                       int obs_dim, int action_dim, bool* stored_spec) {
  const core::CheckpointFile file = core::ReadCheckpointFile(checkpoint);
  const core::CheckpointHeader header = core::ParseCheckpointHeader(file.header, checkpoint);
  auto it = header.metadata.find(kRobotSpecCheckpointKey);
  if (stored_spec) *stored_spec = it != header.metadata.end();
  if (it != header.metadata.end()) {
    RobotSpec stored;
    try {
      stored = ParseRobotSpec(it->second, checkpoint + " (stored robot spec)");
    } catch (const RobotSpecError& e) {
      return checkpoint + ": its stored robot spec does not load: " + e.what();
    }
    const std::string diff = CompareRobotSpecs(stored, spec);
    if (!diff.empty())
      return checkpoint + " was trained through robot spec '" + stored.name +
             "', which differs from " + spec.source + ": " + diff;
  }
  if (spec.obs_dim() != obs_dim || spec.action_dim() != action_dim)
    return spec.source + " assembles observations of " + std::to_string(spec.obs_dim()) +
           " and actions of " + std::to_string(spec.action_dim()) + " numbers, " + checkpoint +
           " takes " + std::to_string(obs_dim) + " and gives " + std::to_string(action_dim);
  return "";
}

RobotServer::RobotServer(ros::NodeHandle nh, ros::NodeHandle pnh, const PolicyNodeOptions& options,
                         RobotSpec spec, std::shared_ptr<core::Policy> policy)
    : options_(options),
      spec_(std::move(spec)),
      layout_(spec_),
      nh_(nh),
      pnh_(pnh),
      policy_(std::move(policy)) {
  CheckPolicyAgainstSpec();
  Subscribe();
  AdvertiseAndStartTimers();
  LogServing();
}

// The checkpoint's observation mode, image size and sizes against the spec; throws
// std::invalid_argument naming both.
void RobotServer::CheckPolicyAgainstSpec() {
  pixels_ = policy_->pixels();
  const auto& net = policy_->options().network;
  if (pixels_ && spec_.images.empty())
    throw std::invalid_argument("~robot: " + options_.checkpoint + " holds a pixels policy, but " +
                                spec_.source + " names no camera (images:)");
  if (!pixels_ && !spec_.images.empty())
    throw std::invalid_argument("~robot: " + spec_.source + " names a camera (image '" +
                                spec_.images[0].name + "'), but " + options_.checkpoint +
                                " holds a state policy");
  if (pixels_) {
    const SpecImage& cam = spec_.images[0];
    if (net.image_height != cam.size || net.image_width != cam.size || net.image_channels != 3)
      throw std::invalid_argument(
          "~robot: " + spec_.source + ": image '" + cam.name + "' (topic " + cam.topic +
          ") gives " + std::to_string(cam.size) + "x" + std::to_string(cam.size) +
          " rgb8 images, " + options_.checkpoint + " takes " + std::to_string(net.image_height) +
          "x" + std::to_string(net.image_width) + "x" + std::to_string(net.image_channels));
    frames_.emplace(cam.size, cam.size, 3, std::max(1, net.frame_stack));
  }
  bool stored = false;
  // A pixels network reads no state: the spec's state fields are checked against the stored spec
  // only.
  const std::string bad = CheckCheckpointAgainstSpec(options_.checkpoint, spec_,
                                                     pixels_ ? spec_.obs_dim() : policy_->obs_dim(),
                                                     policy_->action_dim(), &stored);
  if (!bad.empty()) throw std::invalid_argument("~robot: " + bad);
  if (!stored)
    ROS_WARN_STREAM_NAMED(
        kPolicyLog, options_.checkpoint << " stores no robot spec (trained on msspr's own topics): "
                                        << "serving it through " << spec_.source
                                        << " on the sizes alone");
}

// The observation topics of the spec, its goal and, for a pixels policy, its camera.
void RobotServer::Subscribe() {
  histories_.resize(layout_.topics.size());
  last_receipt_.resize(layout_.topics.size());
  rejected_since_accepted_.assign(layout_.topics.size(), 0);
  last_rejection_.assign(layout_.topics.size(), "");
  for (size_t k = 0; k < layout_.topics.size(); ++k) {
    const std::string& type = layout_.topics[k].type;
    const int i = static_cast<int>(k);
    if (type == kTf2Type) {
      tf_topic_ = i;
      tf_buffer_ = std::make_unique<tf2_ros::Buffer>(ros::Duration(10.0));
      tf_listener_ =
          std::make_unique<tf2_ros::TransformListener>(*tf_buffer_, nh_, /*spin_thread=*/true);
    } else if (type == kOdometryType)
      SubscribeObservation<nav_msgs::Odometry>(i);
    else if (type == kPoseStampedType)
      SubscribeObservation<geometry_msgs::PoseStamped>(i);
    else if (type == kTwistType)
      SubscribeObservation<geometry_msgs::Twist>(i);
    else if (type == kTwistStampedType)
      SubscribeObservation<geometry_msgs::TwistStamped>(i);
    else if (type == kJointStateType)
      SubscribeObservation<sensor_msgs::JointState>(i);
    else if (type == kFloat64MultiArrayType)
      SubscribeObservation<std_msgs::Float64MultiArray>(i);
    else if (type == kJointTrajectoryType)
      SubscribeObservation<trajectory_msgs::JointTrajectory>(i);
  }
  if (spec_.goal.source == "pose")
    goal_sub_ = nh_.subscribe<geometry_msgs::PoseStamped>(
        spec_.goal.topic, 1,
        [this](const geometry_msgs::PoseStamped::ConstPtr& m) { OnGoalMessage(*m); });
  else if (spec_.goal.source == "observation")
    goal_sub_ = nh_.subscribe<std_msgs::Float64MultiArray>(
        spec_.goal.topic, 1,
        [this](const std_msgs::Float64MultiArray::ConstPtr& m) { OnGoalMessage(*m); });
  else if (spec_.goal.source == "image" && spec_.goal.type == kImageType)
    goal_sub_ = nh_.subscribe<sensor_msgs::Image>(
        spec_.goal.topic, 1, [this](const sensor_msgs::Image::ConstPtr& m) { OnGoalImage(*m); });
  else if (spec_.goal.source == "image")
    goal_sub_ = nh_.subscribe<sensor_msgs::CompressedImage>(
        spec_.goal.topic, 1,
        [this](const sensor_msgs::CompressedImage::ConstPtr& m) { OnGoalImage(*m); });
  if (pixels_) {
    const SpecImage& cam = spec_.images[0];
    const uint32_t queue = options_.stepping == Stepping::kLockstep ? 10 : 1;
    if (cam.type == kImageType)
      image_sub_ = nh_.subscribe<sensor_msgs::Image>(
          cam.topic, queue, [this](const sensor_msgs::Image::ConstPtr& m) { OnImageMessage(*m); },
          ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
    else
      image_sub_ = nh_.subscribe<sensor_msgs::CompressedImage>(
          cam.topic, queue,
          [this](const sensor_msgs::CompressedImage::ConstPtr& m) { OnImageMessage(*m); },
          ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  }
}

// The command topics, /diagnostics, the control-rate timer (real time), the watchdog.
void RobotServer::AdvertiseAndStartTimers() {
  cmd_topics_ = spec_.CommandTopics();
  for (const auto& c : cmd_topics_) {
    if (c.type == kTwistType)
      cmd_pubs_.push_back(nh_.advertise<geometry_msgs::Twist>(c.topic, 10));
    else if (c.type == kTwistStampedType)
      cmd_pubs_.push_back(nh_.advertise<geometry_msgs::TwistStamped>(c.topic, 10));
    else if (c.type == kFloat64MultiArrayType)
      cmd_pubs_.push_back(nh_.advertise<std_msgs::Float64MultiArray>(c.topic, 10));
    else
      cmd_pubs_.push_back(nh_.advertise<trajectory_msgs::JointTrajectory>(c.topic, 10));
  }
  diag_pub_ = nh_.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 10);
  const ros::WallDuration period(1.0 / spec_.control_rate);
  if (options_.stepping == Stepping::kRealtime)
    rate_timer_ = nh_.createWallTimer(period, &RobotServer::OnRateTick, this);
  watchdog_timer_ = nh_.createWallTimer(ros::WallDuration(std::min(0.05, spec_.stale_after / 4)),
                                        &RobotServer::OnWatchdog, this);
  diag_timer_ = nh_.createWallTimer(ros::WallDuration(options_.diagnostics_period),
                                    &RobotServer::OnDiagnostics, this);
}

void RobotServer::LogServing() const {
  std::ostringstream s;
  for (const auto& t : layout_.topics) s << " " << t.name << " (" << t.type << ")";
  if (pixels_)
    s << " and camera " << spec_.images[0].topic << " (" << spec_.images[0].type << " -> "
      << spec_.images[0].size << "x" << spec_.images[0].size << " rgb8, frame_stack "
      << frames_->stack() << ")";
  std::string commands;
  for (const auto& c : cmd_topics_)
    commands += (commands.empty() ? "" : ", ") + c.type + " on " + c.topic;
  ROS_INFO_STREAM_NAMED(kPolicyLog, "msspr_policy_node serving "
                                        << options_.checkpoint << " through robot spec '"
                                        << spec_.name << "' (" << spec_.source << ", "
                                        << SteppingName(options_.stepping) << "): observation from"
                                        << s.str() << ", goal from " << spec_.goal.topic << ", "
                                        << commands << " at " << spec_.control_rate << " Hz");
}

RobotServer::~RobotServer() = default;

template <class M>
void RobotServer::SubscribeObservation(int k) {
  const bool lockstep = options_.stepping == Stepping::kLockstep;
  subs_.push_back(nh_.subscribe<M>(
      layout_.topics[k].name, lockstep ? 10 : 1,
      [this, k](const boost::shared_ptr<const M>& m) { OnObservationMessage(k, *m); },
      ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay()));
}

template <class M>
void RobotServer::OnObservationMessage(int k, const M& msg) {
  ++counters_.messages;
  TopicSample s;
  std::string why;
  bool nonfinite = false;
  if (!DecodeObservation(spec_, layout_.topics[k], msg, ros::Time::now(), &s, &why, &nonfinite)) {
    ++counters_.rejected;
    ++rejected_since_accepted_[k];
    last_rejection_[k] = why;
    ROS_ERROR_STREAM_THROTTLE_NAMED(1.0, kPolicyLog, spec_.source << ": rejected message: " << why);
    return;
  }
  rejected_since_accepted_[k] = 0;
  TopicHistory& h = histories_[k];
  if (!h.samples().empty() && s.stamp < h.samples().back().stamp) {
    // Stamps going back: a restarted driver or a new episode's clock. Start over.
    h.Clear();
  }
  const ros::Time stamp = s.stamp;
  h.Add(std::move(s));
  h.Trim(64);
  last_receipt_[k] = ros::WallTime::now();
  (void)stamp;
  if (k == 0) ++first_topic_messages_;
  if (options_.stepping == Stepping::kLockstep) TryActLockstep();
}

template <class M>
void RobotServer::OnImageMessage(const M& msg) {
  ++counters_.messages;
  ++counters_.images;
  TopicSample s;
  std::string why;
  if (!DecodeImageSample(spec_.images[0], msg, ros::Time::now(), &s, &why)) {
    ++counters_.rejected;
    ++counters_.bad_images;
    ROS_ERROR_STREAM_THROTTLE_NAMED(1.0, kPolicyLog, spec_.source << ": rejected image: " << why);
    return;
  }
  if (!image_history_.samples().empty() && s.stamp < image_history_.samples().back().stamp)
    image_history_.Clear();  // stamps going back: start over, as for the other topics
  image_history_.Add(std::move(s));
  image_history_.Trim(16);
  image_receipt_ = ros::WallTime::now();
  if (options_.stepping == Stepping::kLockstep) TryActLockstep();
}

template <class M>
void RobotServer::OnGoalImage(const M& msg) {
  ++counters_.images;
  std::vector<uint8_t> rgb;
  std::string why;
  if (!DecodeImage(msg, spec_.images[0].size, &rgb, &why)) {
    ++counters_.rejected;
    ++counters_.bad_images;
    ROS_ERROR_STREAM_THROTTLE_NAMED(
        1.0, kPolicyLog,
        spec_.source << ": rejected goal image (topic " << spec_.goal.topic << "): " << why);
    return;
  }
  // A goal is one image, repeated frame_stack times; a new goal starts a new frame history.
  goal_image_ = frames_->Repeat(rgb.data());
  frames_->Clear();
}

void RobotServer::PollTf() {
  if (tf_topic_ < 0) return;
  TopicSample s;
  std::string why;
  bool nonfinite = false;
  if (!DecodeTf(spec_, layout_.topics[tf_topic_], *tf_buffer_, ros::Time::now(), &s, &why,
                &nonfinite)) {
    if (nonfinite) {
      ++counters_.rejected;
      ROS_ERROR_STREAM_THROTTLE_NAMED(1.0, kPolicyLog,
                                      spec_.source << ": rejected transform: " << why);
    }
    return;
  }
  TopicHistory& h = histories_[tf_topic_];
  if (!h.samples().empty() && s.stamp <= h.samples().back().stamp) {
    if (s.stamp < h.samples().back().stamp)
      h.Clear();  // time went back
    else
      return;
  }
  ++counters_.messages;
  h.Add(std::move(s));
  h.Trim(64);
  last_receipt_[tf_topic_] = ros::WallTime::now();
}

void RobotServer::TryActLockstep() {
  if (draining_) return;  // the outer call acts once the queue is drained
  // Messages that have already arrived go first: a new episode's goal (an
  // unstamped Float64MultiArray cannot be waited for by stamp) is published
  // before its first observation, on another connection.
  draining_ = true;
  ros::getGlobalCallbackQueue()->callAvailable();
  draining_ = false;
  if (histories_[0].samples().empty()) return;
  if (acted_messages_ >= first_topic_messages_)
    return;  // acted on the first topic's newest message
  const ros::Time t = histories_[0].samples().back().stamp;
  const ros::Time ready = Before(t, ros::Duration(spec_.tolerance));
  auto caught_up = [&](size_t k) {
    return !histories_[k].samples().empty() && histories_[k].samples().back().stamp >= ready;
  };
  for (size_t k = 1; k < layout_.topics.size(); ++k) {
    if (static_cast<int>(k) == tf_topic_) {
      // The listener fills the buffer on its own thread: wait for it briefly.
      const ros::WallTime until =
          ros::WallTime::now() + ros::WallDuration(std::min(0.2, spec_.stale_after));
      PollTf();
      while (!caught_up(k) && ros::WallTime::now() < until && ros::ok()) {
        ros::WallDuration(0.0005).sleep();
        PollTf();
      }
    }
    if (!caught_up(k)) return;  // its message for t comes later and calls again
  }
  if (pixels_ &&
      (image_history_.samples().empty() || image_history_.samples().back().stamp < ready))
    return;  // the camera's image for t comes later and calls again
  acted_messages_ = first_topic_messages_;
  ActAt(t);
}

template <class M>
void RobotServer::OnGoalMessage(const M& msg) {
  std::vector<double> g;
  std::string why;
  if (!DecodeGoal(spec_, msg, &g, &why)) {
    ++counters_.rejected;
    ROS_ERROR_STREAM_THROTTLE_NAMED(1.0, kPolicyLog, spec_.source << ": rejected goal: " << why);
    return;
  }
  goal_.assign(g.begin(), g.end());
}

void RobotServer::OnRateTick(const ros::WallTimerEvent&) {
  PollTf();
  ActAt(ros::Time::now());
}

void RobotServer::OnWatchdog(const ros::WallTimerEvent&) {
  // Inputs are stale when any observation topic has been silent longer than
  // stale_after (wall time), or there is no goal yet.
  PollTf();
  const ros::WallTime now = ros::WallTime::now();
  std::string why;
  for (size_t k = 0; k < layout_.topics.size() && why.empty(); ++k) {
    const SpecField& f = spec_.observation[layout_.topics[k].fields[0]];
    const std::string who = "topic " + layout_.topics[k].name + " (field '" + f.name + "'): ";
    // Messages that arrive and are rejected are the cause, not silence.
    const std::string rejected = rejected_since_accepted_[k] == 0
                                     ? std::string()
                                     : std::to_string(rejected_since_accepted_[k]) +
                                           " message(s) received and rejected" +
                                           " (last: " + last_rejection_[k] + ")";
    if (histories_[k].samples().empty())
      why = who + (rejected.empty() ? "no message yet" : "no usable message: " + rejected);
    else if ((now - last_receipt_[k]).toSec() > spec_.stale_after)
      why = who + "no usable message for " + std::to_string((now - last_receipt_[k]).toSec()) +
            " s (stale_after " + std::to_string(spec_.stale_after) + " s)" +
            (rejected.empty() ? ": silent" : ": " + rejected);
  }
  if (why.empty() && pixels_) {
    const SpecImage& cam = spec_.images[0];
    if (image_history_.samples().empty())
      why = "topic " + cam.topic + " (image '" + cam.name + "'): no image yet";
    else if ((now - image_receipt_).toSec() > spec_.stale_after)
      why = "topic " + cam.topic + " (image '" + cam.name + "'): silent for " +
            std::to_string((now - image_receipt_).toSec()) + " s (stale_after " +
            std::to_string(spec_.stale_after) + " s)";
  }
  const bool no_goal = pixels_ ? goal_image_.empty() : goal_.empty();
  if (why.empty() && no_goal && !spec_.goal.topic.empty())
    why = "no goal yet on " + spec_.goal.topic;
  if (!why.empty()) {
    // Rate mode: a stop every control period while stale. Lockstep: one stop when
    // inputs go stale (every command steps a lockstep simulator once).
    if (options_.stepping == Stepping::kRealtime
            ? (now - last_stop_).toSec() >= 1.0 / spec_.control_rate
            : !stale_)
      PublishStop(why);
  } else if (stale_ && options_.stepping == Stepping::kLockstep) {
    stale_ = false;  // inputs are back; the next message acts
    ROS_INFO_STREAM_NAMED(kPolicyLog, "inputs fresh again: serving");
  }
}

void RobotServer::ActAt(const ros::Time& t) {
  std::vector<float> obs;
  const std::string why = SampleObservation(spec_, layout_, histories_, t, ros::Time(0, 0), &obs);
  if (!why.empty()) {
    PublishStop(why);
    return;
  }
  std::vector<uint8_t> stacked;
  if (pixels_) {
    const TopicSample* img = nullptr;
    const std::string iwhy =
        SampleImage(spec_, spec_.images[0], image_history_, t, ros::Time(0, 0), &img);
    if (!iwhy.empty()) {
      PublishStop(iwhy);
      return;
    }
    if (goal_image_.empty()) {
      PublishStop("no goal image yet on " + spec_.goal.topic);
      return;
    }
    // The episode's frames: a new image is pushed, the same one again replaces
    // it, and an older one (time went back) or a fresh start repeats it.
    if (frames_->empty() || img->stamp < frame_stamp_)
      frames_->Reset(img->pixels.data());
    else if (img->stamp == frame_stamp_)
      frames_->Replace(img->pixels.data());
    else
      frames_->Push(img->pixels.data());
    frame_stamp_ = img->stamp;
    stacked = frames_->Stacked();
  } else if (goal_.empty()) {
    PublishStop("no goal yet on " + spec_.goal.topic);
    return;
  }
  if (stale_) {
    stale_ = false;
    ROS_INFO_STREAM_NAMED(kPolicyLog, "inputs fresh again: serving");
  }
  torch::Tensor a;
  try {
    torch::NoGradGuard no_grad;
    if (pixels_) {
      const int64_t side = spec_.images[0].size;
      const std::vector<int64_t> shape = {side, side, static_cast<int64_t>(3 * frames_->stack())};
      a = policy_->Act(torch::from_blob(stacked.data(), shape, torch::kUInt8),
                       torch::from_blob(goal_image_.data(), shape, torch::kUInt8));
    } else {
      a = policy_->Act(
          torch::from_blob(obs.data(), {static_cast<int64_t>(obs.size())}, torch::kFloat32),
          torch::from_blob(goal_.data(), {static_cast<int64_t>(goal_.size())}, torch::kFloat32));
    }
    a = a.to(torch::kCPU).contiguous();
  } catch (const c10::Error& e) {
    ++counters_.inference_errors;
    ROS_ERROR_STREAM_THROTTLE_NAMED(1.0, kPolicyLog,
                                    "inference failed: " << e.what_without_backtrace());
    return;
  }
  std::vector<double> av(a.data_ptr<float>(), a.data_ptr<float>() + a.numel());
  for (double v : av)
    if (!std::isfinite(v)) {
      ++counters_.inference_errors;
      PublishStop("the policy returned NaN / Inf");
      return;
    }
  PublishCommand(av, options_.stepping == Stepping::kLockstep ? t : ros::Time::now());
}

ros::Time RobotServer::CommandStamp() const {
  if (options_.stepping == Stepping::kLockstep && !histories_.empty() &&
      !histories_[0].samples().empty())
    return histories_[0].samples().back().stamp;
  return ros::Time::now();
}

void RobotServer::PublishCommand(const std::vector<double>& a, const ros::Time& stamp) {
  for (size_t c = 0; c < cmd_topics_.size(); ++c) {
    const std::string& type = cmd_topics_[c].type;
    const std::string& topic = cmd_topics_[c].topic;
    if (type == kTwistType) {
      cmd_pubs_[c].publish(MakeTwist(spec_, a, topic));
    } else if (type == kTwistStampedType) {
      geometry_msgs::TwistStamped m;
      m.header.stamp = stamp;
      m.twist = MakeTwist(spec_, a, topic);
      cmd_pubs_[c].publish(m);
    } else if (type == kFloat64MultiArrayType) {
      cmd_pubs_[c].publish(MakeFloat64MultiArray(spec_, a, topic));
    } else {
      trajectory_msgs::JointTrajectory m = MakeJointTrajectory(spec_, a, topic);
      m.header.stamp = stamp;
      cmd_pubs_[c].publish(m);
    }
  }
  ++counters_.commands;
}

void RobotServer::PublishStop(const std::string& why) {
  if (!stale_) {
    stale_ = true;
    ++counters_.stale_events;
    ROS_WARN_STREAM_NAMED(kPolicyLog, "inputs stale, sending stop commands: " << why);
  }
  stale_why_ = why;
  last_stop_ = ros::WallTime::now();
  if (frames_) frames_->Clear();  // after a stop the frame history starts over
  for (size_t c = 0; c < cmd_topics_.size(); ++c) {
    const std::string& type = cmd_topics_[c].type;
    const std::string& topic = cmd_topics_[c].topic;
    if (type == kTwistType) {
      cmd_pubs_[c].publish(geometry_msgs::Twist());
    } else if (type == kTwistStampedType) {
      geometry_msgs::TwistStamped m;
      m.header.stamp = CommandStamp();
      cmd_pubs_[c].publish(m);
    } else if (type == kFloat64MultiArrayType) {
      std_msgs::Float64MultiArray m =
          MakeFloat64MultiArray(spec_, std::vector<double>(spec_.action_dim(), 0.0), topic);
      std::fill(m.data.begin(), m.data.end(), 0.0);
      cmd_pubs_[c].publish(m);
    } else {
      // An empty trajectory makes joint_trajectory_controller stop and hold its position.
      trajectory_msgs::JointTrajectory m;
      m.header.stamp = CommandStamp();
      for (const auto& f : spec_.action)
        if (f.topic == topic)
          m.joint_names.insert(m.joint_names.end(), f.joints.begin(), f.joints.end());
      cmd_pubs_[c].publish(m);
    }
  }
  ++counters_.stops;
}

void RobotServer::OnDiagnostics(const ros::WallTimerEvent&) {
  diagnostic_msgs::DiagnosticArray arr;
  arr.header.stamp = ros::Time::now();
  diagnostic_msgs::DiagnosticStatus st;
  st.name = ros::this_node::getName() + ": robot " + spec_.name;
  st.hardware_id = spec_.name;
  st.level =
      stale_ ? diagnostic_msgs::DiagnosticStatus::WARN : diagnostic_msgs::DiagnosticStatus::OK;
  st.message = stale_ ? "inputs stale, stopping: " + stale_why_ : "serving";
  auto kv = [&](const std::string& k, const std::string& v) {
    diagnostic_msgs::KeyValue x;
    x.key = k;
    x.value = v;
    st.values.push_back(x);
  };
  kv("spec", spec_.source);
  kv("stale", stale_ ? "true" : "false");
  kv("messages", std::to_string(counters_.messages));
  kv("rejected", std::to_string(counters_.rejected));
  kv("commands", std::to_string(counters_.commands));
  kv("stop_commands", std::to_string(counters_.stops));
  kv("stale_events", std::to_string(counters_.stale_events));
  kv("inference_errors", std::to_string(counters_.inference_errors));
  if (pixels_) {
    kv("images", std::to_string(counters_.images));
    kv("bad_images", std::to_string(counters_.bad_images));
  }
  const ros::WallTime now = ros::WallTime::now();
  for (size_t k = 0; k < layout_.topics.size(); ++k)
    kv("age_s " + layout_.topics[k].name,
       histories_[k].samples().empty() ? "none" : std::to_string((now - last_receipt_[k]).toSec()));
  if (pixels_)
    kv("age_s " + spec_.images[0].topic,
       image_history_.samples().empty() ? "none" : std::to_string((now - image_receipt_).toSec()));
  arr.status.push_back(st);
  diag_pub_.publish(arr);
}

}  // namespace msspr::ros_bridge
