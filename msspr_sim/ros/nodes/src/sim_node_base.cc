#include "msspr_sim_nodes/sim_node_base.h"

#include <diagnostic_msgs/DiagnosticArray.h>
#include <rosgraph_msgs/Clock.h>
#include <sensor_msgs/Image.h>

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "msspr/EpisodeInfo.h"
#include "msspr/Observation.h"
#include "msspr_bags/dataset_bag.h"  // kCameraFrame
#include "msspr_bridge/msg_conversion.h"
#include "msspr_sim/expert.h"  // sim::EpisodeSeed

namespace msspr::ros_bridge {

void LoadSimNodeCommonOptions(const ros::NodeHandle& pnh, SimNodeCommonOptions* o) {
  auto param = [&](const std::string& name, const auto& def) { return SimParam(pnh, name, def); };
  o->observation_mode = param("observation_mode", o->observation_mode);
  o->image_size = param("image_size", o->image_size);
  o->stepping = param("stepping", o->stepping);
  o->control_rate = param("control_rate", o->control_rate);
  o->action_timeout = param("action_timeout", o->action_timeout);
  o->republish_timeout = param("republish_timeout", o->republish_timeout);
  o->publish_clock = param("publish_clock", o->publish_clock);
  o->clock_publish_rate = param("clock_publish_rate", o->clock_publish_rate);
  o->auto_reset = param("auto_reset", o->auto_reset);
  o->episode_length = param("episode_length", o->episode_length);
  o->num_episodes = param("num_episodes", o->num_episodes);
  o->val_episodes = param("val_episodes", o->val_episodes);
  o->shutdown_when_done = param("shutdown_when_done", o->shutdown_when_done);
  o->episode_gap = param("episode_gap", o->episode_gap);
  o->wait_for_subscribers = param("wait_for_subscribers", o->wait_for_subscribers);
  o->seed = param("seed", o->seed);
  auto bad = [](const std::string& name, const std::string& rule, const auto& v) {
    std::ostringstream s;
    s << "~" << name << " must be " << rule << ", got " << v;
    throw std::invalid_argument(s.str());
  };
  if (o->observation_mode != "state" && o->observation_mode != "pixels" &&
      o->observation_mode != "both")
    bad("observation_mode", "state, pixels or both", "'" + o->observation_mode + "'");
  if (o->stepping != "lockstep" && o->stepping != "realtime")
    bad("stepping", "lockstep or realtime", "'" + o->stepping + "'");
  if (!(o->control_rate > 0 && std::isfinite(o->control_rate)))
    bad("control_rate", "> 0 (Hz)", o->control_rate);
  if (!(o->action_timeout > 0 && std::isfinite(o->action_timeout)))
    bad("action_timeout", "> 0 (s)", o->action_timeout);
  if (!(o->republish_timeout > 0 && std::isfinite(o->republish_timeout)))
    bad("republish_timeout", "> 0 (s)", o->republish_timeout);
  if (!(o->clock_publish_rate >= 0 && std::isfinite(o->clock_publish_rate)))
    bad("clock_publish_rate", ">= 0 (Hz; 0: once per step)", o->clock_publish_rate);
  if (o->image_size < 8 || o->image_size > 1024) bad("image_size", "in 8..1024", o->image_size);
  if (o->episode_length < 2) bad("episode_length", ">= 2", o->episode_length);
  if (o->num_episodes < 0) bad("num_episodes", ">= 0 (0: unbounded)", o->num_episodes);
  if (o->val_episodes < 0) bad("val_episodes", ">= 0", o->val_episodes);
  if (!(o->episode_gap >= 0 && o->episode_gap <= 3600))
    bad("episode_gap", "in 0..3600 (s)", o->episode_gap);
  if (o->wait_for_subscribers < 0) bad("wait_for_subscribers", ">= 0", o->wait_for_subscribers);
  if (o->seed < 0) bad("seed", ">= 0", o->seed);
}

SimNodeBase::SimNodeBase(ros::NodeHandle nh, ros::NodeHandle pnh,
                         const SimNodeCommonOptions& common, size_t action_dim, double control_dt,
                         std::string env_name)
    : common_(common),
      nh_(nh),
      pnh_(pnh),
      it_(nh),
      action_dim_(action_dim),
      control_dt_(control_dt),
      env_name_(std::move(env_name)),
      latest_action_(action_dim, 0.0) {
  obs_pub_ = nh_.advertise<msspr::Observation>("observation", kStepTopicQueue);
  episode_pub_ = nh_.advertise<msspr::EpisodeInfo>("episode", kStepTopicQueue, /*latch=*/true);
  if (common_.publish_clock) clock_pub_ = nh_.advertise<rosgraph_msgs::Clock>("/clock", 10);
  diag_pub_ = nh_.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 10);
  if (pixels()) {
    image_pub_ = it_.advertise("camera/image", 10);
    goal_image_pub_ = nh_.advertise<sensor_msgs::Image>("goal_image", 1, /*latch=*/true);
  }
}

