#include "msspr_sim_nodes/arm_task_sim_node.h"

#include <visualization_msgs/MarkerArray.h>

#include <cmath>
#include <stdexcept>

#include "msspr_bags/dataset_bag.h"
#include "msspr_bridge/msg_conversion.h"
#include "msspr_sim/package_files.h"

namespace msspr::ros_bridge {

// --- the shared node --------------------------------------------------------------------

ArmTaskSimNodeOptions LoadArmTaskSimNodeOptions(const ros::NodeHandle& pnh, sim::EnvId id) {
  ArmTaskSimNodeOptions o;
  if (!sim::IsPuzzle(id) && id != sim::EnvId::kCubeDouble && id != sim::EnvId::kCubeSingle &&
      id != sim::EnvId::kScene)
    throw std::invalid_argument("LoadArmTaskSimNodeOptions: '" + sim::EnvIdName(id) +
                                "' is not cube-single, puzzle-3x3, puzzle-4x4, cube-double or "
                                "scene");
  o.env = id;
  o.max_episode_steps = sim::EvalEpisodeCap(id);
  ROS_INFO_STREAM_NAMED("msspr_sim",
                        "msspr_sim_node (env " << sim::EnvIdName(id) << ") parameters:");
  LoadSimNodeCommonOptions(pnh, &o);
  o.max_episode_steps = SimParam(pnh, "max_episode_steps", o.max_episode_steps);
  o.initial_task = SimParam(pnh, "initial_task", o.initial_task);
  o.world_frame = SimParam(pnh, "world_frame", o.world_frame);
  o.robot_description = SimParam(pnh, "robot_description", o.robot_description);
  o.standard_topics = SimParam(pnh, "standard_topics", o.standard_topics);
  o.urdf = SimParam(pnh, "urdf", sim::DefaultArmUrdf());
  if (o.initial_task != -1 && (o.initial_task < 1 || o.initial_task > 5))
    throw std::invalid_argument("~initial_task must be -1 (none) or 1..5, got " +
                                std::to_string(o.initial_task));
  if (o.max_episode_steps < 1)
    throw std::invalid_argument("~max_episode_steps must be >= 1, got " +
                                std::to_string(o.max_episode_steps));
  if (o.world_frame.empty()) throw std::invalid_argument("~world_frame must be non-empty");
  return o;
}

template <class Env>
ArmTaskSimNode<Env>::ArmTaskSimNode(ros::NodeHandle nh, ros::NodeHandle pnh,
                                    const ArmTaskSimNodeOptions& options,
                                    const typename Env::Options& env_options)
    : SimNodeBase(nh, pnh, options, sim::ArmEnv::kActionSize,
                  env_options.scene.timestep * env_options.substeps, sim::EnvLabel(options.env)),
      options_(options) {
  typename Env::Options eo = env_options;
  eo.enable_rendering = pixels();
  eo.scene.pixel_style = pixels();  // OGBench's visual look (translucent arm, goals hidden)
  eo.image_size = options_.image_size;
  eo.max_episode_steps = options_.max_episode_steps;
  env_ = MakeArmEnv<Env>(nh_, options_.robot_description, options_.urdf, options_.world_frame, eo);
  joint_state_pub_ = nh_.advertise<sensor_msgs::JointState>("joint_states", kStepTopicQueue);
  if (options_.standard_topics) {
    gripper_state_pub_ =
        nh_.advertise<sensor_msgs::JointState>("gripper/joint_states", kStepTopicQueue);
    goal_obs_pub_ =
        nh_.advertise<std_msgs::Float64MultiArray>("goal_observation", 1, /*latch=*/true);
    ee_twist_sub_ = nh_.subscribe("ee_twist", 10, &ArmTaskSimNode::OnEeTwist, this,
                                  ros::TransportHints().tcpNoDelay());
    gripper_cmd_sub_ = nh_.subscribe("gripper_command", 10, &ArmTaskSimNode::OnGripperCommand, this,
                                     ros::TransportHints().tcpNoDelay());
  }
  static_tf_.sendTransform(MakeArmStaticTransforms(env_->arm()));
}

template <class Env>
ArmTaskSimNode<Env>::~ArmTaskSimNode() = default;

template <class Env>
void ArmTaskSimNode<Env>::PublishRobot(const ros::Time& stamp) {
  const ArmStandardMessages m = MakeArmStandardMessages(
      env_->arm(), env_->Qpos(), env_->Qvel(), static_cast<double>(env_->GetObservation()[18]),
      env_->PinchPosition(), env_->PinchRotation(), stamp, options_.world_frame);
  tf_.sendTransform(m.transforms);
  if (options_.standard_topics) gripper_state_pub_.publish(m.gripper_state);
  joint_state_pub_.publish(m.joint_states);
  PublishObjects(stamp);
}

template <class Env>
void ArmTaskSimNode<Env>::OnEeTwist(const geometry_msgs::TwistStamped::ConstPtr& msg) {
  standard_commands_.AddTwist(*msg);
  MaybeStepStandard();
}

template <class Env>
void ArmTaskSimNode<Env>::OnGripperCommand(const std_msgs::Float64MultiArray::ConstPtr& msg) {
  standard_commands_.AddGrip(msg->data.empty() ? std::nan("") : msg->data[0]);
  MaybeStepStandard();
}

template <class Env>
void ArmTaskSimNode<Env>::MaybeStepStandard() {
  standard_commands_.Drain(Now(), [this](const std::vector<float>& action) {
    auto a = boost::make_shared<msspr::Action>();
    a->header.stamp = Now();
    a->episode_id = static_cast<uint32_t>(std::max<int64_t>(episode_id_, 0));
    a->step = EpisodeStep();
    a->action = action;
    OnAction(a);
  });
}

template <class Env>
void ArmTaskSimNode<Env>::StartEpisode(int task_id, uint64_t seed) {
  const auto o = env_->ResetToTask(task_id, seed);
  const auto& g = env_->goal_observation();
  goal_.assign(g.begin(), g.end());
  BeginEpisode(task_id, seed, "", std::vector<float>(o.begin(), o.end()));
}

template <class Env>
void ArmTaskSimNode<Env>::PublishGoalObservation() {
  if (!options_.standard_topics || goal_.empty()) return;
  std_msgs::Float64MultiArray g;
  g.data.assign(goal_.begin(), goal_.end());
  goal_obs_pub_.publish(g);
}

template <class Env>
void ArmTaskSimNode<Env>::BeginEpisode(int task_id, uint64_t seed, const std::string& split,
                                       const std::vector<float>& start) {
  std::function<std::vector<uint8_t>()> render_goal;
  if (!goal_.empty() && pixels()) render_goal = [this] { return env_->goal_image(); };
  PublishGoalObservation();  // before the episode's first observation
  AnnounceEpisode(task_id, seed, split, start, goal_, render_goal);
}

template <class Env>
msspr::Observation ArmTaskSimNode<Env>::MakeObservation() const {
  msspr::Observation o;
  o.header.stamp = Now();
  o.header.frame_id = options_.world_frame;
  o.episode_id = static_cast<uint32_t>(std::max<int64_t>(episode_id_, 0));
  o.step = static_cast<uint32_t>(env_->episode_steps());
  const auto state = env_->GetObservation();
  o.state.assign(state.begin(), state.end());
  o.goal = goal_;
  o.success = !options_.auto_reset && env_->Success();  // play data: no goal
  o.last = IsLastStep(env_->episode_steps(), options_.max_episode_steps);
  return o;
}

template <class Env>
void ArmTaskSimNode<Env>::Publish() {
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

template <class Env>
void ArmTaskSimNode<Env>::DoStep(const std::vector<double>& action) {
  typename Env::Action a;
  std::copy(action.begin(), action.end(), a.begin());
  env_->Step(a);
  ++tick_;
  ++counters_.steps;
  Publish();
}

template <class Env>
void ArmTaskSimNode<Env>::StartInitialEpisode() {
  if (options_.initial_task >= 1)
    StartEpisode(options_.initial_task, static_cast<uint64_t>(options_.seed));
}

// Collection mode: OGBench's play resets; play data has no goal, as msspr_collect writes it.
template <class Env>
void ArmTaskSimNode<Env>::StartCollectionEpisode(uint64_t seed, const std::string& split) {
  const auto o = env_->ResetForCollection(seed);
  goal_.clear();
  BeginEpisode(0, seed, split, std::vector<float>(o.begin(), o.end()));
}

template <class Env>
bool ArmTaskSimNode<Env>::Reset(msspr::Reset::Request& req, msspr::Reset::Response& res) {
  const std::string env = sim::EnvLabel(options_.env);
  if (!req.start.empty() || !req.goal.empty()) {
    res.ok = false;
    res.message = env + " takes no explicit start and goal: use task_id 1..5 (and set_goal)";
    return true;
  }
  if (req.task_id < 1 || req.task_id > 5) {
    res.ok = false;
    res.message = "task_id must be 1..5 for " + env + ", got " + std::to_string(req.task_id);
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

// A new goal observation: what the env reads of it becomes the goal (ApplyGoal).
template <class Env>
bool ArmTaskSimNode<Env>::SetGoal(msspr::SetGoal::Request& req, msspr::SetGoal::Response& res) {
  const size_t n = static_cast<size_t>(env_->observation_size());
  if (req.goal.size() != n || !AllFinite(req.goal)) {
    res.ok = false;
    res.message = "goal must be " + std::to_string(n) + " finite numbers (an observation)";
    return true;
  }
  const std::string problem = ApplyGoal(req.goal);
  if (!problem.empty()) {
    res.ok = false;
    res.message = "goal: " + problem;
    return true;
  }
  goal_ = req.goal;
  PublishGoalObservation();
  res.ok = true;
  res.message = "goal set";
  return true;
}

template class ArmTaskSimNode<sim::CubeEnv>;
template class ArmTaskSimNode<sim::PuzzleEnv>;
template class ArmTaskSimNode<sim::CubeDoubleEnv>;
template class ArmTaskSimNode<sim::SceneEnv>;

// --- the puzzles ------------------------------------------------------------------------

namespace {

sim::PuzzleEnvOptions PuzzleOptions(sim::EnvId id) {
  sim::PuzzleEnvOptions o;
  o.side = sim::PuzzleSide(id);
  return o;
}

}  // namespace

sensor_msgs::JointState MakePuzzleButtonStates(const sim::PuzzleEnv& env, const ros::Time& stamp) {
  return MakeButtonStates(env, env.num_buttons(), sim::PuzzleEnv::kProprioSize, stamp);
}

sim::LightsOutState PuzzleGoalStates(const std::vector<float>& goal, int buttons) {
  sim::LightsOutState s(static_cast<size_t>(buttons));
  for (int k = 0; k < buttons; ++k) {
    const size_t at = static_cast<size_t>(sim::PuzzleEnv::kProprioSize + 4 * k);
    s[static_cast<size_t>(k)] =
        static_cast<uint8_t>(sim::ButtonStateFromOneHot(goal.at(at), goal.at(at + 1), k));
  }
  return s;
}

PuzzleSimNode::PuzzleSimNode(ros::NodeHandle nh, ros::NodeHandle pnh,
                             const ArmTaskSimNodeOptions& options)
    : ArmTaskSimNode(nh, pnh, options, PuzzleOptions(options.env)) {
  marker_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("markers", 1, /*latch=*/true);
  if (options.standard_topics)
    buttons_pub_ = nh_.advertise<sensor_msgs::JointState>("buttons/joint_states", kStepTopicQueue);
  PublishRobot(Now());  // the arm at home, before any episode
  StartRos();
}

void AppendButtonMarkers(const std::vector<Eigen::Vector3d>& tops, const std::vector<int>& states,
                         const std::array<float, 3>& off, const std::array<float, 3>& on,
                         const std::string& frame, visualization_msgs::MarkerArray* markers) {
  for (size_t k = 0; k < tops.size(); ++k) {
    const Eigen::Vector3d& top = tops[k];
    for (int part = 0; part < 2; ++part) {
      visualization_msgs::Marker m;
      m.header.frame_id = frame;
      m.ns = part == 0 ? "button_boxes" : "button_caps";
      m.id = static_cast<int>(k);
      m.type = part == 0 ? visualization_msgs::Marker::CUBE : visualization_msgs::Marker::CYLINDER;
      m.action = visualization_msgs::Marker::ADD;
      m.pose.orientation.w = 1.0;
      m.pose.position.x = top.x();
      m.pose.position.y = top.y();
      if (part == 0) {  // the fixed box, z 0.0024-0.084
        m.pose.position.z = 0.0432;
        m.scale.x = m.scale.y = 0.096;
        m.scale.z = 0.0816;
        m.color.r = m.color.g = m.color.b = 0.15f;
      } else {  // the cap, 1.52 cm tall under the top
        m.pose.position.z = top.z() - 0.0076;
        m.scale.x = m.scale.y = 0.0344;
        m.scale.z = 0.0152;
        const std::array<float, 3>& c = states.at(k) != 0 ? on : off;
        m.color.r = c[0];
        m.color.g = c[1];
        m.color.b = c[2];
      }
      m.color.a = 1.0f;
      markers->markers.push_back(m);
    }
  }
}

// The button states; a box and a cap per button, the caps red (state 0) or blue (state 1),
// latched and sent again whenever a state changes.
void PuzzleSimNode::PublishObjects(const ros::Time& stamp) {
  if (options().standard_topics) buttons_pub_.publish(MakePuzzleButtonStates(*env_, stamp));
  if (drawn_states_ == env_->button_states()) return;
  drawn_states_ = env_->button_states();
  std::vector<Eigen::Vector3d> tops;
  for (int k = 0; k < env_->num_buttons(); ++k) tops.push_back(env_->ButtonTop(k));
  visualization_msgs::MarkerArray arr;
  AppendButtonMarkers(tops, std::vector<int>(drawn_states_.begin(), drawn_states_.end()),
                      {0.96f, 0.26f, 0.33f}, {0.35f, 0.55f, 0.91f}, options().world_frame, &arr);
  marker_pub_.publish(arr);
}

std::string PuzzleSimNode::ApplyGoal(const std::vector<float>& goal) {
  try {
    env_->SetGoalStates(PuzzleGoalStates(goal, env_->num_buttons()));
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

// --- cube-double ------------------------------------------------------------------------

namespace {

constexpr float kCubeColour[2][3] = {{0.96f, 0.26f, 0.33f}, {0.35f, 0.55f, 0.91f}};

// A cube's centre decoded from a cube-double observation (10 (centre - c), c = (0.425, 0, 0)).
Eigen::Vector3d CubeDoubleCentre(const std::vector<float>& obs, int i) {
  const size_t k = static_cast<size_t>(sim::ArmEnv::kProprioSize + 9 * i);
  return Eigen::Vector3d(0.425, 0, 0) + Eigen::Vector3d(obs[k], obs[k + 1], obs[k + 2]) / 10.0;
}

}  // namespace

CubeDoubleSimNode::CubeDoubleSimNode(ros::NodeHandle nh, ros::NodeHandle pnh,
                                     const ArmTaskSimNodeOptions& options)
    : ArmTaskSimNode(nh, pnh, options, sim::CubeDoubleEnvOptions()) {
  marker_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("markers", 1, /*latch=*/true);
  if (options.standard_topics)
    for (int i = 0; i < sim::CubeDoubleEnv::kCubes; ++i)
      cube_pose_pubs_.push_back(nh_.advertise<geometry_msgs::PoseStamped>(
          "cube_" + std::to_string(i) + "_pose", kStepTopicQueue));
  // Markers for the cubes and their goals, locked to their frames.
  visualization_msgs::MarkerArray arr;
  for (int i = 0; i < sim::CubeDoubleEnv::kCubes; ++i)
    for (int goal = 0; goal < 2; ++goal) {
      visualization_msgs::Marker m;
      m.header.frame_id = "cube_" + std::to_string(i) + (goal ? "_goal" : "");
      m.ns = goal ? "goals" : "cubes";
      m.id = i;
      m.type = visualization_msgs::Marker::CUBE;
      m.action = visualization_msgs::Marker::ADD;
      m.pose.orientation.w = 1.0;
      m.scale.x = m.scale.y = m.scale.z = 0.04;
      m.color.r = kCubeColour[i][0];
      m.color.g = kCubeColour[i][1];
      m.color.b = kCubeColour[i][2];
      m.color.a = goal ? 0.3f : 1.0f;
      m.frame_locked = true;
      arr.markers.push_back(m);
    }
  marker_pub_.publish(arr);
  PublishRobot(Now());  // the arm at home, before any episode
  StartRos();
}

// Each cube's pose (cube_<i>_pose, tf2 cube_<i>) and its goal's (tf2 cube_<i>_goal).
void CubeDoubleSimNode::PublishObjects(const ros::Time& stamp) {
  std::vector<geometry_msgs::TransformStamped> tfs;
  const std::vector<double> qpos = env_->Qpos();
  for (int i = 0; i < sim::CubeDoubleEnv::kCubes; ++i) {
    const double* q = qpos.data() + 8 + 7 * i;  // after the arm's 6 and the fingers' 2
    const std::string frame = "cube_" + std::to_string(i);
    tfs.push_back(ToTf(FreeBodyPose(q), stamp, options().world_frame, frame));
    tfs.push_back(ToTf(YawPose(env_->GoalPosition(i), env_->GoalYaw(i)), stamp,
                       options().world_frame, frame + "_goal"));
    if (options().standard_topics)
      cube_pose_pubs_[static_cast<size_t>(i)].publish(
          FreeBodyPoseMsg(q, stamp, options().world_frame));
  }
  object_tf_.sendTransform(tfs);
}

// The goal markers move to the goal observation's cube centres (and yaws).
std::string CubeDoubleSimNode::ApplyGoal(const std::vector<float>& goal) {
  for (int i = 0; i < sim::CubeDoubleEnv::kCubes; ++i) {
    const size_t k = static_cast<size_t>(sim::ArmEnv::kProprioSize + 9 * i);
    env_->SetGoal(i, CubeDoubleCentre(goal, i), std::atan2(goal[k + 8], goal[k + 7]));
  }
  return "";
}

}  // namespace msspr::ros_bridge
