#include "msspr_sim_nodes/cube_sim_node.h"

#include <geometry_msgs/TransformStamped.h>
#include <sensor_msgs/JointState.h>
#include <unistd.h>
#include <visualization_msgs/MarkerArray.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <sstream>

#include "msspr/EpisodeInfo.h"
#include "msspr_bags/dataset_bag.h"
#include "msspr_bridge/msg_conversion.h"
#include "msspr_sim/env_id.h"
#include "msspr_sim/package_files.h"
#include "msspr_sim_nodes/arm_messages.h"

namespace msspr::ros_bridge {

namespace {

constexpr int kObs = sim::CubeEnv::kObservationSize;
constexpr int kAct = sim::CubeEnv::kActionSize;

}  // namespace

CubeStandardMessages MakeCubeStandardMessages(const sim::CubeEnv& env, const ros::Time& stamp,
                                              const std::string& world_frame,
                                              const std::string& cube_frame,
                                              const std::string& goal_frame) {
  const std::vector<double> qpos = env.Qpos();
  ArmStandardMessages arm = MakeArmStandardMessages(
      env.arm(), qpos, env.Qvel(), static_cast<double>(env.GetObservation()[18]),
      env.PinchPosition(), env.PinchRotation(), stamp, world_frame);
  CubeStandardMessages out;
  out.joint_states = std::move(arm.joint_states);
  out.gripper_state = std::move(arm.gripper_state);
  out.transforms = std::move(arm.transforms);
  out.cube_pose.header.stamp = stamp;
  out.cube_pose.header.frame_id = world_frame;
  out.cube_pose.pose.position.x = qpos[8];
  out.cube_pose.pose.position.y = qpos[9];
  out.cube_pose.pose.position.z = qpos[10];
  out.cube_pose.pose.orientation.w = qpos[11];
  out.cube_pose.pose.orientation.x = qpos[12];
  out.cube_pose.pose.orientation.y = qpos[13];
  out.cube_pose.pose.orientation.z = qpos[14];
  Eigen::Isometry3d cube = Eigen::Isometry3d::Identity();
  cube.translation() = Eigen::Vector3d(qpos[8], qpos[9], qpos[10]);
  cube.linear() =
      Eigen::Quaterniond(qpos[11], qpos[12], qpos[13], qpos[14]).normalized().toRotationMatrix();
  out.transforms.push_back(ToTf(cube, stamp, world_frame, cube_frame));
  Eigen::Isometry3d goal = Eigen::Isometry3d::Identity();
  goal.translation() = env.GoalPosition();
  goal.linear() = Eigen::AngleAxisd(env.GoalYaw(), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  out.transforms.push_back(ToTf(goal, stamp, world_frame, goal_frame));
  return out;
}

std::vector<geometry_msgs::TransformStamped> MakeCubeStaticTransforms(const sim::CubeEnv& env) {
  return MakeArmStaticTransforms(env.arm());
}

CubeSimNodeOptions LoadCubeSimNodeOptions(const ros::NodeHandle& pnh) {
  CubeSimNodeOptions o;
  ROS_INFO_NAMED("msspr_sim", "msspr_sim_node (env cube-single) parameters:");
  LoadSimNodeCommonOptions(pnh, &o);
  o.max_episode_steps = SimParam(pnh, "max_episode_steps", o.max_episode_steps);
  o.initial_task = SimParam(pnh, "initial_task", o.initial_task);
  o.world_frame = SimParam(pnh, "world_frame", o.world_frame);
  o.cube_frame = SimParam(pnh, "cube_frame", o.cube_frame);
  o.goal_frame = SimParam(pnh, "goal_frame", o.goal_frame);
  o.robot_description = SimParam(pnh, "robot_description", o.robot_description);
  o.standard_topics = SimParam(pnh, "standard_topics", o.standard_topics);
  o.urdf = SimParam(pnh, "urdf", sim::DefaultArmUrdf());
  auto bad = [](const std::string& name, const std::string& rule, const auto& v) {
    std::ostringstream s;
    s << "~" << name << " must be " << rule << ", got " << v;
    throw std::invalid_argument(s.str());
  };
  if (o.initial_task != -1 && (o.initial_task < 1 || o.initial_task > 5))
    bad("initial_task", "-1 (none) or 1..5", o.initial_task);
  if (o.max_episode_steps < 1) bad("max_episode_steps", ">= 1", o.max_episode_steps);
  if (o.world_frame.empty() || o.cube_frame.empty() || o.goal_frame.empty())
    bad("world_frame/~cube_frame/~goal_frame", "non-empty", "''");
  return o;
}

CubeSimNode::CubeSimNode(ros::NodeHandle nh, ros::NodeHandle pnh, const CubeSimNodeOptions& options)
    : SimNodeBase(nh, pnh, options, kAct,
                  sim::CubeSceneOptions().timestep * sim::CubeEnvOptions().substeps,
                  sim::EnvLabel(sim::EnvId::kCubeSingle)),
      options_(options) {
  sim::CubeEnvOptions env_opt;
  env_opt.enable_rendering = pixels();
  env_opt.image_size = options_.image_size;
  env_opt.max_episode_steps = options_.max_episode_steps;
  env_opt.scene.pixel_style = pixels();
  env_ = MakeArmEnv<sim::CubeEnv>(nh_, options_.robot_description, options_.urdf,
                                  options_.world_frame, env_opt);

  joint_state_pub_ = nh_.advertise<sensor_msgs::JointState>("joint_states", kStepTopicQueue);
  marker_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("markers", 1, /*latch=*/true);
  if (options_.standard_topics) {
    gripper_state_pub_ =
        nh_.advertise<sensor_msgs::JointState>("gripper/joint_states", kStepTopicQueue);
    cube_pose_pub_ = nh_.advertise<geometry_msgs::PoseStamped>("cube_pose", kStepTopicQueue);
    goal_obs_pub_ =
        nh_.advertise<std_msgs::Float64MultiArray>("goal_observation", 1, /*latch=*/true);
    ee_twist_sub_ = nh_.subscribe("ee_twist", 10, &CubeSimNode::OnEeTwist, this,
                                  ros::TransportHints().tcpNoDelay());
    gripper_cmd_sub_ = nh_.subscribe("gripper_command", 10, &CubeSimNode::OnGripperCommand, this,
                                     ros::TransportHints().tcpNoDelay());
  }
  PublishStaticFrames();
  PublishRobot(Now());  // the arm at home, before any episode
  StartRos();
}

CubeSimNode::~CubeSimNode() = default;

// Fixed URDF joints once on /tf_static (as robot_state_publisher does), and
// latched markers for the cube and the goal, locked to their frames.
void CubeSimNode::PublishStaticFrames() {
  static_tf_.sendTransform(MakeCubeStaticTransforms(*env_));

  visualization_msgs::MarkerArray arr;
  for (int k = 0; k < 2; ++k) {
    visualization_msgs::Marker m;
    m.header.frame_id = k == 0 ? options_.cube_frame : options_.goal_frame;
    m.ns = k == 0 ? "cube" : "goal";
    m.type = visualization_msgs::Marker::CUBE;
    m.action = visualization_msgs::Marker::ADD;
    m.pose.orientation.w = 1.0;
    m.scale.x = m.scale.y = m.scale.z = 0.04;
    m.color.r = 0.96f;
    m.color.g = 0.26f;
    m.color.b = 0.33f;
    m.color.a = k == 0 ? 1.0f : 0.3f;
    m.frame_locked = true;
    arr.markers.push_back(m);
  }
  marker_pub_.publish(arr);
}

// joint_states for every moving URDF joint (the mimic finger included) and
// tf2 for the moving joints, the cube and the goal marker.
void CubeSimNode::PublishRobot(const ros::Time& stamp) {
  const CubeStandardMessages m = MakeCubeStandardMessages(*env_, stamp, options_.world_frame,
                                                          options_.cube_frame, options_.goal_frame);
  tf_.sendTransform(m.transforms);
  if (options_.standard_topics) {
    cube_pose_pub_.publish(m.cube_pose);
    gripper_state_pub_.publish(m.gripper_state);
  }
  joint_state_pub_.publish(m.joint_states);
}

void CubeSimNode::PublishGoalObservation() {
  if (!options_.standard_topics || goal_.empty()) return;
  std_msgs::Float64MultiArray g;
  g.data.assign(goal_.begin(), goal_.end());
  goal_obs_pub_.publish(g);
}

void CubeSimNode::OnEeTwist(const geometry_msgs::TwistStamped::ConstPtr& msg) {
  standard_commands_.AddTwist(*msg);
  MaybeStepStandard();
}

void CubeSimNode::OnGripperCommand(const std_msgs::Float64MultiArray::ConstPtr& msg) {
  standard_commands_.AddGrip(msg->data.empty() ? std::nan("") : msg->data[0]);
  MaybeStepStandard();
}

void CubeSimNode::MaybeStepStandard() {
  standard_commands_.Drain(Now(), [this](const std::vector<float>& action) {
    // The same checks, counters and stepping as an msspr/Action for the current step.
    auto a = boost::make_shared<msspr::Action>();
    a->header.stamp = Now();
    a->episode_id = static_cast<uint32_t>(std::max<int64_t>(episode_id_, 0));
    a->step = EpisodeStep();
    a->action = action;
    OnAction(a);
  });
}

void CubeSimNode::StartEpisode(int task_id, uint64_t seed) {
  const sim::CubeEnv::Observation o = env_->ResetToTask(task_id, seed);
  goal_.assign(env_->goal_observation().begin(), env_->goal_observation().end());
  BeginEpisode(task_id, seed, "", o);
}

// After a reset: the episode's EpisodeInfo, its goal image (none without a goal), the first
// observation.
void CubeSimNode::BeginEpisode(int task_id, uint64_t seed, const std::string& split,
                               const sim::CubeEnv::Observation& start) {
  std::function<std::vector<uint8_t>()> render_goal;
  if (!goal_.empty()) render_goal = [this] { return env_->goal_image(); };
  PublishGoalObservation();  // before the episode's first observation
  AnnounceEpisode(task_id, seed, split, std::vector<float>(start.begin(), start.end()), goal_,
                  render_goal);
}

msspr::Observation CubeSimNode::MakeObservation() const {
  msspr::Observation o;
  o.header.stamp = Now();
  o.header.frame_id = options_.world_frame;
  o.episode_id = static_cast<uint32_t>(std::max<int64_t>(episode_id_, 0));
  o.step = static_cast<uint32_t>(env_->episode_steps());
  const sim::CubeEnv::Observation s = env_->GetObservation();
  o.state.assign(s.begin(), s.end());
  o.goal = goal_;
  o.success = !options_.auto_reset && env_->Success();  // play data: no goal
  o.last = IsLastStep(env_->episode_steps(), options_.max_episode_steps);
  return o;
}

void CubeSimNode::Publish() {
  const msspr::Observation o = MakeObservation();
  PublishClock(o.header.stamp);
  PublishRobot(o.header.stamp);
  if (pixels()) {
    const auto img = env_->Render();
    image_pub_.publish(ToImageMsg(img.data(), options_.image_size, o.header.stamp, kCameraFrame));
  }
  obs_pub_.publish(o);
  MarkPublished(o.last);
}

void CubeSimNode::DoStep(const std::vector<double>& action) {
  sim::CubeEnv::Action a;
  std::copy(action.begin(), action.end(), a.begin());
  env_->Step(a);
  ++tick_;
  ++counters_.steps;
  Publish();
}

void CubeSimNode::StartInitialEpisode() {
  if (options_.initial_task >= 1)
    StartEpisode(options_.initial_task, static_cast<uint64_t>(options_.seed));
}

// Collection mode: OGBench's play resets (a random arm pose, the cube at a
// random place); play data has no goal, as msspr_collect --env cube-single
// writes it (the env's goal marker is the oracle's first target, not sent).
void CubeSimNode::StartCollectionEpisode(uint64_t seed, const std::string& split) {
  const sim::CubeEnv::Observation o = env_->ResetForCollection(seed);
  goal_.clear();
  BeginEpisode(0, seed, split, o);
}

bool CubeSimNode::Reset(msspr::Reset::Request& req, msspr::Reset::Response& res) {
  if (!req.start.empty() || !req.goal.empty()) {
    res.ok = false;
    res.message = "cube-single takes no explicit start and goal: use task_id 1..5 (and set_goal)";
    return true;
  }
  if (req.task_id < 1 || req.task_id > 5) {
    res.ok = false;
    res.message = "task_id must be 1..5 for cube-single, got " + std::to_string(req.task_id);
    return true;
  }
  try {
    started_ = true;
    StartEpisode(req.task_id, req.seed);
  } catch (const std::exception& e) {
    res.ok = false;
    res.message = e.what();
    return true;
  }
  res.ok = true;
  res.message = "episode " + std::to_string(episode_id_);
  res.observation = MakeObservation();
  res.goal = goal_;
  return true;
}

// A new goal observation (28 numbers): the goal marker moves to its cube
// position and yaw, so success and tf2 follow it; in pixels mode the goal
// image is rendered for it (the scene posed as the goal) and published.
bool CubeSimNode::SetGoal(msspr::SetGoal::Request& req, msspr::SetGoal::Response& res) {
  if (req.goal.size() != static_cast<size_t>(kObs) || !AllFinite(req.goal)) {
    res.ok = false;
    res.message = "goal must be 28 finite numbers (a cube-single observation)";
    return true;
  }
  goal_ = req.goal;
  sim::CubeEnv::Observation g;
  std::copy(goal_.begin(), goal_.end(), g.begin());
  env_->SetGoalObservation(g);
  PublishGoalObservation();
  if (pixels())
    goal_image_pub_.publish(
        ToImageMsg(env_->goal_image().data(), options_.image_size, Now(), kCameraFrame));
  res.ok = true;
  res.message = "goal set";
  return true;
}

}  // namespace msspr::ros_bridge
