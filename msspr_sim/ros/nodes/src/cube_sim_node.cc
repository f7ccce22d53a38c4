#include "msspr_sim_nodes/cube_sim_node.h"

#include <visualization_msgs/MarkerArray.h>

#include <stdexcept>
#include <utility>

#include "msspr_bags/dataset_bag.h"
#include "msspr_bridge/msg_conversion.h"
#include "msspr_sim/env_id.h"

namespace msspr::ros_bridge {

CubeObjectMessages MakeCubeObjectMessages(const sim::CubeEnv& env, const ros::Time& stamp,
                                          const std::string& world_frame,
                                          const std::string& cube_frame,
                                          const std::string& goal_frame) {
  const std::vector<double> qpos = env.Qpos();
  CubeObjectMessages out;
  out.cube_pose = FreeBodyPoseMsg(qpos.data() + 8, stamp, world_frame);
  out.transforms.push_back(ToTf(FreeBodyPose(qpos.data() + 8), stamp, world_frame, cube_frame));
  out.transforms.push_back(
      ToTf(YawPose(env.GoalPosition(), env.GoalYaw()), stamp, world_frame, goal_frame));
  return out;
}

CubeStandardMessages MakeCubeStandardMessages(const sim::CubeEnv& env, const ros::Time& stamp,
                                              const std::string& world_frame,
                                              const std::string& cube_frame,
                                              const std::string& goal_frame) {
  ArmStandardMessages arm = MakeArmStandardMessages(
      env.arm(), env.Qpos(), env.Qvel(), static_cast<double>(env.GetObservation()[18]),
      env.PinchPosition(), env.PinchRotation(), stamp, world_frame);
  CubeObjectMessages objects =
      MakeCubeObjectMessages(env, stamp, world_frame, cube_frame, goal_frame);
  CubeStandardMessages out;
  out.joint_states = std::move(arm.joint_states);
  out.gripper_state = std::move(arm.gripper_state);
  out.cube_pose = std::move(objects.cube_pose);
  out.transforms = std::move(arm.transforms);
  out.transforms.insert(out.transforms.end(), objects.transforms.begin(), objects.transforms.end());
  return out;
}

std::vector<geometry_msgs::TransformStamped> MakeCubeStaticTransforms(const sim::CubeEnv& env) {
  return MakeArmStaticTransforms(env.arm());
}

CubeSimNodeOptions LoadCubeSimNodeOptions(const ros::NodeHandle& pnh) {
  CubeSimNodeOptions o;
  static_cast<ArmTaskSimNodeOptions&>(o) = LoadArmTaskSimNodeOptions(pnh, sim::EnvId::kCubeSingle);
  o.cube_frame = SimParam(pnh, "cube_frame", o.cube_frame);
  o.goal_frame = SimParam(pnh, "goal_frame", o.goal_frame);
  if (o.cube_frame.empty() || o.goal_frame.empty())
    throw std::invalid_argument("~cube_frame/~goal_frame must be non-empty, got ''");
  return o;
}

CubeSimNode::CubeSimNode(ros::NodeHandle nh, ros::NodeHandle pnh, const CubeSimNodeOptions& options)
    : ArmTaskSimNode(nh, pnh, options, sim::CubeEnvOptions()), cube_options_(options) {
  marker_pub_ = nh_.advertise<visualization_msgs::MarkerArray>("markers", 1, /*latch=*/true);
  if (options.standard_topics)
    cube_pose_pub_ = nh_.advertise<geometry_msgs::PoseStamped>("cube_pose", kStepTopicQueue);
  // Latched markers for the cube and the goal, locked to their frames.
  visualization_msgs::MarkerArray arr;
  for (int k = 0; k < 2; ++k) {
    visualization_msgs::Marker m;
    m.header.frame_id = k == 0 ? options.cube_frame : options.goal_frame;
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
  PublishRobot(Now());  // the arm at home, before any episode
  StartRos();
}

void CubeSimNode::PublishObjects(const ros::Time& stamp) {
  const CubeObjectMessages m = MakeCubeObjectMessages(
      *env_, stamp, options().world_frame, cube_options_.cube_frame, cube_options_.goal_frame);
  object_tf_.sendTransform(m.transforms);
  if (options().standard_topics) cube_pose_pub_.publish(m.cube_pose);
}

// A new goal observation (28 numbers): the goal marker moves to its cube position and yaw,
// so success and tf2 follow it; in pixels mode the goal image is rendered for it (the scene
// posed as the goal) and published.
std::string CubeSimNode::ApplyGoal(const std::vector<float>& goal) {
  sim::CubeEnv::Observation g;
  std::copy(goal.begin(), goal.end(), g.begin());
  env_->SetGoalObservation(g);
  if (pixels())
    goal_image_pub_.publish(
        ToImageMsg(env_->goal_image().data(), options().image_size, Now(), kCameraFrame));
  return "";
}

}  // namespace msspr::ros_bridge
