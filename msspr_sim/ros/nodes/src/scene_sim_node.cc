// msspr_sim_node ~env scene (SceneSimNode, arm_task_sim_node.h): the scene's objects as ROS
// topics, tf2 and rviz markers beside the arm's.
#include <visualization_msgs/MarkerArray.h>

#include <array>
#include <cmath>
#include <string>
#include <vector>

#include "msspr_bridge/msg_conversion.h"
#include "msspr_sim_nodes/arm_task_sim_node.h"

namespace msspr::ros_bridge {
namespace {

constexpr std::array<float, 3> kRed = {0.96f, 0.26f, 0.33f}, kWhite = {0.9f, 0.9f, 0.9f},
                               kBlue = {0.6f, 0.72f, 0.94f}, kGlass = {0.0f, 0.3f, 0.4f};

visualization_msgs::Marker Box(const std::string& frame, const std::string& ns, int id,
                               const Eigen::Vector3d& centre, const Eigen::Vector3d& size,
                               const std::array<float, 3>& rgb, float alpha) {
  visualization_msgs::Marker m;
  m.header.frame_id = frame;
  m.ns = ns;
  m.id = id;
  m.type = visualization_msgs::Marker::CUBE;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.position.x = centre.x();
  m.pose.position.y = centre.y();
  m.pose.position.z = centre.z();
  m.pose.orientation.w = 1.0;
  m.scale.x = size.x();
  m.scale.y = size.y();
  m.scale.z = size.z();
  m.color.r = rgb[0];
  m.color.g = rgb[1];
  m.color.b = rgb[2];
  m.color.a = alpha;
  m.frame_locked = true;  // the moving parts' frames; a no-op for the world frame's
  return m;
}

// A handle bar: a cylinder of `radius` and `length` along x (horizontal) or z.
visualization_msgs::Marker Handle(const std::string& frame, const std::string& ns,
                                  const Eigen::Vector3d& centre, double radius, double length,
                                  bool along_x, bool locked) {
  visualization_msgs::Marker m =
      Box(frame, ns, 0, centre, Eigen::Vector3d(2 * radius, 2 * radius, length),
          locked ? kRed : kWhite, 1.0f);
  m.type = visualization_msgs::Marker::CYLINDER;
  if (along_x) {  // the cylinder's z axis turned onto x
    m.pose.orientation.w = std::sqrt(0.5);
    m.pose.orientation.y = std::sqrt(0.5);
  }
  return m;
}

}  // namespace

sensor_msgs::JointState MakeSceneButtonStates(const sim::SceneEnv& env, const ros::Time& stamp) {
  return MakeButtonStates(env, 2, sim::ArmEnv::kProprioSize + 9, stamp);  // after the cube's 9
}

sensor_msgs::JointState MakeSceneSlideStates(const sim::SceneEnv& env, const ros::Time& stamp) {
  sensor_msgs::JointState js;
  js.header.stamp = stamp;
  const sim::SceneEnv::Observation o = env.GetObservation();
  js.name = {"drawer_slide", "window_slide"};
  js.position = {env.Drawer(), env.Window()};
  js.velocity = {o[37], o[39]};
  js.effort = {env.DrawerLocked() ? 1.0 : 0.0, env.WindowLocked() ? 1.0 : 0.0};
  return js;
}

SceneSimNode::SceneSimNode(ros::NodeHandle nh, ros::NodeHandle pnh,
                           const ArmTaskSimNodeOptions& options)
    : ArmTaskSimNode(nh, pnh, options, sim::SceneEnvOptions()) {
  marker_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("markers", 1, /*latch=*/true);
  if (options.standard_topics) {
    buttons_pub_ = nh_.advertise<sensor_msgs::JointState>("buttons/joint_states", kStepTopicQueue);
    slides_pub_ = nh_.advertise<sensor_msgs::JointState>("slides/joint_states", kStepTopicQueue);
    cube_pose_pub_ = nh_.advertise<geometry_msgs::PoseStamped>("cube_pose", kStepTopicQueue);
  }
  PublishRobot(Now());  // the arm at home, before any episode
  StartRos();
}

// The markers: the table's fixed parts in the world frame, the moving ones locked to their
// frames (cube, cube_goal, drawer, window); sent again when a button state (and with it a
// lock's colour) changes.
void SceneSimNode::PublishMarkers() {
  const std::string& world = options().world_frame;
  visualization_msgs::MarkerArray arr;
  AppendButtonMarkers({env_->ButtonTop(0), env_->ButtonTop(1)},
                      {drawn_states_[0], drawn_states_[1]}, kRed, kWhite, world, &arr);
  const Eigen::Vector3d cube(0.04, 0.04, 0.04);
  arr.markers.push_back(Box("cube", "cube", 0, Eigen::Vector3d::Zero(), cube, kRed, 1.0f));
  arr.markers.push_back(
      Box("cube_goal", "cube_goal", 0, Eigen::Vector3d::Zero(), cube, kRed, 0.3f));
  // The drawer's case (x 0.212-0.448, y -0.52 to -0.32, z 0-0.168), its tray and handle.
  arr.markers.push_back(Box(world, "drawer_case", 0, Eigen::Vector3d(0.33, -0.42, 0.084),
                            Eigen::Vector3d(0.236, 0.2, 0.168), kBlue, 0.4f));
  arr.markers.push_back(Box("drawer", "drawer_tray", 0, Eigen::Vector3d(0, 0, 0.003),
                            Eigen::Vector3d(0.188, 0.168, 0.114), kBlue, 0.8f));
  arr.markers.push_back(Handle("drawer", "drawer_handle", Eigen::Vector3d(0, 0.17, -0.01), 0.009,
                               0.1, true, drawn_states_[0] == 0));
  // The window's frame and fixed pane, its sliding pane and handle.
  const Eigen::Vector3d post(0.02, 0.06, 0.4), bar(0.452, 0.06, 0.02);
  arr.markers.push_back(
      Box(world, "window_frame", 0, Eigen::Vector3d(0.084, 0.3, 0.2), post, kWhite, 1.0f));
  arr.markers.push_back(
      Box(world, "window_frame", 1, Eigen::Vector3d(0.516, 0.3, 0.2), post, kWhite, 1.0f));
  arr.markers.push_back(
      Box(world, "window_frame", 2, Eigen::Vector3d(0.3, 0.3, 0.01), bar, kWhite, 1.0f));
  arr.markers.push_back(
      Box(world, "window_frame", 3, Eigen::Vector3d(0.3, 0.3, 0.39), bar, kWhite, 1.0f));
  const Eigen::Vector3d pane(0.196, 0.008, 0.34);
  arr.markers.push_back(
      Box(world, "window_fixed_pane", 0, Eigen::Vector3d(0.4, 0.313, 0.202), pane, kGlass, 0.3f));
  arr.markers.push_back(
      Box("window", "window_pane", 0, Eigen::Vector3d::Zero(), pane, kGlass, 0.3f));
  arr.markers.push_back(Handle("window", "window_handle", Eigen::Vector3d(0.08, -0.058, 0.035),
                               0.008, 0.09, false, drawn_states_[1] == 0));
  marker_pub_.publish(arr);
}

void SceneSimNode::PublishObjects(const ros::Time& stamp) {
  const std::string& world = options().world_frame;
  const double* q = env_->CubeQpos();
  std::vector<geometry_msgs::TransformStamped> tfs;
  tfs.push_back(ToTf(FreeBodyPose(q), stamp, world, "cube"));
  tfs.push_back(
      ToTf(YawPose(env_->CubeTargetPosition(), env_->CubeTargetYaw()), stamp, world, "cube_goal"));
  tfs.push_back(ToTf(YawPose(env_->DrawerPosition(), 0.0), stamp, world, "drawer"));
  tfs.push_back(ToTf(YawPose(env_->WindowPosition(), 0.0), stamp, world, "window"));
  object_tf_.sendTransform(tfs);
  if (options().standard_topics) {
    buttons_pub_.publish(MakeSceneButtonStates(*env_, stamp));
    slides_pub_.publish(MakeSceneSlideStates(*env_, stamp));
    cube_pose_pub_.publish(FreeBodyPoseMsg(q, stamp, world));
  }
  if (drawn_states_ == env_->button_states()) return;
  drawn_states_ = env_->button_states();
  PublishMarkers();
}

std::string SceneSimNode::ApplyGoal(const std::vector<float>& goal) {
  try {
    double yaw = 0;
    const sim::SceneState s = sim::SceneEnv::StateFromObservation(goal, &yaw);
    env_->SetGoalState(s);
    env_->SetCubeTarget(s.cube, yaw);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

}  // namespace msspr::ros_bridge
