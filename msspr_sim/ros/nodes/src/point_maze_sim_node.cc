#include "msspr_sim_nodes/point_maze_sim_node.h"

#include <geometry_msgs/PoseStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/JointState.h>
#include <visualization_msgs/MarkerArray.h>

#include <cmath>
#include <sstream>

#include "msspr/EpisodeInfo.h"
#include "msspr_bags/dataset_bag.h"
#include "msspr_bridge/msg_conversion.h"
#include "msspr_sim/env_id.h"
#include "msspr_sim/expert.h"
#include "msspr_sim/maze_map.h"
#include "msspr_sim_nodes/maze_markers.h"

namespace msspr::ros_bridge {

PointMazeSimNodeOptions LoadPointMazeSimNodeOptions(const ros::NodeHandle& pnh) {
  PointMazeSimNodeOptions o;
  ROS_INFO_NAMED("msspr_sim", "msspr_sim_node parameters:");
  LoadSimNodeCommonOptions(pnh, &o);
  o.maze = SimParam(pnh, "maze", o.maze);
  o.max_episode_steps = SimParam(pnh, "max_episode_steps", o.max_episode_steps);
  o.initial_task = SimParam(pnh, "initial_task", o.initial_task);
  o.world_frame = SimParam(pnh, "world_frame", o.world_frame);
  o.agent_frame = SimParam(pnh, "agent_frame", o.agent_frame);
  o.robot_description = SimParam(pnh, "robot_description", o.robot_description);
  o.publish_markers = SimParam(pnh, "publish_markers", o.publish_markers);
  o.path_length = SimParam(pnh, "path_length", o.path_length);
  o.marker_rate = SimParam(pnh, "marker_rate", o.marker_rate);
  o.standard_topics = SimParam(pnh, "standard_topics", o.standard_topics);
  o.odom_frame = SimParam(pnh, "odom_frame", o.odom_frame);
  o.base_frame = SimParam(pnh, "base_frame", o.base_frame);
  o.cmd_vel_max_speed = SimParam(pnh, "cmd_vel_max_speed", o.cmd_vel_max_speed);
  // Every parameter is checked before the node starts: a bad one is fatal (exit 1).
  auto bad = [](const std::string& name, const std::string& rule, const auto& v) {
    std::ostringstream s;
    s << "~" << name << " must be " << rule << ", got " << v;
    throw std::invalid_argument(s.str());
  };
  try {
    sim::MazeMap::FromName(o.maze);
  } catch (const std::exception&) {
    bad("maze", "arena, medium, large or giant", "'" + o.maze + "'");
  }
  if (o.initial_task < -1 || o.initial_task > 5)
    bad("initial_task", "-1 (none), 0 (random) or 1..5", o.initial_task);
  if (o.max_episode_steps < 1) bad("max_episode_steps", ">= 1", o.max_episode_steps);
  if (o.path_length < 2) bad("path_length", ">= 2", o.path_length);
  if (!(o.marker_rate > 0 && std::isfinite(o.marker_rate)))
    bad("marker_rate", "> 0 (Hz)", o.marker_rate);
  if (!(o.cmd_vel_max_speed > 0 && std::isfinite(o.cmd_vel_max_speed)))
    bad("cmd_vel_max_speed", "> 0 (m/s)", o.cmd_vel_max_speed);
  if (o.odom_frame.empty() || o.base_frame.empty() || o.odom_frame == o.base_frame)
    bad("odom_frame/~base_frame", "two different non-empty frames",
        o.odom_frame + "/" + o.base_frame);
  if (o.world_frame.empty() || o.agent_frame.empty() || o.world_frame == o.agent_frame)
    bad("world_frame/~agent_frame", "two different non-empty frames",
        o.world_frame + "/" + o.agent_frame);
  return o;
}

PointMazeSimNode::PointMazeSimNode(ros::NodeHandle nh, ros::NodeHandle pnh,
                                   const PointMazeSimNodeOptions& options)
    : SimNodeBase(nh, pnh, options, sim::PointMaze::kActionDim, 0.02 * sim::PointMaze::kFrameSkip,
                  sim::EnvLabel(sim::EnvId::kPointMaze, options.maze)),
      options_(options) {
  sim::PointMazeOptions env_opt;
  env_opt.maze = options_.maze;
  env_opt.enable_rendering = pixels();
  env_opt.image_size = options_.image_size;
  env_opt.max_episode_steps = options_.max_episode_steps;
  env_ = std::make_unique<sim::PointMaze>(env_opt);
  // The robot description, when one is loaded: checked against the MuJoCo model
  // (a mismatch is fatal), then joint_states and tf2 along its joints.
  std::string key, xml;
  if (!options_.robot_description.empty() && nh_.searchParam(options_.robot_description, key) &&
      nh_.getParam(key, xml)) {
    robot_ = CheckPointRobotUrdf(xml, "parameter " + key, *env_, options_.world_frame,
                                 options_.agent_frame);
    joint_state_pub_ = nh_.advertise<sensor_msgs::JointState>("joint_states", kStepTopicQueue);
    ROS_INFO_STREAM_NAMED("msspr_sim", "robot_description "
                                           << key << ": robot '" << robot_->name << "', "
                                           << robot_->chain.size() << " prismatic joints, radius "
                                           << robot_->radius << " m: agrees with the simulation");
  } else {
    ROS_INFO_STREAM_NAMED("msspr_sim", "no robot_description parameter: tf2 "
                                           << options_.world_frame << " -> " << options_.agent_frame
                                           << " only");
  }
  if (options_.publish_markers)
    markers_.Advertise(nh_, options_.marker_rate, options_.path_length,
                       [this](const std::deque<Eigen::Vector2d>& path, const ros::Time& stamp) {
                         return MazeMarkers(env_->map(), env_->goal(),
                                            env_->options().success_radius, path,
                                            options_.world_frame, stamp);
                       });
  if (options_.standard_topics) {
    odom_pub_ = nh_.advertise<nav_msgs::Odometry>("odom", kStepTopicQueue);
    goal_pose_pub_ = nh_.advertise<geometry_msgs::PoseStamped>("goal_pose", 1, /*latch=*/true);
    cmd_vel_sub_ = nh_.subscribe("cmd_vel", 10, &PointMazeSimNode::OnCmdVel, this,
                                 ros::TransportHints().tcpNoDelay());
  }
  StartRos();
}

void PointMazeSimNode::StartEpisode(int task_id, uint64_t seed, const std::string& split,
                                    const Eigen::Vector2d* start, const Eigen::Vector2d& goal) {
  if (start != nullptr)
    env_->Reset(*start, goal);
  else if (task_id == 0)
    env_->ResetRandom(seed);
  else
    env_->ResetToTask(task_id, seed);
  markers_.NewEpisode();
  goal_dirty_ = true;
  last_position_step_ = -1;
  AnnounceEpisode(task_id, seed, split, ToFloatVector(env_->state()), ToFloatVector(env_->goal()),
                  [this] { return env_->RenderGoal(); });
}

msspr::Observation PointMazeSimNode::MakeObservation() const {
  msspr::Observation o;
  o.header.stamp = Now();
  o.header.frame_id = options_.world_frame;
  o.episode_id = static_cast<uint32_t>(std::max<int64_t>(episode_id_, 0));
  o.step = static_cast<uint32_t>(env_->steps());
  o.state = ToFloatVector(env_->state());
  o.goal = ToFloatVector(env_->goal());
  o.success = env_->success();
  o.last = IsLastStep(env_->steps(), options_.max_episode_steps);
  return o;
}

void PointMazeSimNode::OnCmdVel(const geometry_msgs::Twist::ConstPtr& msg) {
  // The same checks, counters and stepping as an msspr/Action for the current step.
  auto a = boost::make_shared<msspr::Action>();
  a->header.stamp = Now();
  a->episode_id = static_cast<uint32_t>(std::max<int64_t>(episode_id_, 0));
  a->step = EpisodeStep();
  a->action = {static_cast<float>(msg->linear.x / options_.cmd_vel_max_speed),
               static_cast<float>(msg->linear.y / options_.cmd_vel_max_speed)};
  OnAction(a);
}

void PointMazeSimNode::PublishStandard(const msspr::Observation& o) {
  if (goal_dirty_) {
    geometry_msgs::PoseStamped g;
    g.header.stamp = o.header.stamp;
    g.header.frame_id = options_.odom_frame;
    g.pose.position.x = env_->goal().x();
    g.pose.position.y = env_->goal().y();
    g.pose.orientation.w = 1.0;
    goal_pose_pub_.publish(g);
    goal_dirty_ = false;
  }
  const Eigen::Vector2d p = env_->state();
  nav_msgs::Odometry od;
  od.header.stamp = o.header.stamp;
  od.header.frame_id = options_.odom_frame;
  od.child_frame_id = options_.base_frame;
  od.pose.pose.position.x = p.x();
  od.pose.pose.position.y = p.y();
  od.pose.pose.orientation.w = 1.0;
  // Twist in base_link (no rotation: the same axes as odom), from the last step.
  if (last_position_step_ >= 0 && env_->steps() == last_position_step_ + 1) {
    const double dt = 0.02 * sim::PointMaze::kFrameSkip;
    od.twist.twist.linear.x = (p.x() - last_position_.x()) / dt;
    od.twist.twist.linear.y = (p.y() - last_position_.y()) / dt;
  }
  last_position_ = p;
  last_position_step_ = env_->steps();
  odom_pub_.publish(od);
  geometry_msgs::TransformStamped tf;
  tf.header = od.header;
  tf.child_frame_id = options_.base_frame;
  tf.transform.translation.x = p.x();
  tf.transform.translation.y = p.y();
  tf.transform.rotation.w = 1.0;
  tf_.sendTransform(tf);
}

void PointMazeSimNode::Publish() {
  const msspr::Observation o = MakeObservation();
  PublishClock(o.header.stamp);
  if (options_.standard_topics) PublishStandard(o);
  if (robot_) {  // along the URDF's joints: joint k moves by qpos[k] = state[k] along its axis
    std::vector<geometry_msgs::TransformStamped> tfs;
    sensor_msgs::JointState js;
    js.header.stamp = o.header.stamp;
    for (size_t k = 0; k < robot_->chain.size(); ++k) {
      const auto& j = robot_->chain[k];
      const Eigen::Vector3d t = j.origin + j.axis * static_cast<double>(o.state[k]);
      geometry_msgs::TransformStamped tf;
      tf.header.stamp = o.header.stamp;
      tf.header.frame_id = j.parent;
      tf.child_frame_id = j.child;
      tf.transform.translation.x = t.x();
      tf.transform.translation.y = t.y();
      tf.transform.translation.z = t.z();
      tf.transform.rotation.w = 1.0;
      tfs.push_back(tf);
      js.name.push_back(j.name);
      js.position.push_back(o.state[k]);
    }
    tf_.sendTransform(tfs);
    joint_state_pub_.publish(js);
  } else {
    geometry_msgs::TransformStamped tf;
    tf.header.stamp = o.header.stamp;
    tf.header.frame_id = options_.world_frame;
    tf.child_frame_id = options_.agent_frame;
    tf.transform.translation.x = o.state[0];
    tf.transform.translation.y = o.state[1];
    tf.transform.rotation.w = 1.0;
    tf_.sendTransform(tf);
  }
  markers_.Update(Eigen::Vector2d(o.state[0], o.state[1]), o.header.stamp);
  if (pixels()) {
    const auto img = env_->Render();
    image_pub_.publish(ToImageMsg(img.data(), options_.image_size, o.header.stamp, kCameraFrame));
  }
  obs_pub_.publish(o);
  MarkPublished(o.last);
}

void PointMazeSimNode::DoStep(const std::vector<double>& action) {
  env_->Step(Eigen::Vector2d(action[0], action[1]));
  ++tick_;
  ++counters_.steps;
  Publish();
}

void PointMazeSimNode::StartInitialEpisode() {
  if (options_.initial_task >= 0)
    StartEpisode(options_.initial_task, static_cast<uint64_t>(options_.seed), "");
}

bool PointMazeSimNode::Reset(msspr::Reset::Request& req, msspr::Reset::Response& res) {
  const bool explicit_start = !req.start.empty() || !req.goal.empty();
  if (explicit_start) {
    if (req.start.size() != 2 || req.goal.size() != 2 || !AllFinite(req.start) ||
        !AllFinite(req.goal)) {
      res.ok = false;
      res.message = "start and goal must both be 2 finite numbers (x, y)";
      return true;
    }
    const Eigen::Vector2d s(req.start[0], req.start[1]);
    if (env_->map().IsWall(env_->map().XYToCell(s))) {
      res.ok = false;
      res.message =
          "start (" + std::to_string(s.x()) + ", " + std::to_string(s.y()) + ") is inside a wall";
      return true;
    }
    started_ = true;
    StartEpisode(req.task_id, req.seed, "", &s, Eigen::Vector2d(req.goal[0], req.goal[1]));
    res.ok = true;
    res.message = "episode " + std::to_string(episode_id_);
    res.observation = MakeObservation();
    res.goal = ToFloatVector(env_->goal());
    return true;
  }
  if (req.task_id < 0 || req.task_id > 5) {
    res.ok = false;
    res.message = "task_id must be 0 (random) or 1..5, got " + std::to_string(req.task_id);
    return true;
  }
  try {
    started_ = true;
    StartEpisode(req.task_id, req.seed, "");
  } catch (const std::exception& e) {
    res.ok = false;
    res.message = e.what();
    return true;
  }
  res.ok = true;
  res.message = "episode " + std::to_string(episode_id_);
  res.observation = MakeObservation();
  res.goal = ToFloatVector(env_->goal());
  return true;
}

bool PointMazeSimNode::SetGoal(msspr::SetGoal::Request& req, msspr::SetGoal::Response& res) {
  if (req.goal.size() != static_cast<size_t>(sim::PointMaze::kObsDim) || !AllFinite(req.goal)) {
    res.ok = false;
    res.message = "goal must be 2 finite numbers (x, y)";
    return true;
  }
  env_->SetGoal(Eigen::Vector2d(req.goal[0], req.goal[1]));
  goal_dirty_ = true;
  if (pixels()) {
    const auto goal_img = env_->RenderGoal();
    goal_image_pub_.publish(ToImageMsg(goal_img.data(), options_.image_size, Now(), kCameraFrame));
  }
  res.ok = true;
  res.message = "goal set";
  return true;
}

}  // namespace msspr::ros_bridge
