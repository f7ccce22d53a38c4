#include "msspr_sim_nodes/puzzle_sim_node.h"

#include <visualization_msgs/MarkerArray.h>

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "msspr_bags/dataset_bag.h"
#include "msspr_bridge/msg_conversion.h"
#include "msspr_sim/package_files.h"
#include "msspr_sim_nodes/arm_messages.h"

namespace msspr::ros_bridge {
namespace {

constexpr int kAct = sim::PuzzleEnv::kActionSize;

}  // namespace

sensor_msgs::JointState MakePuzzleButtonStates(const sim::PuzzleEnv& env, const ros::Time& stamp) {
  sensor_msgs::JointState js;
  js.header.stamp = stamp;
  const sim::PuzzleEnv::Observation o = env.GetObservation();
  for (int k = 0; k < env.num_buttons(); ++k) {
    js.name.push_back("buttonbox_joint_" + std::to_string(k));
    js.position.push_back(env.ButtonJoint(k));
    js.velocity.push_back(o[static_cast<size_t>(sim::PuzzleEnv::kProprioSize + 4 * k + 3)]);
    js.effort.push_back(env.button_states()[static_cast<size_t>(k)]);
  }
  return js;
}

sim::LightsOutState PuzzleGoalStates(const std::vector<float>& goal, int buttons) {
  sim::LightsOutState s(static_cast<size_t>(buttons));
  for (int k = 0; k < buttons; ++k) {
    const float a = goal.at(static_cast<size_t>(sim::PuzzleEnv::kProprioSize + 4 * k));
    const float b = goal.at(static_cast<size_t>(sim::PuzzleEnv::kProprioSize + 4 * k + 1));
    if (!((a == 1.f && b == 0.f) || (a == 0.f && b == 1.f)))
      throw std::invalid_argument("button " + std::to_string(k) +
                                  "'s state entries must be (1, 0) or (0, 1)");
    s[static_cast<size_t>(k)] = b == 1.f ? 1 : 0;
  }
  return s;
}

PuzzleSimNodeOptions LoadPuzzleSimNodeOptions(const ros::NodeHandle& pnh, sim::EnvId id) {
  PuzzleSimNodeOptions o;
  o.side = sim::PuzzleSide(id);
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

PuzzleSimNode::PuzzleSimNode(ros::NodeHandle nh, ros::NodeHandle pnh,
                             const PuzzleSimNodeOptions& options)
    : SimNodeBase(
          nh, pnh, options, kAct,
          sim::CubeSceneOptions().timestep * sim::PuzzleEnvOptions().substeps,
          sim::EnvLabel(options.side == 3 ? sim::EnvId::kPuzzle3x3 : sim::EnvId::kPuzzle4x4)),
      options_(options) {
  sim::PuzzleEnvOptions env_opt;
  env_opt.side = options_.side;
  env_opt.enable_rendering = pixels();
  env_opt.image_size = options_.image_size;
  env_opt.max_episode_steps = options_.max_episode_steps;
  env_ = MakeArmEnv<sim::PuzzleEnv>(nh_, options_.robot_description, options_.urdf,
                                    options_.world_frame, env_opt);
  joint_state_pub_ = nh_.advertise<sensor_msgs::JointState>("joint_states", kStepTopicQueue);
  marker_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("markers", 1, /*latch=*/true);
  if (options_.standard_topics) {
    gripper_state_pub_ =
        nh_.advertise<sensor_msgs::JointState>("gripper/joint_states", kStepTopicQueue);
    buttons_pub_ = nh_.advertise<sensor_msgs::JointState>("buttons/joint_states", kStepTopicQueue);
    goal_obs_pub_ =
        nh_.advertise<std_msgs::Float64MultiArray>("goal_observation", 1, /*latch=*/true);
    ee_twist_sub_ = nh_.subscribe("ee_twist", 10, &PuzzleSimNode::OnEeTwist, this,
                                  ros::TransportHints().tcpNoDelay());
    gripper_cmd_sub_ = nh_.subscribe("gripper_command", 10, &PuzzleSimNode::OnGripperCommand, this,
                                     ros::TransportHints().tcpNoDelay());
  }
  static_tf_.sendTransform(MakeArmStaticTransforms(env_->arm()));
  PublishRobot(Now());
  StartRos();
}

PuzzleSimNode::~PuzzleSimNode() = default;

// A box and a cap per button; the caps red (state 0) or blue (state 1). Latched, and sent
// again whenever a state changes.
void PuzzleSimNode::PublishMarkers() {
  if (drawn_states_ == env_->button_states()) return;
  drawn_states_ = env_->button_states();
  visualization_msgs::MarkerArray arr;
  for (int k = 0; k < env_->num_buttons(); ++k) {
    const Eigen::Vector3d top = env_->ButtonTop(k);
    for (int part = 0; part < 2; ++part) {
      visualization_msgs::Marker m;
      m.header.frame_id = options_.world_frame;
      m.ns = part == 0 ? "button_boxes" : "button_caps";
      m.id = k;
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
        const bool on = drawn_states_[static_cast<size_t>(k)] != 0;
        m.color.r = on ? 0.35f : 0.96f;
        m.color.g = on ? 0.55f : 0.26f;
        m.color.b = on ? 0.91f : 0.33f;
      }
      m.color.a = 1.0f;
      arr.markers.push_back(m);
    }
  }
  marker_pub_.publish(arr);
}

void PuzzleSimNode::PublishRobot(const ros::Time& stamp) {
  const ArmStandardMessages m = MakeArmStandardMessages(
      env_->arm(), env_->Qpos(), env_->Qvel(), static_cast<double>(env_->GetObservation()[18]),
      env_->PinchPosition(), env_->PinchRotation(), stamp, options_.world_frame);
  tf_.sendTransform(m.transforms);
  if (options_.standard_topics) {
    gripper_state_pub_.publish(m.gripper_state);
    buttons_pub_.publish(MakePuzzleButtonStates(*env_, stamp));
  }
  joint_state_pub_.publish(m.joint_states);
  PublishMarkers();
}

void PuzzleSimNode::OnEeTwist(const geometry_msgs::TwistStamped::ConstPtr& msg) {
  standard_commands_.AddTwist(*msg);
  MaybeStepStandard();
}

void PuzzleSimNode::OnGripperCommand(const std_msgs::Float64MultiArray::ConstPtr& msg) {
  standard_commands_.AddGrip(msg->data.empty() ? std::nan("") : msg->data[0]);
  MaybeStepStandard();
}

void PuzzleSimNode::MaybeStepStandard() {
  standard_commands_.Drain(Now(), [this](const std::vector<float>& action) {
    auto a = boost::make_shared<msspr::Action>();
    a->header.stamp = Now();
    a->episode_id = static_cast<uint32_t>(std::max<int64_t>(episode_id_, 0));
    a->step = EpisodeStep();
    a->action = action;
    OnAction(a);
  });
}

void PuzzleSimNode::StartEpisode(int task_id, uint64_t seed) {
  const sim::PuzzleEnv::Observation o = env_->ResetToTask(task_id, seed);
  goal_ = env_->goal_observation();
  BeginEpisode(task_id, seed, "", o);
}

void PuzzleSimNode::BeginEpisode(int task_id, uint64_t seed, const std::string& split,
                                 const sim::PuzzleEnv::Observation& start) {
  std::function<std::vector<uint8_t>()> render_goal;
  if (!goal_.empty() && pixels()) render_goal = [this] { return env_->goal_image(); };
  if (options_.standard_topics && !goal_.empty()) {
    std_msgs::Float64MultiArray g;
    g.data.assign(goal_.begin(), goal_.end());
    goal_obs_pub_.publish(g);
  }
  AnnounceEpisode(task_id, seed, split, start, goal_, render_goal);
}

msspr::Observation PuzzleSimNode::MakeObservation() const {
  msspr::Observation o;
  o.header.stamp = Now();
  o.header.frame_id = options_.world_frame;
  o.episode_id = static_cast<uint32_t>(std::max<int64_t>(episode_id_, 0));
  o.step = static_cast<uint32_t>(env_->episode_steps());
  o.state = env_->GetObservation();
  o.goal = goal_;
  o.success = !options_.auto_reset && env_->Success();  // play data: no goal
  o.last = IsLastStep(env_->episode_steps(), options_.max_episode_steps);
  return o;
}

void PuzzleSimNode::Publish() {
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

void PuzzleSimNode::DoStep(const std::vector<double>& action) {
  sim::PuzzleEnv::Action a;
  std::copy(action.begin(), action.end(), a.begin());
  env_->Step(a);
  ++tick_;
  ++counters_.steps;
  Publish();
}

void PuzzleSimNode::StartInitialEpisode() {
  if (options_.initial_task >= 1)
    StartEpisode(options_.initial_task, static_cast<uint64_t>(options_.seed));
}

// Collection mode: OGBench's play resets (a random arm, every state U{0, 1}); play data has
// no goal, as msspr_collect --env puzzle-* writes it.
void PuzzleSimNode::StartCollectionEpisode(uint64_t seed, const std::string& split) {
  const sim::PuzzleEnv::Observation o = env_->ResetForCollection(seed);
  goal_.clear();
  BeginEpisode(0, seed, split, o);
}

bool PuzzleSimNode::Reset(msspr::Reset::Request& req, msspr::Reset::Response& res) {
  const std::string env =
      sim::EnvLabel(options_.side == 3 ? sim::EnvId::kPuzzle3x3 : sim::EnvId::kPuzzle4x4);
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

// A new goal observation (19 + 4 N numbers): its button states become the goal board.
bool PuzzleSimNode::SetGoal(msspr::SetGoal::Request& req, msspr::SetGoal::Response& res) {
  const size_t n = static_cast<size_t>(env_->observation_size());
  if (req.goal.size() != n || !AllFinite(req.goal)) {
    res.ok = false;
    res.message = "goal must be " + std::to_string(n) + " finite numbers (an observation)";
    return true;
  }
  try {
    env_->SetGoalStates(PuzzleGoalStates(req.goal, env_->num_buttons()));
  } catch (const std::exception& e) {
    res.ok = false;
    res.message = std::string("goal: ") + e.what();
    return true;
  }
  goal_ = req.goal;
  if (options_.standard_topics) {
    std_msgs::Float64MultiArray g;
    g.data.assign(goal_.begin(), goal_.end());
    goal_obs_pub_.publish(g);
  }
  res.ok = true;
  res.message = "goal set";
  return true;
}

}  // namespace msspr::ros_bridge
