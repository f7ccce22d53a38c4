#include "msspr_sim_nodes/ant_sim_node.h"

#include <geometry_msgs/TransformStamped.h>
#include <sensor_msgs/JointState.h>
#include <visualization_msgs/MarkerArray.h>

#include <algorithm>
#include <sstream>
#include <stdexcept>

#include "msspr_bridge/msg_conversion.h"
#include "msspr_sim/package_files.h"
#include "msspr_sim_nodes/maze_markers.h"
#include "msspr_sim_nodes/robot_model.h"

namespace msspr::ros_bridge {

AntSimNodeOptions LoadAntSimNodeOptions(const ros::NodeHandle& pnh, sim::EnvId env) {
  AntSimNodeOptions o;
  o.env = env;
  ROS_INFO_STREAM_NAMED("msspr_sim",
                        "msspr_sim_node (env " << sim::EnvIdName(env) << ") parameters:");
  LoadSimNodeCommonOptions(pnh, &o);
  o.max_episode_steps = SimParam(pnh, "max_episode_steps", o.max_episode_steps);
  o.initial_task = SimParam(pnh, "initial_task", o.initial_task);
  o.world_frame = SimParam(pnh, "world_frame", o.world_frame);
  o.base_frame = SimParam(pnh, "base_frame", o.base_frame);
  o.robot_description = SimParam(pnh, "robot_description", o.robot_description);
  o.urdf = SimParam(pnh, "urdf", sim::PackageFile("msspr_sim/urdf/ant.urdf"));
  o.publish_markers = SimParam(pnh, "publish_markers", o.publish_markers);
  o.marker_rate = SimParam(pnh, "marker_rate", o.marker_rate);
  o.path_length = SimParam(pnh, "path_length", o.path_length);
  auto bad = [](const std::string& name, const std::string& rule, const auto& v) {
    std::ostringstream s;
    s << "~" << name << " must be " << rule << ", got " << v;
    throw std::invalid_argument(s.str());
  };
  if (o.observation_mode != "state")
    bad("observation_mode", "state for the ant mazes (no camera yet)",
        "'" + o.observation_mode + "'");
  if (o.auto_reset)
    bad("auto_reset",
        "false for the ant mazes: their datasets come from msspr_collect --env " +
            sim::EnvIdName(env) + " (the expert runs in process)",
        "true");
  if (o.initial_task < -1 || o.initial_task > 5)
    bad("initial_task", "-1 (none), 0 (random) or 1..5", o.initial_task);
  if (o.max_episode_steps < 1) bad("max_episode_steps", ">= 1", o.max_episode_steps);
  if (o.world_frame.empty() || o.base_frame.empty())
    bad("world_frame/~base_frame", "non-empty", "''");
  if (!(o.marker_rate > 0)) bad("marker_rate", "> 0", o.marker_rate);
  if (o.path_length < 0) bad("path_length", ">= 0", o.path_length);
  return o;
}

AntSimNode::AntSimNode(ros::NodeHandle nh, ros::NodeHandle pnh, const AntSimNodeOptions& options)
    : SimNodeBase(nh, pnh, options, sim::AntMaze::kActionDim,
                  sim::kAntTimestep * sim::AntMaze::kFrameSkip, sim::EnvLabel(options.env)),
      options_(options) {
  sim::AntMazeOptions env_opt;
  env_opt.maze = sim::AntMazeName(options_.env);
  env_opt.max_episode_steps = options_.max_episode_steps;
  env_ = std::make_unique<sim::AntMaze>(env_opt);
  // The URDF: robot_description when set, else ~urdf (then served as
  // robot_description); checked against the simulation (a mismatch is fatal).
  const RobotDescription desc =
      LoadRobotDescription(nh_, options_.robot_description, options_.urdf);
  const std::string &key = desc.key, &xml = desc.xml, &source = desc.source;
  robot_ = CheckAntUrdf(xml, source, *env_, options_.base_frame);
  ROS_INFO_STREAM_NAMED("msspr_sim", "robot_description "
                                         << key << " (from " << source << "): robot '"
                                         << robot_.name << "', " << robot_.joints.size()
                                         << " joints below the torso: agrees with the simulation");
  joint_state_pub_ = nh_.advertise<sensor_msgs::JointState>("joint_states", kStepTopicQueue);
  if (options_.publish_markers)
    markers_.Advertise(nh_, options_.marker_rate, options_.path_length,
                       [this](const std::deque<Eigen::Vector2d>& path, const ros::Time& stamp) {
                         return MazeMarkers(env_->map(), env_->goal_xy(),
                                            env_->options().success_radius, path,
                                            options_.world_frame, stamp);
                       });
  // The fixed joints (the thighs) once on /tf_static, as robot_state_publisher does.
  std::vector<geometry_msgs::TransformStamped> fixed;
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(8);
  for (const auto& j : robot_.joints)
    if (!j.revolute)
      fixed.push_back(ToTf(robot_.ChildPose(j, zero), ros::Time(0), j.parent, j.child));
  static_tf_.sendTransform(fixed);
  StartRos();
}

AntSimNode::~AntSimNode() = default;

void AntSimNode::StartEpisode(int task_id, uint64_t seed, const Eigen::Vector2d* start,
                              const Eigen::Vector2d& goal) {
  if (start != nullptr)
    env_->Reset(*start, goal, seed);
  else if (task_id == 0)
    env_->ResetRandom(seed);
  else
    env_->ResetToTask(task_id, seed);
  markers_.NewEpisode();
  AnnounceEpisode(task_id, seed, "", ToFloatVector(env_->state()), ToFloatVector(env_->goal()),
                  nullptr);
}

msspr::Observation AntSimNode::MakeObservation() const {
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

// tf2: world -> torso from the free joint, then every hinge's child link;
// joint_states of the eight hinges (kAntHingeJoints order).
void AntSimNode::PublishRobot(const ros::Time& stamp) {
  const Eigen::VectorXd qpos = env_->qpos(), qvel = env_->qvel();
  Eigen::Isometry3d torso = Eigen::Isometry3d::Identity();
  torso.translation() = qpos.head<3>();
  torso.linear() =
      Eigen::Quaterniond(qpos[3], qpos[4], qpos[5], qpos[6]).normalized().toRotationMatrix();
  std::vector<geometry_msgs::TransformStamped> tfs{
      ToTf(torso, stamp, options_.world_frame, options_.base_frame)};
  const Eigen::VectorXd hinges = qpos.segment<8>(7);
  for (const auto& j : robot_.joints)
    if (j.revolute) tfs.push_back(ToTf(robot_.ChildPose(j, hinges), stamp, j.parent, j.child));
  tf_.sendTransform(tfs);
  sensor_msgs::JointState js;
  js.header.stamp = stamp;
  for (size_t k = 0; k < sim::kAntHingeJoints.size(); ++k) {
    js.name.emplace_back(sim::kAntHingeJoints[k]);
    js.position.push_back(qpos[7 + static_cast<Eigen::Index>(k)]);
    js.velocity.push_back(qvel[6 + static_cast<Eigen::Index>(k)]);
  }
  joint_state_pub_.publish(js);
}

void AntSimNode::Publish() {
  const msspr::Observation o = MakeObservation();
  PublishClock(o.header.stamp);
  PublishRobot(o.header.stamp);
  markers_.Update(Eigen::Vector2d(o.state[0], o.state[1]), o.header.stamp);
  obs_pub_.publish(o);
  MarkPublished(o.last);
}

void AntSimNode::DoStep(const std::vector<double>& action) {
  env_->Step(
      Eigen::Map<const Eigen::VectorXd>(action.data(), static_cast<Eigen::Index>(action.size())));
  ++tick_;
  ++counters_.steps;
  Publish();
}

void AntSimNode::StartInitialEpisode() {
  if (options_.initial_task >= 0)
    StartEpisode(options_.initial_task, static_cast<uint64_t>(options_.seed), nullptr,
                 Eigen::Vector2d::Zero());
}

void AntSimNode::StartCollectionEpisode(uint64_t, const std::string&) {
  // Refused at start-up (LoadAntSimNodeOptions): never called.
  throw std::logic_error("AntSimNode: collection mode is not supported");
}

bool AntSimNode::Reset(msspr::Reset::Request& req, msspr::Reset::Response& res) {
  const bool explicit_start = !req.start.empty() || !req.goal.empty();
  Eigen::Vector2d start = Eigen::Vector2d::Zero();
  res.ok = false;
  if (explicit_start) {
    if (req.start.size() != 2 || req.goal.size() != 2 || !AllFinite(req.start) ||
        !AllFinite(req.goal)) {
      res.message = "start and goal must both be 2 finite numbers (the torso's x, y)";
      return true;
    }
    start = Eigen::Vector2d(req.start[0], req.start[1]);
    const Eigen::Vector2d& s = start;
    if (env_->map().IsWall(env_->map().XYToCell(s))) {
      res.message =
          "start (" + std::to_string(s.x()) + ", " + std::to_string(s.y()) + ") is inside a wall";
      return true;
    }
  } else if (req.task_id < 0 || req.task_id > 5) {
    res.message = "task_id must be 0 (random) or 1..5, got " + std::to_string(req.task_id);
    return true;
  }
  try {
    started_ = true;
    if (explicit_start)
      StartEpisode(req.task_id, req.seed, &start, Eigen::Vector2d(req.goal[0], req.goal[1]));
    else
      StartEpisode(req.task_id, req.seed, nullptr, Eigen::Vector2d::Zero());
  } catch (const std::exception& e) {
    res.message = e.what();
    return true;
  }
  res.ok = true;
  res.message = "episode " + std::to_string(episode_id_);
  res.observation = MakeObservation();
  res.goal = ToFloatVector(env_->goal());
  return true;
}

// A new goal: a full 29-D ant observation (qpos then qvel; success reads its x, y).
bool AntSimNode::SetGoal(msspr::SetGoal::Request& req, msspr::SetGoal::Response& res) {
  if (req.goal.size() != static_cast<size_t>(sim::AntMaze::kObsDim) || !AllFinite(req.goal)) {
    res.ok = false;
    res.message = "goal must be 29 finite numbers (an ant-maze observation: qpos, then qvel)";
    return true;
  }
  Eigen::VectorXd g(sim::AntMaze::kObsDim);
  for (int i = 0; i < sim::AntMaze::kObsDim; ++i) g[i] = req.goal[static_cast<size_t>(i)];
  env_->SetGoal(g);
  markers_.GoalMoved();
  res.ok = true;
  res.message = "goal set";
  return true;
}

}  // namespace msspr::ros_bridge
