#include "msspr_sim_nodes/arm_messages.h"

#include "msspr_bridge/msg_conversion.h"

namespace msspr::ros_bridge {
namespace {

// Joint values q [num_dofs] of the ArmModel from MuJoCo's qpos (arm 0-5, left finger 6).
Eigen::VectorXd ArmQ(const sim::ArmModel& arm, const std::vector<double>& qpos) {
  const int n = arm.num_dofs();
  Eigen::VectorXd q(n);
  for (int i = 0; i < n; ++i) q[i] = qpos.at(static_cast<size_t>(i));
  return q;
}

}  // namespace

ArmStandardMessages MakeArmStandardMessages(
    const sim::ArmModel& arm, const std::vector<double>& qpos, const std::vector<double>& qvel,
    double contact, const Eigen::Vector3d& pinch_position, const Eigen::Matrix3d& pinch_rotation,
    const ros::Time& stamp, const std::string& world_frame) {
  ArmStandardMessages out;
  const auto& links = arm.links();
  const Eigen::VectorXd q = ArmQ(arm, qpos);
  const std::vector<Eigen::Isometry3d> poses = arm.LinkPoses(q);
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
  for (size_t i = 6; i < js.name.size(); ++i) {  // the arm's six joints come first
    out.gripper_state.name = {js.name[i]};
    out.gripper_state.position = {js.position[i]};
    out.gripper_state.velocity = {js.velocity[i]};
    out.gripper_state.effort = {50.0 * contact};
    break;
  }
  // The pinch pose as the arm's controller measures it (as ur_robot_driver's
  // tool0_controller frame): the simulator's own pinch site, which the
  // observation reads. It comes from the physics' last kinematics pass, one
  // 2 ms substep before the joint positions, so it differs from the URDF's
  // pinch link (forward kinematics of joint_states) by up to about a millimetre.
  Eigen::Isometry3d pinch = Eigen::Isometry3d::Identity();
  pinch.translation() = pinch_position;
  pinch.linear() = pinch_rotation;
  out.transforms.push_back(ToTf(pinch, stamp, world_frame, kPinchControllerFrame));
  return out;
}

void EeCommandPairs::AddTwist(const geometry_msgs::TwistStamped& twist) {
  twists_.push_back(twist);
  if (twists_.size() > 10) twists_.pop_front();
}

void EeCommandPairs::AddGrip(double grip) {
  grips_.push_back(grip);
  if (grips_.size() > 10) grips_.pop_front();
}

void EeCommandPairs::Drain(const ros::Time& now,
                           const std::function<void(const std::vector<float>&)>& step) {
  while (!twists_.empty() && !grips_.empty()) {
    const geometry_msgs::TwistStamped twist = twists_.front();
    const double grip = grips_.front();
    twists_.pop_front();
    grips_.pop_front();
    if (!twist.header.stamp.isZero() && twist.header.stamp + ros::Duration(1e-6) < now) {
      if (stale_++ == 0 || stale_ % 100 == 0)
        ROS_WARN_STREAM_NAMED(
            "msspr_sim", "ee_twist stamped " << twist.header.stamp << " for an observation before "
                                             << now << ": dropped with its gripper command ("
                                             << stale_ << " so far)");
      continue;
    }
    const auto& t = twist.twist;
    step({static_cast<float>(t.linear.x / kEeSpeed), static_cast<float>(t.linear.y / kEeSpeed),
          static_cast<float>(t.linear.z / kEeSpeed), static_cast<float>(t.angular.z / kEeYawRate),
          static_cast<float>(grip)});
  }
}

Eigen::Isometry3d FreeBodyPose(const double* q) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = Eigen::Vector3d(q[0], q[1], q[2]);
  pose.linear() = Eigen::Quaterniond(q[3], q[4], q[5], q[6]).normalized().toRotationMatrix();
  return pose;
}

geometry_msgs::PoseStamped FreeBodyPoseMsg(const double* q, const ros::Time& stamp,
                                           const std::string& frame) {
  geometry_msgs::PoseStamped p;
  p.header.stamp = stamp;
  p.header.frame_id = frame;
  p.pose.position.x = q[0];
  p.pose.position.y = q[1];
  p.pose.position.z = q[2];
  p.pose.orientation.w = q[3];
  p.pose.orientation.x = q[4];
  p.pose.orientation.y = q[5];
  p.pose.orientation.z = q[6];
  return p;
}

Eigen::Isometry3d YawPose(const Eigen::Vector3d& p, double yaw) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.translation() = p;
  pose.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return pose;
}

std::vector<geometry_msgs::TransformStamped> MakeArmStaticTransforms(const sim::ArmModel& arm) {
  const auto& links = arm.links();
  const std::vector<Eigen::Isometry3d> poses = arm.LinkPoses(Eigen::VectorXd::Zero(arm.num_dofs()));
  std::vector<geometry_msgs::TransformStamped> tfs;
  for (size_t i = 1; i < links.size(); ++i) {
    if (links[i].type != sim::ArmModel::JointType::kFixed) continue;
    const auto& parent = links[static_cast<size_t>(links[i].parent)];
    tfs.push_back(ToTf(poses[static_cast<size_t>(links[i].parent)].inverse() * poses[i],
                       ros::Time(0), parent.name, links[i].name));
  }
  return tfs;
}

}  // namespace msspr::ros_bridge
