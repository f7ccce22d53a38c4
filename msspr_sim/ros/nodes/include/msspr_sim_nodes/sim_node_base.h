// The ROS layer that msspr_sim_node's two environments share (PointMazeSimNode: the
// point maze; CubeSimNode: cube-single), so that both behave alike: the
// observation, episode, camera/image, goal_image, /clock and /diagnostics
// publishers; the action subscriber with its checks and counters
// (action_counters.h); the reset, set_goal and pause services; lockstep
// stepping (one step per current action; an unanswered observation is sent
// again after republish_timeout) or real-time stepping (control_rate Hz, the
// latest action held for action_timeout, then zero). A derived node owns the
// environment and implements the hooks below.
#pragma once

#include <image_transport/image_transport.h>
#include <ros/ros.h>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "msspr/Action.h"
#include "msspr/Pause.h"
#include "msspr/Reset.h"
#include "msspr/SetGoal.h"
#include "msspr_bridge/ros_params.h"
#include "msspr_sim_nodes/action_counters.h"

namespace msspr::ros_bridge {

// The parameters every sim node takes (docs/nodes.md "msspr_sim_node").
struct SimNodeCommonOptions {
  std::string observation_mode = "state";  // state | pixels | both
  int image_size = 64;
  std::string stepping = "lockstep";  // lockstep | realtime
  double control_rate = 10.0;         // Hz, real-time stepping
  double action_timeout = 0.5;        // s; an older action becomes zero (real time)
  double republish_timeout = 1.0;     // s; lockstep re-sends an unanswered observation
  bool publish_clock = true;
  // Real time: /clock also runs on between steps, published at this rate of wall
  // time (Hz; 0: it moves once per step), at control_rate * control period
  // times wall speed and never reaching the next step's time (as Gazebo's clock
  // runs). So that a recorder stamps a command by when it arrived within the
  // step, not by when its copy of the clock last moved (collect.launch robot:=...).
  double clock_publish_rate = 0.0;
  // Collection mode: episodes of episode_length steps from the env's random
  // collection resets (seeds sim::EpisodeSeed(seed, k)), the last step's
  // action triggering the next reset; an agent drives them (expert or oracle
  // node) and rosbag record writes the dataset (launch/collect.launch).
  bool auto_reset = false;
  int episode_length = 1001;
  int num_episodes = 0;  // 0: unbounded
  int val_episodes = 0;  // extra episodes tagged split "val"
  bool shutdown_when_done = true;
  // Sim time (s) skipped between collection episodes: the next episode's messages are
  // stamped that much after the last one's, so that a recording of standard topics
  // split by a gap (a robot spec's episodes: split_by gap) finds every episode.
  double episode_gap = 0.0;
  int wait_for_subscribers = 0;  // observation subscribers before starting
  int seed = 0;
};

// A ~param of a sim node, logged under "msspr_sim".
template <typename T>
T SimParam(const ros::NodeHandle& pnh, const std::string& name, const T& def) {
  return LoggedParam(pnh, name, def, "msspr_sim");
}

// The publisher queue (per subscriber) of every per-step stream of the sims
// and of the agents that drive them in collection (observation, episode,
// joint states, poses, the oracle's and the expert's actions). Lockstep runs
// as fast as the agent answers, so a subscriber that falls behind for a few
// tens of milliseconds (rosbag record on a loaded machine) would otherwise
// lose steps from the middle of a recording.
constexpr uint32_t kStepTopicQueue = 1000;

// An agent node's wait before its first answer (~wait_for_command_subscribers): until each of
// its command publishers has `wanted` subscribers (the sim and a recorder: 2), so that a
// recording that starts with the sim's first step has every command. Unanswered, the sim
// sends the observation again after republish_timeout.
class CommandSubscriberWait {
 public:
  explicit CommandSubscriberWait(int wanted = 0) : wanted_(wanted) {}
  bool Ready(std::initializer_list<const ros::Publisher*> publishers, const char* who) {
    if (ready_ || wanted_ <= 0) return true;
    for (const ros::Publisher* p : publishers) {
      if (p->getNumSubscribers() < static_cast<uint32_t>(wanted_)) {
        ROS_INFO_THROTTLE(5.0, "%s: waiting for %d subscribers of %s", who, wanted_,
                          p->getTopic().c_str());
        return false;
      }
    }
    return ready_ = true;
  }

 private:
  int wanted_;
  bool ready_ = false;
};

// Reads the common ~params into `o` (its values are the defaults), logging
// each; throws std::invalid_argument naming a bad one.
void LoadSimNodeCommonOptions(const ros::NodeHandle& pnh, SimNodeCommonOptions* o);

class SimNodeBase {
 public:
  virtual ~SimNodeBase() = default;
  using Counters = ActionCounters;
  const Counters& counters() const { return counters_; }

 protected:
  SimNodeBase(ros::NodeHandle nh, ros::NodeHandle pnh, const SimNodeCommonOptions& common,
              size_t action_dim, double control_dt, std::string env_name);
  // Advertises the common topics and services, starts the timers and
  // publishes /clock at time 0: the end of a derived constructor (callbacks
  // run from the spinner, after construction).
  void StartRos();

