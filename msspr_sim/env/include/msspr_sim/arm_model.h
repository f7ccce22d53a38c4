// The robot arm of the cube task, read from URDF with urdfdom: a kinematic
// tree of links and joints, forward kinematics with Eigen. No ROS.
//
// Conventions (those of URDF and of MuJoCo's bodies, so the two agree): a
// link's frame is its parent's frame times its joint's origin times the
// joint motion (a rotation about, or a translation along, the joint axis in
// the joint frame). The configuration q holds one value per independent
// degree of freedom: first the revolute joints of the chain from the root
// to the tip link ("arm joints", root first), then the single prismatic
// gripper joint; a mimic joint takes multiplier * q[its leader] + offset.
#pragma once

#include <Eigen/Geometry>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace urdf {
class ModelInterface;
}

namespace msspr::sim {

// A robot description that cannot be used. what() names the source (file)
// and the offending element, e.g. "ur5e.urdf: joint 'elbow_joint': ...".
class UrdfError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Which links and how many joints the cube task expects.
struct ArmModelOptions {
  std::string tip_link = "pinch";      // the controlled point (OGBench's pinch site)
  std::string flange_link = "flange";  // the tool flange (OGBench's attachment_site)
  int num_arm_joints = 6;              // revolute joints on the root-to-tip chain
};

class ArmModel {
 public:
  enum class JointType { kFixed, kRevolute, kPrismatic };

  // One link and the joint that connects it to its parent (none for the root).
  struct Link {
    std::string name;
    int parent = -1;    // index into links(); -1 for the root
    std::string joint;  // joint name; empty for the root
    JointType type = JointType::kFixed;
    Eigen::Isometry3d origin = Eigen::Isometry3d::Identity();  // parent frame -> joint frame
    Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();           // unit, joint frame
    int dof = -1;                                              // index into q; -1 if fixed
    double multiplier = 1.0, offset = 0.0;  // joint value = multiplier q[dof] + offset
    bool mimic = false;
    double lower = 0.0, upper = 0.0;  // joint limits (rad or m)
  };

  // Parses the URDF file at `path`. Throws UrdfError naming the file when it
  // cannot be read, when urdfdom rejects it (with urdfdom's own messages) or
  // when it does not have the structure described above (naming the link or
  // joint at fault).
  static ArmModel FromFile(const std::string& path, const ArmModelOptions& options = {});
  // As FromFile, for URDF text; `source` names it in error messages.
  static ArmModel FromString(const std::string& urdf_xml, const std::string& source,
                             const ArmModelOptions& options = {});

  const std::string& source() const { return source_; }
  const std::string& name() const;
  // Links in an order where every parent precedes its children; links()[0] is the root.
  const std::vector<Link>& links() const { return links_; }
  // Index of the link called `name`; throws std::out_of_range if there is none.
  int LinkIndex(const std::string& name) const;
  int tip_link() const { return tip_; }
  int flange_link() const { return flange_; }
  // Link indices of the arm joints, root first (q[i] moves links()[arm_joint_links()[i]]).
  const std::vector<int>& arm_joint_links() const { return arm_joint_links_; }
  // Link index of the gripper's independent prismatic joint (q[num_arm_joints]).
  int gripper_link() const { return gripper_; }
  int num_dofs() const { return static_cast<int>(arm_joint_links_.size()) + 1; }
  // Lower / upper limits of q, [num_dofs()].
  Eigen::VectorXd LowerLimits() const;
  Eigen::VectorXd UpperLimits() const;

  // Pose of link `link` in the root frame at configuration q [num_dofs()].
  Eigen::Isometry3d LinkPose(int link, const Eigen::VectorXd& q) const;
  // Poses of all links, indexed as links().
  std::vector<Eigen::Isometry3d> LinkPoses(const Eigen::VectorXd& q) const;

  // The parsed urdfdom model (for MJCF generation).
  const urdf::ModelInterface& urdf() const { return *urdf_; }

 private:
  ArmModel() = default;
  Eigen::Isometry3d JointMotion(const Link& link, const Eigen::VectorXd& q) const;

  std::string source_;
  std::shared_ptr<const urdf::ModelInterface> urdf_;
  std::vector<Link> links_;
  std::vector<int> arm_joint_links_;
  int tip_ = -1, flange_ = -1, gripper_ = -1;
};

}  // namespace msspr::sim