void SimNodeBase::StartRos() {
  action_sub_ =
      nh_.subscribe("action", 10, &SimNodeBase::OnAction, this, ros::TransportHints().tcpNoDelay());
  reset_srv_ = nh_.advertiseService("reset", &SimNodeBase::OnReset, this);
  goal_srv_ = nh_.advertiseService("set_goal", &SimNodeBase::OnSetGoal, this);
  pause_srv_ = nh_.advertiseService("pause", &SimNodeBase::OnPause, this);
  if (realtime())
    realtime_timer_ = nh_.createWallTimer(ros::WallDuration(1.0 / common_.control_rate),
                                          &SimNodeBase::OnRealtimeTick, this);
  if (realtime() && common_.publish_clock && common_.clock_publish_rate > 0)
    clock_timer_ = nh_.createWallTimer(ros::WallDuration(1.0 / common_.clock_publish_rate),
                                       &SimNodeBase::OnClockTick, this);
  watchdog_timer_ = nh_.createWallTimer(ros::WallDuration(0.05), &SimNodeBase::OnWatchdog, this);
  diag_timer_ = nh_.createWallTimer(ros::WallDuration(1.0), &SimNodeBase::OnDiagnostics, this);
  wait_since_ = ros::WallTime::now();
  PublishClock(TickToTime(0, control_dt_));  // time 0 until the first step
  ROS_INFO_STREAM_NAMED("msspr_sim", "msspr_sim_node serving " << env_name_ << " ("
                                                               << common_.stepping << ", "
                                                               << common_.observation_mode << ")");
}

void SimNodeBase::PublishClock(const ros::Time& stamp) {
  if (!common_.publish_clock) return;
  if (stamp < last_clock_) return;  // the running clock never goes back
  last_step_wall_ = ros::WallTime::now();
  last_clock_ = stamp;
  rosgraph_msgs::Clock c;
  c.clock = stamp;
  clock_pub_.publish(c);
}

void SimNodeBase::OnClockTick(const ros::WallTimerEvent&) {
  if (!active_ || paused_) return;
  // Sim time runs control_rate * control_dt times as fast as wall time, and stops
  // 1 ms short of the next step's stamp until the step happens.
  const double speed = common_.control_rate * control_dt_;
  const double ahead =
      std::min((ros::WallTime::now() - last_step_wall_).toSec() * speed, control_dt_ - 0.001);
  const ros::Time t = Now() + ros::Duration(std::max(ahead, 0.0));
  if (t <= last_clock_) return;
  last_clock_ = t;
  rosgraph_msgs::Clock c;
  c.clock = t;
  clock_pub_.publish(c);
}

void SimNodeBase::AnnounceEpisode(int task_id, uint64_t seed, const std::string& split,
                                  std::vector<float> start, std::vector<float> goal,
                                  const std::function<std::vector<uint8_t>()>& render_goal) {
  ++episode_id_;
  ++tick_;
  active_ = true;
  ForgetAction();
  ++counters_.episodes;
  msspr::EpisodeInfo info;
  info.header.stamp = Now();
  info.episode_id = static_cast<uint32_t>(episode_id_);
  info.env = env_name_;
  info.split = split;
  info.task_id = task_id;
  info.seed = seed;
  info.start = std::move(start);
  info.goal = std::move(goal);
  episode_pub_.publish(info);
  if (pixels() && render_goal) {
    const std::vector<uint8_t> img = render_goal();
    goal_image_pub_.publish(
        ToImageMsg(img.data(), common_.image_size, info.header.stamp, kCameraFrame));
  }
  Publish();
}

