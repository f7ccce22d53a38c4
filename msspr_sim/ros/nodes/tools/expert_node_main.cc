// msspr_expert_node: the scripted BFS expert over ROS. mode "goal" drives toward
// each observation's goal (evaluation, demo); "navigate" / "stitch" run the
// data-collection procedures with the episode seeds announced on `episode`, so
// that a recording of sim + expert equals what msspr_collect writes.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/Twist.h>
#include <ros/ros.h>

#include <map>
#include <memory>

#include "msspr/Action.h"
#include "msspr/EpisodeInfo.h"
#include "msspr/Observation.h"
#include "msspr_bridge/msg_conversion.h"
#include "msspr_sim/expert.h"
#include "msspr_sim/maze_map.h"
#include "msspr_sim_nodes/sim_node_base.h"

namespace {

using msspr::sim::Cell;

class ExpertNode {
 public:
  ExpertNode(ros::NodeHandle nh, ros::NodeHandle pnh) : nh_(nh) {
    std::string maze = "medium";
    pnh.param<std::string>("maze", maze, maze);
    pnh.param<std::string>("mode", mode_, "goal");
    pnh.param("noise_std", noise_, mode_ == "goal" ? 0.0 : 0.5);
    pnh.param("seed", seed_, 0);
    // "action": msspr/Action on action; "cmd_vel": geometry_msgs/Twist on cmd_vel with
    // linear = cmd_vel_max_speed * action (a robot's command).
    pnh.param<std::string>("command", command_, "action");
    pnh.param("cmd_vel_max_speed", max_speed_, 2.0);
    int wait = 0;
    pnh.param("wait_for_command_subscribers", wait, wait);
    wait_ = msspr::ros_bridge::CommandSubscriberWait(wait);
    if (command_ != "action" && command_ != "cmd_vel")
      throw std::invalid_argument("~command must be action or cmd_vel, got '" + command_ + "'");
    ROS_INFO_STREAM("msspr_expert_node parameters:\n  maze: "
                    << maze << "\n  mode: " << mode_ << "\n  noise_std: " << noise_
                    << "\n  seed: " << seed_ << "\n  command: " << command_
                    << "\n  cmd_vel_max_speed: " << max_speed_
                    << "\n  wait_for_command_subscribers: " << wait);
    map_ = std::make_unique<msspr::sim::MazeMap>(msspr::sim::MazeMap::FromName(maze));
    if (mode_ == "goal") {
      goal_expert_ =
          std::make_unique<msspr::sim::GoalExpert>(*map_, noise_, static_cast<uint64_t>(seed_));
    } else {
      kind_ = msspr::sim::ParseDatasetKind(mode_);  // throws on anything else
    }
    if (command_ == "cmd_vel")
      cmd_vel_pub_ = nh_.advertise<geometry_msgs::Twist>("cmd_vel", 10);
    else
      action_pub_ = nh_.advertise<msspr::Action>("action", msspr::ros_bridge::kStepTopicQueue);
    obs_sub_ = nh_.subscribe("observation", 10, &ExpertNode::OnObservation, this,
                             ros::TransportHints().tcpNoDelay());
    episode_sub_ = nh_.subscribe("episode", 10, &ExpertNode::OnEpisode, this);
  }

 private:
  void OnEpisode(const msspr::EpisodeInfo::ConstPtr& info) {
    if (mode_ == "goal") return;
    episodes_[info->episode_id] =
        std::make_unique<msspr::sim::CollectionExpert>(*map_, kind_, noise_, info->seed);
    while (episodes_.size() > 4) episodes_.erase(episodes_.begin());
    auto it = pending_.find(info->episode_id);
    if (it != pending_.end()) {
      auto obs = it->second;
      pending_.erase(it);
      OnObservation(obs);
    }
  }

  void OnObservation(const msspr::Observation::ConstPtr& obs) {
    if (obs->state.size() != 2 || !msspr::ros_bridge::AllFinite(obs->state)) {
      ROS_ERROR_STREAM_THROTTLE(1.0, "msspr_expert_node: rejected observation with "
                                         << obs->state.size() << " values (expected 2 finite)");
      ++rejected_;
      return;
    }
    if (!wait_.Ready({command_ == "cmd_vel" ? &cmd_vel_pub_ : &action_pub_}, "msspr_expert_node"))
      return;
    // A re-sent observation gets the same answer (the noise stream must not advance).
    if (answered_ && obs->episode_id == last_episode_ && obs->step == last_step_) {
      Send(last_action_);
      return;
    }
    Eigen::Vector2d a;
    const Eigen::Vector2d s(obs->state[0], obs->state[1]);
    if (mode_ == "goal") {
      if (obs->goal.size() != 2 || !msspr::ros_bridge::AllFinite(obs->goal)) {
        ROS_ERROR_THROTTLE(1.0, "msspr_expert_node: observation without a valid goal");
        ++rejected_;
        return;
      }
      a = goal_expert_->Act(s, Eigen::Vector2d(obs->goal[0], obs->goal[1]));
    } else {
      auto it = episodes_.find(obs->episode_id);
      if (it == episodes_.end()) {  // its EpisodeInfo has not arrived yet
        pending_[obs->episode_id] = obs;
        return;
      }
      a = it->second->Act(s);
    }
    msspr::Action msg;
    msg.header.stamp = obs->header.stamp;
    msg.episode_id = obs->episode_id;
    msg.step = obs->step;
    msg.action = {static_cast<float>(a.x()), static_cast<float>(a.y())};
    Send(msg);
    last_action_ = msg;
    last_episode_ = obs->episode_id;
    last_step_ = obs->step;
    answered_ = true;
  }

  void Send(const msspr::Action& msg) {
    if (command_ != "cmd_vel") {
      action_pub_.publish(msg);
      return;
    }
    geometry_msgs::Twist t;
    t.linear.x = max_speed_ * static_cast<double>(msg.action[0]);
    t.linear.y = max_speed_ * static_cast<double>(msg.action[1]);
    cmd_vel_pub_.publish(t);
  }

  ros::NodeHandle nh_;
  std::string mode_, command_;
  double max_speed_ = 2.0;
  ros::Publisher cmd_vel_pub_;
  double noise_ = 0.0;
  int seed_ = 0;
  msspr::sim::DatasetKind kind_ = msspr::sim::DatasetKind::kNavigate;
  std::unique_ptr<msspr::sim::MazeMap> map_;
  std::unique_ptr<msspr::sim::GoalExpert> goal_expert_;
  std::map<uint32_t, std::unique_ptr<msspr::sim::CollectionExpert>> episodes_;
  std::map<uint32_t, msspr::Observation::ConstPtr> pending_;
  ros::Publisher action_pub_;
  ros::Subscriber obs_sub_, episode_sub_;
  msspr::ros_bridge::CommandSubscriberWait wait_;
  msspr::Action last_action_;
  uint32_t last_episode_ = 0, last_step_ = 0;
  bool answered_ = false;
  uint64_t rejected_ = 0;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "msspr_expert_node");
  ros::NodeHandle nh, pnh("~");
  try {
    ExpertNode node(nh, pnh);
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL_STREAM("msspr_expert_node: " << e.what());
    return 1;
  }
  return 0;
}
