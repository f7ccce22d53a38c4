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
#include "msspr_sim_nodes/robot_model.h"

namespace msspr::ros_bridge {

namespace {

constexpr int kObs = sim::CubeEnv::kObservationSize;
constexpr int kAct = sim::CubeEnv::kActionSize;

// Joint values q [num_dofs] of the ArmModel from MuJoCo's qpos (arm 0-5, left finger 6).
Eigen::VectorXd ArmQ(const sim::CubeEnv& env) {
  const std::vector<double> qpos = env.Qpos();
  const int n = env.arm().num_dofs();
  Eigen::VectorXd q(n);
  for (int i = 0; i < n; ++i) q[i] = qpos[static_cast<size_t>(i)];
  return q;
}
}  // namespace

CubeStandardMessages MakeCubeStandardMessages(const sim::CubeEnv& env, const ros::Time& stamp,
                                              const std::string& world_frame,
                                              const std::string& cube_frame,
                                              const std::string& goal_frame) {
  CubeStandardMessages out;
  const auto& arm = env.arm();
  const auto& links = arm.links();
  const Eigen::VectorXd q = ArmQ(env);
  const std::vector<Eigen::Isometry3d> poses = arm.LinkPoses(q);
  const std::vector<double> qvel = env.Qvel();
  sensor_msgs::JointState& js = out.joint_states;
  js.header.stamp = stamp;
  for (size_t i = 1; i < links.size(); ++i) {
    const auto& l = links[i];
    if (l.type == sim::ArmModel::JointType::kFixed) continue;
    js.name.push_back(l.joint);
    js.position.push_back(l.multiplier * q[l.dof] + l.offset);
    // qvel: arm 0-5, then the fingers (the mimic one follows the left's dof)
    js.velocity.push_back(l.multiplier * qvel[static_cast<size_t>(l.dof)]);
    out.transforms.push_back(ToTf(poses[static_cast<size_t>(l.parent)].inverse() * poses[i], stamp,
                                  links[static_cast<size_t>(l.parent)].name, l.name));
  }
  // The gripper: the first finger joint that is not a mimic (its dof drives the opening).
  out.gripper_state.header.stamp = stamp;
  const sim::CubeEnv::Observation obs = env.GetObservation();
  for (size_t i = 0; i < js.name.size(); ++i) {
    if (i < 6) continue;  // the arm's six joints come first
    out.gripper_state.name = {js.name[i]};
    out.gripper_state.position = {js.position[i]};
    out.gripper_state.velocity = {js.velocity[i]};
    out.gripper_state.effort = {50.0 * static_cast<double>(obs[18])};
    break;
  }
  const std::vector<double> qpos = env.Qpos();
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
  // The pinch pose as the arm's controller measures it (as ur_robot_driver's
  // tool0_controller frame): the simulator's own pinch site, which the
  // observation reads. It comes from the physics' last kinematics pass, one
  // 2 ms substep before the joint positions, so it differs from the URDF's
  // pinch link (forward kinematics of joint_states) by up to about a millimetre.
  Eigen::Isometry3d pinch = Eigen::Isometry3d::Identity();
  pinch.translation() = env.PinchPosition();
  pinch.linear() = env.PinchRotation();
  out.transforms.push_back(ToTf(pinch, stamp, world_frame, kCubePinchControllerFrame));
  return out;
}

std::vector<geometry_msgs::TransformStamped> MakeCubeStaticTransforms(const sim::CubeEnv& env) {
  const auto& links = env.arm().links();
  const std::vector<Eigen::Isometry3d> poses = env.arm().LinkPoses(ArmQ(env));
  std::vector<geometry_msgs::TransformStamped> tfs;
  for (size_t i = 1; i < links.size(); ++i) {
    if (links[i].type != sim::ArmModel::JointType::kFixed) continue;
    const auto& parent = links[static_cast<size_t>(links[i].parent)];
    tfs.push_back(ToTf(poses[static_cast<size_t>(links[i].parent)].inverse() * poses[i],
                       ros::Time(0), parent.name, links[i].name));
  }
  return tfs;
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
  // The URDF: robot_description when set (written to a temporary file for
  // CubeEnv, which parses a path), else ~urdf, then served as robot_description.
  const RobotDescription desc =
      LoadRobotDescription(nh_, options_.robot_description, options_.urdf);
  const std::string &key = desc.key, &xml = desc.xml, &source = desc.source;
  sim::CubeEnvOptions env_opt;
  env_opt.enable_rendering = pixels();
  env_opt.image_size = options_.image_size;
  env_opt.max_episode_steps = options_.max_episode_steps;
  env_opt.scene.pixel_style = pixels();
  const std::string tmp = "/tmp/msspr_cube_sim_" + std::to_string(getpid()) + ".urdf";
  {
    std::ofstream f(tmp);
    f << xml;
    if (!f) throw std::runtime_error("cannot write " + tmp);
  }
  env_opt.urdf_path = tmp;
  try {
    env_ = std::make_unique<sim::CubeEnv>(env_opt);
  } catch (const std::exception& e) {
    std::remove(tmp.c_str());
    throw std::runtime_error(source + ": " + e.what());
  }
  std::remove(tmp.c_str());
  const auto& root = env_->arm().links().front().name;
  if (root != options_.world_frame)
    throw std::invalid_argument(source + ": the URDF's root link is '" + root +
                                "', ~world_frame is '" + options_.world_frame + "'");
  ROS_INFO_STREAM_NAMED(
      "msspr_sim", "robot_description " << key << " (from " << source << "): robot '"
                                        << env_->arm().name() << "', " << env_->arm().links().size()
                                        << " links; simulated from the same text");

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
  pending_twists_.push_back(*msg);
  MaybeStepStandard();
}

void CubeSimNode::OnGripperCommand(const std_msgs::Float64MultiArray::ConstPtr& msg) {
  pending_grips_.push_back(msg->data.empty() ? std::nan("") : msg->data[0]);
  MaybeStepStandard();
}

void CubeSimNode::MaybeStepStandard() {
  constexpr size_t kMaxPending = 10;
  while (pending_twists_.size() > kMaxPending) pending_twists_.pop_front();
  while (pending_grips_.size() > kMaxPending) pending_grips_.pop_front();
  while (!pending_twists_.empty() && !pending_grips_.empty()) {
    const geometry_msgs::TwistStamped twist = pending_twists_.front();
    const double grip = pending_grips_.front();
    pending_twists_.pop_front();
    pending_grips_.pop_front();
    // Stamped for an earlier observation (a zero stamp counts as now).
    if (!twist.header.stamp.isZero() && twist.header.stamp + ros::Duration(1e-6) < Now()) {
      if (stale_standard_commands_++ == 0 || stale_standard_commands_ % 100 == 0)
        ROS_WARN_STREAM_NAMED(
            "msspr_sim", "ee_twist stamped " << twist.header.stamp << " for an observation before "
                                             << Now() << ": dropped with its gripper command ("
                                             << stale_standard_commands_ << " so far)");
      continue;
    }
    // The same checks, counters and stepping as an msspr/Action for the current step.
    auto a = boost::make_shared<msspr::Action>();
    a->header.stamp = Now();
    a->episode_id = static_cast<uint32_t>(std::max<int64_t>(episode_id_, 0));
    a->step = EpisodeStep();
    const auto& t = twist.twist;
    a->action = {static_cast<float>(t.linear.x / kCubeEeSpeed),
                 static_cast<float>(t.linear.y / kCubeEeSpeed),
                 static_cast<float>(t.linear.z / kCubeEeSpeed),
                 static_cast<float>(t.angular.z / kCubeEeYawRate), static_cast<float>(grip)};
    OnAction(a);
  }
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
