#include "policy_node.h"

#include <diagnostic_msgs/DiagnosticArray.h>
#include <torch/torch.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "msspr/Action.h"
#include "msspr_bridge/msg_conversion.h"
#include "msspr_bridge/ros_params.h"
#include "msspr_core/policy.h"
#include "msspr_sim/maze_map.h"
#include "value_markers.h"

namespace msspr::ros_bridge {

namespace {

constexpr size_t kMaxPending = 8;  // pixels: unpaired observations / images kept

template <typename T>
T Param(const ros::NodeHandle& pnh, const std::string& name, const T& def) {
  return LoggedParam(pnh, name, def, kPolicyLog);
}

// Percentile q in [0, 1] of the values (nearest rank); NaN when empty.
double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const size_t k =
      std::min(v.size() - 1, static_cast<size_t>(std::ceil(q * v.size())) - (q > 0 ? 1 : 0));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

std::string Fixed(double v, int digits = 3) {
  if (!std::isfinite(v)) return "nan";
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(digits);
  s << v;
  return s.str();
}

}  // namespace

const char* RejectKey(RejectReason reason) {
  switch (reason) {
    case RejectReason::kWrongDim:
      return "rejected_wrong_dim";
    case RejectReason::kNonFinite:
      return "rejected_nonfinite";
    case RejectReason::kNoGoal:
      return "rejected_no_goal";
    case RejectReason::kBadImage:
      return "rejected_bad_image";
    case RejectReason::kCount:
      break;
  }
  return "rejected_unknown";
}

PolicyNodeOptions LoadPolicyNodeOptions(const ros::NodeHandle& pnh) {
  PolicyNodeOptions o;
  ROS_INFO_NAMED(kPolicyLog, "msspr_policy_node parameters:");
  o.checkpoint = Param(pnh, "checkpoint", o.checkpoint);
  o.robot = Param(pnh, "robot", o.robot);
  o.observation_mode = Param(pnh, "observation_mode", o.observation_mode);
  // ~stepping (lockstep | realtime); the deprecated ~mode (lockstep | rate) still works.
  std::string stepping = Param(pnh, "stepping", std::string());
  std::string mode;
  if (pnh.getParam("mode", mode)) {
    ROS_WARN_STREAM_NAMED(kPolicyLog,
                          "~mode is deprecated: use ~stepping (lockstep | realtime; "
                          "~mode rate is ~stepping realtime)");
    if (mode != "lockstep" && mode != "rate")
      throw std::invalid_argument("~mode must be lockstep or rate, got '" + mode + "'");
    const std::string as_stepping = mode == "rate" ? "realtime" : "lockstep";
    if (!stepping.empty() && stepping != as_stepping)
      throw std::invalid_argument("~stepping " + stepping + " and the deprecated ~mode " + mode +
                                  " disagree: give ~stepping only");
    stepping = as_stepping;
  }
  if (stepping.empty()) stepping = "lockstep";
  if (stepping != "lockstep" && stepping != "realtime")
    throw std::invalid_argument("~stepping must be lockstep or realtime, got '" + stepping + "'");
  o.stepping = stepping == "lockstep" ? Stepping::kLockstep : Stepping::kRealtime;
  o.rate = Param(pnh, "rate", o.rate);
  o.observation_timeout = Param(pnh, "observation_timeout", o.observation_timeout);
  o.threads = Param(pnh, "threads", o.threads);
  o.device = Param(pnh, "device", o.device);
  o.diagnostics_period = Param(pnh, "diagnostics_period", o.diagnostics_period);
  o.latency_window = Param(pnh, "latency_window", o.latency_window);
  o.value_marker_maze = Param(pnh, "value_marker_maze", o.value_marker_maze);
  o.value_marker_period = Param(pnh, "value_marker_period", o.value_marker_period);
  o.value_marker_per_cell = Param(pnh, "value_marker_per_cell", o.value_marker_per_cell);
  if (o.checkpoint.empty())
    throw std::invalid_argument(
        "~checkpoint is required (a policy.pt from Trainer::ExportPolicy "
        "or a trainer checkpoint)");
  if (o.observation_mode != "state" && o.observation_mode != "pixels")
    throw std::invalid_argument("~observation_mode must be state or pixels, got '" +
                                o.observation_mode + "'");
  auto positive = [](const char* name, double v) {
    if (!(v > 0) || !std::isfinite(v))
      throw std::invalid_argument(std::string("~") + name + " must be a finite number > 0, got " +
                                  std::to_string(v));
  };
  positive("rate", o.rate);
  positive("observation_timeout", o.observation_timeout);
  positive("diagnostics_period", o.diagnostics_period);
  positive("value_marker_period", o.value_marker_period);
  if (!o.value_marker_maze.empty()) {
    try {
      sim::MazeMap::FromName(o.value_marker_maze);
    } catch (const std::exception& e) {
      throw std::invalid_argument("~value_marker_maze: " + std::string(e.what()));
    }
  }
  if (o.value_marker_per_cell < 1 || o.value_marker_per_cell > 10)
    throw std::invalid_argument("~value_marker_per_cell must be in 1..10, got " +
                                std::to_string(o.value_marker_per_cell));
  if (o.threads < 1 || o.threads > 1024)
    throw std::invalid_argument("~threads must be in 1..1024, got " + std::to_string(o.threads));
  if (o.latency_window < 1 || o.latency_window > 10000000)
    throw std::invalid_argument("~latency_window must be in 1..10000000, got " +
                                std::to_string(o.latency_window));
  return o;
}

std::shared_ptr<core::Policy> LoadPolicyForNode(const PolicyNodeOptions& options) {
  torch::set_num_threads(options.threads);
  if (!std::ifstream(options.checkpoint).good())
    throw std::runtime_error(options.checkpoint + ": checkpoint file not found or not readable");
  torch::Device device(torch::kCPU);
  try {
    device = torch::Device(options.device);
  } catch (const c10::Error& e) {
    throw std::invalid_argument("~device '" + options.device + "': " + e.what_without_backtrace());
  }
  auto policy = std::make_shared<core::Policy>(core::Policy::Load(options.checkpoint, device));
  const auto& n = policy->options().network;
  ROS_INFO_STREAM_NAMED(
      kPolicyLog,
      "loaded " << options.checkpoint << ": agent " << policy->agent_name() << ", obs_mode "
                << n.obs_mode << ", obs_dim " << n.obs_dim << ", action_dim " << n.action_dim
                << (policy->pixels() ? ", image " + std::to_string(n.image_height) + "x" +
                                           std::to_string(n.image_width) + "x" +
                                           std::to_string(n.image_channels) + " frame_stack " +
                                           std::to_string(n.frame_stack)
                                     : std::string())
                << ", torch threads " << torch::get_num_threads() << ", device " << device.str());
  return policy;
}

PolicyNode::PolicyNode(ros::NodeHandle nh, ros::NodeHandle pnh, const PolicyNodeOptions& options,
                       std::shared_ptr<core::Policy> policy)
    : options_(options), nh_(nh), pnh_(pnh), policy_(std::move(policy)), it_(nh) {
  const auto& n = policy_->options().network;
  pixels_ = policy_->pixels();
  const std::string ckpt_mode = pixels_ ? "pixels" : "state";
  if (options_.observation_mode != ckpt_mode)
    throw std::invalid_argument("~observation_mode is '" + options_.observation_mode + "' but " +
                                options_.checkpoint + " holds a " + ckpt_mode +
                                " policy (network.obs_mode '" + n.obs_mode +
                                "'); set ~observation_mode:=" + ckpt_mode + " or load a " +
                                options_.observation_mode + " checkpoint");
  obs_dim_ = policy_->obs_dim();
  action_dim_ = policy_->action_dim();
  image_h_ = n.image_height;
  image_w_ = n.image_width;
  image_c_ = n.image_channels;
  frame_stack_ = std::max(1, n.frame_stack);
  if (pixels_ && (image_c_ != 3 || image_h_ != image_w_))
    throw std::invalid_argument(
        options_.checkpoint + ": the node takes square rgb8 images, the policy expects " +
        std::to_string(image_h_) + "x" + std::to_string(image_w_) + "x" + std::to_string(image_c_));
  if (pixels_) frames_.emplace(image_h_, image_w_, image_c_, frame_stack_);
  if (!pixels_ && obs_dim_ < 1)
    throw std::invalid_argument(options_.checkpoint + ": state policy with obs_dim " +
                                std::to_string(obs_dim_));

  const bool lockstep = options_.stepping == Stepping::kLockstep;
  const uint32_t queue = lockstep ? 10 : 1;
  action_pub_ = nh_.advertise<msspr::Action>("action", 10);
  diag_pub_ = nh_.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 10);
  obs_sub_ = nh_.subscribe("observation", queue, &PolicyNode::OnObservation, this,
                           ros::TransportHints().tcpNoDelay());
  if (pixels_) {
    const image_transport::TransportHints hints("raw", ros::TransportHints().tcpNoDelay());
    image_sub_ = it_.subscribe("camera/image", queue, &PolicyNode::OnImage, this, hints);
    goal_image_sub_ = it_.subscribe("goal_image", 1, &PolicyNode::OnGoalImage, this, hints);
    goal_source_ = "goal_image";
  } else {
    goal_state_sub_ = nh_.subscribe("goal_state", 1, &PolicyNode::OnGoalState, this);
  }
  set_goal_srv_ = pnh_.advertiseService("set_goal", &PolicyNode::OnSetGoal, this);
  if (!lockstep)
    rate_timer_ =
        nh_.createWallTimer(ros::WallDuration(1.0 / options_.rate), &PolicyNode::OnRateTick, this);
  diag_timer_ = nh_.createWallTimer(ros::WallDuration(options_.diagnostics_period),
                                    &PolicyNode::OnDiagnostics, this);
  last_diag_time_ = ros::WallTime::now();
  if (!options_.value_marker_maze.empty()) {
    if (!policy_->has_value()) {
      ROS_WARN_STREAM_NAMED(
          kPolicyLog, "~value_marker_maze: the "
                          << policy_->agent_name()
                          << " agent has no value function; no value markers will be published");
    } else if (pixels_ || obs_dim_ != 2) {
      ROS_WARN_STREAM_NAMED(
          kPolicyLog,
          "~value_marker_maze: value markers need a state policy of the point maze "
          "(obs_dim 2); none will be published");
    } else {
      value_markers_ = std::make_unique<ValueMarkers>(options_.value_marker_maze,
                                                      options_.value_marker_per_cell);
      value_pub_ =
          nh_.advertise<visualization_msgs::MarkerArray>("value_markers", 1, /*latch=*/true);
      value_timer_ = nh_.createWallTimer(ros::WallDuration(options_.value_marker_period),
                                         &PolicyNode::OnValueMarkers, this);
    }
  }
  ROS_INFO_STREAM_NAMED(kPolicyLog, "msspr_policy_node serving " << options_.checkpoint << " ("
                                                                 << SteppingName(options_.stepping)
                                                                 << ", " << ckpt_mode << ")");
}