void SimNodeBase::OnAction(const msspr::Action::ConstPtr& msg) {
  std::vector<double> a;
  const ActionUse use =
      CheckAction(*msg, action_dim_, {paused_, active_, realtime(), episode_id_, EpisodeStep()},
                  &counters_, &a);
  if (use == ActionUse::kDrop) return;
  if (use == ActionUse::kLatest) {
    latest_action_ = a;
    latest_action_time_ = ros::WallTime::now();
    have_action_ = true;
    return;
  }
  StepOrNextEpisode(a);
}

void SimNodeBase::StepOrNextEpisode(const std::vector<double>& action) {
  if (common_.auto_reset && static_cast<int64_t>(EpisodeStep()) >= common_.episode_length - 1)
    NextAutoEpisode();  // the last action of the episode is recorded; start the next
  else
    DoStep(action);
}

void SimNodeBase::OnRealtimeTick(const ros::WallTimerEvent&) {
  if (!active_ || paused_) return;
  std::vector<double> a(action_dim_, 0.0);
  if (have_action_ &&
      (ros::WallTime::now() - latest_action_time_).toSec() <= common_.action_timeout)
    a = latest_action_;
  else if (have_action_)
    ++counters_.timeouts;
  StepOrNextEpisode(a);
}

bool SimNodeBase::ReadyToStart() {
  const bool subs_ok = obs_pub_.getNumSubscribers() + StandardObservationSubscribers() >=
                       static_cast<uint32_t>(common_.wait_for_subscribers);
  const bool agent_ok =
      !common_.auto_reset || action_sub_.getNumPublishers() + StandardCommandPublishers() > 0;
  if (!subs_ok || !agent_ok) {
    wait_since_ = ros::WallTime::now();
    ROS_INFO_THROTTLE_NAMED(5.0, "msspr_sim", "waiting for %d observation subscriber(s)%s",
                            common_.wait_for_subscribers,
                            common_.auto_reset ? " and an action publisher" : "");
    return false;
  }
  // Let every new subscriber finish connecting to the other topics too: rosbag record
  // subscribes to its topics one by one, which took over 0.5 s on a loaded 2-core machine
  // (a recording then missed its first cube poses).
  return common_.wait_for_subscribers == 0 || (ros::WallTime::now() - wait_since_).toSec() >= 2.0;
}

bool SimNodeBase::NextAutoEpisode() {
  const int64_t next = episode_id_ + 1;
  const int64_t total = static_cast<int64_t>(common_.num_episodes) + common_.val_episodes;
  if (common_.num_episodes > 0 && next >= total) {
    active_ = false;
    ROS_INFO_STREAM_NAMED("msspr_sim", "collection complete: " << total << " episodes of "
                                                               << common_.episode_length
                                                               << " steps");
    if (common_.shutdown_when_done) ros::shutdown();
    return false;
  }
  const std::string split =
      common_.num_episodes > 0 && next >= common_.num_episodes ? "val" : "train";
  if (next > 0 && common_.episode_gap > 0)  // the gap in sim time between two episodes
    tick_ += static_cast<uint64_t>(std::ceil(common_.episode_gap / control_dt_ - 1e-9));
  StartCollectionEpisode(
      sim::EpisodeSeed(static_cast<uint64_t>(common_.seed), static_cast<uint64_t>(next)), split);
  return true;
}

void SimNodeBase::OnWatchdog(const ros::WallTimerEvent&) {
  OnWatchdogTick();
  if (!started_) {
    if (!ReadyToStart()) return;
    started_ = true;
    if (common_.auto_reset)
      NextAutoEpisode();
    else
      StartInitialEpisode();
    return;
  }
  if (!realtime() && active_ && !paused_ &&
      (ros::WallTime::now() - last_publish_time_).toSec() > common_.republish_timeout) {
    ++counters_.republished;  // the observation or its answer was lost: send it again
    Publish();
  }
}

bool SimNodeBase::OnPause(msspr::Pause::Request& req, msspr::Pause::Response& res) {
  paused_ = req.pause;
  res.paused = paused_;
  if (!paused_) last_publish_time_ = ros::WallTime::now();
  ROS_INFO_STREAM_NAMED("msspr_sim", (paused_ ? "paused" : "resumed"));
  return true;
}

void SimNodeBase::OnDiagnostics(const ros::WallTimerEvent&) {
  diagnostic_msgs::DiagnosticArray arr;
  arr.header.stamp = Now();
  arr.status.push_back(ActionDiagnostics(counters_, ros::this_node::getName(), env_name_));
  diag_pub_.publish(arr);
}

}  // namespace msspr::ros_bridge