  // --- hooks ---
  // One control step with a checked, clipped action; publishes what follows.
  // (In collection mode, the action answering an episode's last step starts
  // the next episode instead: the base does that.)
  virtual void DoStep(const std::vector<double>& action) = 0;
  // The current observation's step (for matching lockstep actions).
  virtual uint32_t EpisodeStep() const = 0;
  // Publishes the current observation (and its images, tf2, ...); called again
  // for an unanswered lockstep observation.
  virtual void Publish() = 0;
  virtual bool Reset(msspr::Reset::Request& req, msspr::Reset::Response& res) = 0;
  virtual bool SetGoal(msspr::SetGoal::Request& req, msspr::SetGoal::Response& res) = 0;
  // Collection mode: starts episode episode_id_ + 1 from a collection reset
  // with `seed`, tagged `split` (episode_id_ and tick_ to advance, as resets do).
  virtual void StartCollectionEpisode(uint64_t seed, const std::string& split) = 0;
  // Without collection mode: the episode to start once the node is ready
  // (initial_task), or none (left to a reset).
  virtual void StartInitialEpisode() = 0;
  // Called first at every watchdog tick.
  virtual void OnWatchdogTick() {}
  // Subscribers of the derived node's standard observation topic (e.g. odom),
  // counted with those of `observation` against wait_for_subscribers; and
  // publishers of its standard command topic (e.g. cmd_vel), which count as
  // an agent in collection mode.
  virtual uint32_t StandardObservationSubscribers() const { return 0; }
  virtual uint32_t StandardCommandPublishers() const { return 0; }

  bool pixels() const { return common_.observation_mode != "state"; }
  bool realtime() const { return common_.stepping == "realtime"; }
  ros::Time Now() const { return TickToTime(tick_, control_dt_); }
  void PublishClock(const ros::Time& stamp);
  // An episode starts: no held action from the previous one.
  void ForgetAction() { have_action_ = false; }
  // Whether an episode at `steps` is at its last step: episode_length - 1 in
  // collection mode, else max_episode_steps.
  bool IsLastStep(int steps, int max_episode_steps) const {
    return common_.auto_reset ? steps >= common_.episode_length - 1 : steps >= max_episode_steps;
  }
  // The environment has just been reset for a new episode: advances
  // episode_id_ and the clock, counts the episode, publishes its EpisodeInfo
  // (env, split, task, seed, start and goal) and, in pixels mode, the goal's
  // image from render_goal (latched on goal_image; none when render_goal is
  // empty), then the first observation (Publish()).
  void AnnounceEpisode(int task_id, uint64_t seed, const std::string& split,
                       std::vector<float> start, std::vector<float> goal,
                       const std::function<std::vector<uint8_t>()>& render_goal);
  // After publishing an observation (for lockstep's republish timeout); a
  // last one ends the episode (but in collection mode, whose next action
  // starts the next one).
  void MarkPublished(bool last) {
    last_publish_time_ = ros::WallTime::now();
    if (last && !common_.auto_reset) active_ = false;  // wait for a reset
  }

  SimNodeCommonOptions common_;
  ros::NodeHandle nh_, pnh_;
  image_transport::ImageTransport it_;
  // goal_image is a plain latched publisher: image_transport publishes only to
  // transports that have a subscriber at that moment, which loses the latch.
  ros::Publisher obs_pub_, episode_pub_, clock_pub_, diag_pub_, goal_image_pub_;
  image_transport::Publisher image_pub_;
  ros::Subscriber action_sub_;
  bool started_ = false, active_ = false, paused_ = false;
  int64_t episode_id_ = -1;
  uint64_t tick_ = 0;
  Counters counters_;

  // An action for the current step, checked and applied as if it came on `action`.
  void OnAction(const msspr::Action::ConstPtr& msg);

 private:
  bool OnReset(msspr::Reset::Request& req, msspr::Reset::Response& res) { return Reset(req, res); }
  bool OnSetGoal(msspr::SetGoal::Request& req, msspr::SetGoal::Response& res) {
    return SetGoal(req, res);
  }
  bool OnPause(msspr::Pause::Request& req, msspr::Pause::Response& res);
  void OnRealtimeTick(const ros::WallTimerEvent&);
  void OnWatchdog(const ros::WallTimerEvent&);
  void OnDiagnostics(const ros::WallTimerEvent&);
  // Whether the subscribers (and in collection mode, the agent) are connected.
  bool ReadyToStart();
  // DoStep, or in collection mode after an episode's last step the next episode.
  void StepOrNextEpisode(const std::vector<double>& action);
  // Collection mode: the next episode, or false (and shutdown_when_done) when
  // num_episodes + val_episodes are done.
  bool NextAutoEpisode();

  size_t action_dim_;
  double control_dt_;
  std::string env_name_;
  std::vector<double> latest_action_;
  bool have_action_ = false;
  ros::WallTime latest_action_time_, last_publish_time_, wait_since_;
  ros::ServiceServer reset_srv_, goal_srv_, pause_srv_;
  ros::WallTimer realtime_timer_, watchdog_timer_, diag_timer_, clock_timer_;
  ros::WallTime last_step_wall_;  // real time: when the clock last moved to a step
  ros::Time last_clock_;
  void OnClockTick(const ros::WallTimerEvent&);
};

}  // namespace msspr::ros_bridge