PolicyNode::~PolicyNode() = default;

void PolicyNode::Reject(RejectReason reason, const std::string& what) {
  const int r = static_cast<int>(reason);
  ++counters_.rejected[r];
  if (!said_[r]) {  // once, unthrottled: what the checkpoint expects and what came
    said_[r] = true;
    const auto& n = policy_->options().network;
    ROS_ERROR_STREAM_NAMED(kPolicyLog,
                           "first rejected input ("
                               << RejectKey(reason) << "): " << what << "; " << options_.checkpoint
                               << " expects "
                               << (pixels_ ? std::to_string(n.image_height) + "x" +
                                                 std::to_string(n.image_width) + " rgb8 images"
                                           : "obs_dim " + std::to_string(obs_dim_))
                               << " and gives action_dim " << action_dim_
                               << "; further rejections are counted in /diagnostics");
    return;
  }
  ROS_ERROR_STREAM_THROTTLE_NAMED(1.0, kPolicyLog, RejectKey(reason) << ": " << what);
}

bool PolicyNode::MakeStateInput(const msspr::Observation& msg, Input* in) {
  if (msg.state.size() != static_cast<size_t>(obs_dim_)) {
    Reject(RejectReason::kWrongDim, "observation state has " + std::to_string(msg.state.size()) +
                                        " values, expected " + std::to_string(obs_dim_));
    return false;
  }
  if (!AllFinite(msg.state)) {
    Reject(RejectReason::kNonFinite, "observation state has NaN or Inf values");
    return false;
  }
  const std::vector<float>* goal = &goal_override_;
  if (goal_override_.empty()) {
    goal = &msg.goal;
    if (msg.goal.empty()) {
      Reject(RejectReason::kNoGoal,
             "no goal: the observation's goal field is empty and no goal was set "
             "(~set_goal or goal_state)");
      return false;
    }
    if (msg.goal.size() != static_cast<size_t>(obs_dim_)) {
      Reject(RejectReason::kWrongDim, "observation goal has " + std::to_string(msg.goal.size()) +
                                          " values, expected " + std::to_string(obs_dim_));
      return false;
    }
    if (!AllFinite(msg.goal)) {
      Reject(RejectReason::kNonFinite, "observation goal has NaN or Inf values");
      return false;
    }
  }
  in->episode_id = msg.episode_id;
  in->step = msg.step;
  in->header = msg.header;
  in->state = msg.state;
  in->goal = *goal;
  return true;
}

void PolicyNode::OnObservation(const msspr::Observation::ConstPtr& msg) {
  const ros::WallTime start = ros::WallTime::now();
  ++counters_.observations;
  if (pixels_) {
    pending_obs_.push_back(msg);
    if (pending_obs_.size() > kMaxPending) {
      pending_obs_.pop_front();
      ++counters_.unmatched_images;
    }
    TryPair();
    return;
  }
  auto in = std::make_unique<Input>();
  if (!MakeStateInput(*msg, in.get())) return;
  in->received = start;
  if (options_.stepping == Stepping::kLockstep)
    Act(*in, start);
  else
    latest_ = std::move(in);
}

void PolicyNode::OnImage(const sensor_msgs::ImageConstPtr& msg) {
  ++counters_.images;
  const std::string why = CheckRgbImage(*msg, image_h_);
  if (!why.empty()) {
    Reject(RejectReason::kBadImage, "camera image: " + why);
    return;
  }
  pending_images_.push_back(msg);
  if (pending_images_.size() > kMaxPending) {
    pending_images_.pop_front();
    ++counters_.unmatched_images;
  }
  TryPair();
}

void PolicyNode::TryPair() {
  // The sim publishes the image and the observation of a step with equal stamps.
  for (auto o = pending_obs_.begin(); o != pending_obs_.end(); ++o) {
    for (auto i = pending_images_.begin(); i != pending_images_.end(); ++i) {
      if ((*i)->header.stamp != (*o)->header.stamp) continue;
      const msspr::Observation::ConstPtr obs = *o;
      const sensor_msgs::ImageConstPtr img = *i;
      // Older unpaired entries will never be answered: drop them.
      counters_.unmatched_images += static_cast<uint64_t>(o - pending_obs_.begin()) +
                                    static_cast<uint64_t>(i - pending_images_.begin());
      pending_obs_.erase(pending_obs_.begin(), o + 1);
      pending_images_.erase(pending_images_.begin(), i + 1);
      const ros::WallTime start = ros::WallTime::now();
      auto in = std::make_unique<Input>();
      if (MakePixelInput(*obs, *img, in.get())) {
        in->received = start;
        if (options_.stepping == Stepping::kLockstep)
          Act(*in, start);
        else
          latest_ = std::move(in);
      }
      TryPair();  // the iterators are invalid now; look again
      return;
    }
  }
}

bool PolicyNode::MakePixelInput(const msspr::Observation& obs, const sensor_msgs::Image& img,
                                Input* in) {
  if (goal_image_.empty()) {
    Reject(RejectReason::kNoGoal, "no goal image received yet on " + goal_image_sub_.getTopic());
    return false;
  }
  // Frame history of the episode: a re-sent step replaces its frame; a new
  // episode (or an earlier step) starts over with the first frame repeated,
  // as the dataset's frame stacking does at a trajectory's start.
  const bool restart = static_cast<int64_t>(obs.episode_id) != frames_episode_ ||
                       static_cast<int64_t>(obs.step) < frames_step_ || frames_->empty();
  if (restart)
    frames_->Reset(img.data.data());
  else if (static_cast<int64_t>(obs.step) == frames_step_)
    frames_->Replace(img.data.data());
  else
    frames_->Push(img.data.data());
  frames_episode_ = obs.episode_id;
  frames_step_ = obs.step;
  in->image.resize(frames_->stacked_bytes());  // [H, W, C * frame_stack]
  frames_->Stacked(in->image.data());
  in->episode_id = obs.episode_id;
  in->step = obs.step;
  in->header = obs.header;
  in->goal_image = goal_image_;
  return true;
}

void PolicyNode::OnGoalImage(const sensor_msgs::ImageConstPtr& msg) {
  const std::string why = CheckRgbImage(*msg, image_h_);
  if (!why.empty()) {
    Reject(RejectReason::kBadImage, "goal image: " + why);
    return;
  }
  // A goal is one image; stacked, it is repeated frame_stack times.
  goal_image_ = frames_->Repeat(msg->data.data());
}

void PolicyNode::OnGoalState(const msspr::Observation::ConstPtr& msg) {
  if (msg->state.empty()) {
    goal_override_.clear();
    goal_source_ = "observation";
    ROS_INFO_NAMED(kPolicyLog, "goal override cleared: using each observation's goal");
    return;
  }
  if (msg->state.size() != static_cast<size_t>(obs_dim_)) {
    Reject(RejectReason::kWrongDim, "goal_state has " + std::to_string(msg->state.size()) +
                                        " values, expected " + std::to_string(obs_dim_));
    return;
  }
  if (!AllFinite(msg->state)) {
    Reject(RejectReason::kNonFinite, "goal_state has NaN or Inf values");
    return;
  }
  goal_override_ = msg->state;
  goal_source_ = "goal_state";
}

bool PolicyNode::OnSetGoal(msspr::SetGoal::Request& req, msspr::SetGoal::Response& res) {
  res.ok = false;
  if (pixels_) {
    res.message = "pixels mode: the goal is the latest image on " + goal_image_sub_.getTopic();
  } else if (req.goal.empty()) {
    goal_override_.clear();
    goal_source_ = "observation";
    res.ok = true;
    res.message = "goal cleared: using each observation's goal";
  } else if (req.goal.size() != static_cast<size_t>(obs_dim_) || !AllFinite(req.goal)) {
    res.message = "goal must be " + std::to_string(obs_dim_) + " finite numbers (empty: clear)";
  } else {
    goal_override_ = req.goal;
    goal_source_ = "set_goal";
    res.ok = true;
    res.message = "goal set";
  }
  ROS_INFO_STREAM_NAMED(kPolicyLog, "~set_goal: " << res.message);
  return true;
}

void PolicyNode::OnRateTick(const ros::WallTimerEvent&) {
  if (!latest_) return;
  const ros::WallTime now = ros::WallTime::now();
  if ((now - latest_->received).toSec() > options_.observation_timeout) {
    ROS_WARN_STREAM_THROTTLE_NAMED(
        5.0, kPolicyLog, "no observation for " << options_.observation_timeout << " s: not acting");
    return;
  }
  Act(*latest_, now);
}

void PolicyNode::Act(const Input& in, const ros::WallTime& start) {
  torch::Tensor obs, goal;
  if (pixels_) {
    const std::vector<int64_t> shape = {image_h_, image_w_, int64_t{image_c_} * frame_stack_};
    obs = torch::from_blob(const_cast<uint8_t*>(in.image.data()), shape, torch::kUInt8);
    goal = torch::from_blob(const_cast<uint8_t*>(in.goal_image.data()), shape, torch::kUInt8);
  } else {
    obs = torch::from_blob(const_cast<float*>(in.state.data()), {obs_dim_}, torch::kFloat32);
    goal = torch::from_blob(const_cast<float*>(in.goal.data()), {obs_dim_}, torch::kFloat32);
  }
  msspr::Action out;
  torch::Tensor a;
  try {
    a = policy_->Act(obs, goal).to(torch::kCPU).contiguous();
  } catch (const c10::Error& e) {
    ++counters_.inference_errors;
    ROS_ERROR_STREAM_THROTTLE_NAMED(1.0, kPolicyLog,
                                    "inference failed: " << e.what_without_backtrace());
    return;
  }
  out.action.assign(a.data_ptr<float>(), a.data_ptr<float>() + a.numel());
  if (out.action.size() != static_cast<size_t>(action_dim_) || !AllFinite(out.action)) {
    ++counters_.inference_errors;
    ROS_ERROR_STREAM_THROTTLE_NAMED(
        1.0, kPolicyLog,
        "the policy returned " << out.action.size() << " values or NaN / Inf: not published");
    return;
  }
  if (!pixels_) last_goal_ = in.goal;
  out.header = in.header;
  out.episode_id = in.episode_id;
  out.step = in.step;
  action_pub_.publish(out);
  ++counters_.actions;
  latencies_ms_.push_back((ros::WallTime::now() - start).toSec() * 1e3);
  while (latencies_ms_.size() > static_cast<size_t>(options_.latency_window))
    latencies_ms_.pop_front();
  // The value estimate costs a second forward pass: once per diagnostics
  // period, after the action has gone out.
  if (value_due_ && policy_->has_value()) {
    value_due_ = false;
    try {
      value_ = policy_->Q(obs, a, goal).min().item<double>();
    } catch (const c10::Error& e) {
      ROS_ERROR_STREAM_THROTTLE_NAMED(1.0, kPolicyLog,
                                      "value estimate failed: " << e.what_without_backtrace());
    }
  }
}

void PolicyNode::OnValueMarkers(const ros::WallTimerEvent&) {
  if (last_goal_.size() != 2 || !value_markers_ || value_markers_->empty())
    return;  // no goal served yet
  visualization_msgs::MarkerArray arr;
  try {
    arr = value_markers_->Make(*policy_, last_goal_);
  } catch (const c10::Error& e) {
    ++counters_.inference_errors;
    ROS_ERROR_STREAM_THROTTLE_NAMED(
        10.0, kPolicyLog, "value markers: inference failed: " << e.what_without_backtrace());
    return;
  }
  value_pub_.publish(arr);
}

void PolicyNode::OnDiagnostics(const ros::WallTimerEvent&) {
  const ros::WallTime now = ros::WallTime::now();
  const double dt = std::max(1e-6, (now - last_diag_time_).toSec());
  const double rate = static_cast<double>(counters_.actions - actions_at_last_diag_) / dt;
  uint64_t rejected = 0;
  for (uint64_t r : counters_.rejected) rejected += r;
  const uint64_t new_rejected = rejected - rejected_at_last_diag_;
  actions_at_last_diag_ = counters_.actions;
  rejected_at_last_diag_ = rejected;
  last_diag_time_ = now;
  value_due_ = true;

  diagnostic_msgs::DiagnosticArray arr;
  arr.header.stamp = ros::Time::now();
  diagnostic_msgs::DiagnosticStatus st;
  st.name = ros::this_node::getName() + ": policy";
  st.hardware_id = options_.checkpoint;
  if (new_rejected > 0 || counters_.inference_errors > 0) {
    st.level = diagnostic_msgs::DiagnosticStatus::WARN;
    st.message =
        std::to_string(new_rejected) + " inputs rejected in the last " + Fixed(dt, 1) + " s";
  } else {
    st.level = diagnostic_msgs::DiagnosticStatus::OK;
    st.message = "ok";
  }
  auto kv = [&](const std::string& k, const std::string& v) {
    diagnostic_msgs::KeyValue p;
    p.key = k;
    p.value = v;
    st.values.push_back(p);
  };
  const std::vector<double> lat(latencies_ms_.begin(), latencies_ms_.end());
  kv("agent", policy_->agent_name());
  kv("stepping", SteppingName(options_.stepping));
  kv("observation_mode", pixels_ ? "pixels" : "state");
  kv("goal_source", goal_source_);
  kv("latency_p50_ms", Fixed(Percentile(lat, 0.50)));
  kv("latency_p99_ms", Fixed(Percentile(lat, 0.99)));
  kv("action_rate_hz", Fixed(rate, 2));
  kv("value_estimate", Fixed(value_, 4));
  kv("observations", std::to_string(counters_.observations));
  if (pixels_) kv("images", std::to_string(counters_.images));
  kv("actions", std::to_string(counters_.actions));
  for (int r = 0; r < static_cast<int>(RejectReason::kCount); ++r)
    kv(RejectKey(static_cast<RejectReason>(r)), std::to_string(counters_.rejected[r]));
  kv("unmatched_images", std::to_string(counters_.unmatched_images));
  kv("inference_errors", std::to_string(counters_.inference_errors));
  arr.status.push_back(st);
  diag_pub_.publish(arr);
}

}  // namespace msspr::ros_bridge
