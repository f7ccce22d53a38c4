#include "msspr_sim/arm_model.h"

#include <console_bridge/console.h>
#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <mutex>
#include <sstream>

#include "urdf_util.h"

namespace msspr::sim {
namespace {

using internal::ToEigen;

// urdfdom reports why it rejects a description only through console_bridge
// (it returns nullptr); this handler collects those lines so that the
// exception can carry them. console_bridge's handler is process-global.
class CollectingHandler : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_WARN) lines_.push_back(text);
  }
  std::string Joined() const {
    std::string all;
    for (const auto& l : lines_) all += (all.empty() ? "" : "; ") + l;
    return all.empty() ? "no reason given" : all;
  }

 private:
  std::vector<std::string> lines_;
};

std::mutex& ParserMutex() {
  static std::mutex m;
  return m;
}

urdf::ModelInterfaceSharedPtr ParseCollectingErrors(const std::string& xml,
                                                    const std::string& source) {
  std::lock_guard<std::mutex> lock(ParserMutex());
  CollectingHandler handler;
  console_bridge::useOutputHandler(&handler);
  urdf::ModelInterfaceSharedPtr model;
  try {
    model = urdf::parseURDF(xml);
  } catch (const std::exception& e) {
    // urdfdom throws for some malformed numbers (std::stod via its own parser).
    console_bridge::restorePreviousOutputHandler();
    throw UrdfError(source + ": urdfdom cannot parse it: " + e.what());
  }
  console_bridge::restorePreviousOutputHandler();
  if (!model) throw UrdfError(source + ": urdfdom cannot parse it: " + handler.Joined());
  return model;
}

const char* TypeName(int type) {
  switch (type) {
    case urdf::Joint::REVOLUTE:
      return "revolute";
    case urdf::Joint::CONTINUOUS:
      return "continuous";
    case urdf::Joint::PRISMATIC:
      return "prismatic";
    case urdf::Joint::FLOATING:
      return "floating";
    case urdf::Joint::PLANAR:
      return "planar";
    case urdf::Joint::FIXED:
      return "fixed";
    default:
      return "unknown";
  }
}

}  // namespace

ArmModel ArmModel::FromFile(const std::string& path, const ArmModelOptions& options) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw UrdfError(path + ": cannot open the file for reading");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw UrdfError(path + ": error while reading the file");
  return FromString(text.str(), path, options);
}

namespace {

// A link and the joint to its parent (`parent`: the parent's index). Throws UrdfError
// naming the joint for an unsupported type, a zero axis or a bad <limit>.
ArmModel::Link LinkOf(const urdf::Link& child, int parent, const std::string& source) {
  using JointType = ArmModel::JointType;
  const urdf::JointConstSharedPtr joint = child.parent_joint;
  const auto fail = [&](const std::string& what) {
    throw UrdfError(source + ": joint '" + joint->name + "'" + what);
  };
  ArmModel::Link l;
  l.name = child.name;
  l.parent = parent;
  l.joint = joint->name;
  l.origin = ToEigen(joint->parent_to_joint_origin_transform);
  switch (joint->type) {
    case urdf::Joint::FIXED:
      l.type = JointType::kFixed;
      break;
    case urdf::Joint::REVOLUTE:
      l.type = JointType::kRevolute;
      break;
    case urdf::Joint::PRISMATIC:
      l.type = JointType::kPrismatic;
      break;
    default:
      fail(std::string(": type ") + TypeName(joint->type) +
           " is not supported (use revolute, prismatic or fixed)");
  }
  if (l.type == JointType::kFixed) return l;
  const Eigen::Vector3d axis(joint->axis.x, joint->axis.y, joint->axis.z);
  if (!(axis.norm() > 1e-9)) fail(": its axis is zero");
  l.axis = axis.normalized();
  // urdfdom already rejects a revolute or prismatic joint without <limit>; the
  // simulation needs a proper range as well.
  if (!joint->limits || !(joint->limits->lower < joint->limits->upper))
    fail(": <limit> must have lower < upper");
  l.lower = joint->limits->lower;
  l.upper = joint->limits->upper;
  if (joint->mimic) {
    l.mimic = true;
    l.multiplier = joint->mimic->multiplier;
    l.offset = joint->mimic->offset;
  }
  return l;
}

}  // namespace

ArmModel ArmModel::FromString(const std::string& urdf_xml, const std::string& source,
                              const ArmModelOptions& options) {
  ArmModel arm;
  arm.source_ = source;
  urdf::ModelInterfaceSharedPtr model = ParseCollectingErrors(urdf_xml, source);
  arm.urdf_ = model;
  const auto fail = [&](const std::string& what) { throw UrdfError(source + ": " + what); };

  // Breadth-first from the root, children in name order, so that parents
  // precede children and the order does not depend on urdfdom's containers.
  const urdf::LinkConstSharedPtr root = model->getRoot();
  if (!root) fail("no root link");
  std::map<std::string, int> index;
  arm.links_.push_back(Link{});
  arm.links_[0].name = root->name;
  index[root->name] = 0;
  for (size_t i = 0; i < arm.links_.size(); ++i) {
    const urdf::LinkConstSharedPtr link = model->getLink(arm.links_[i].name);
    std::vector<urdf::LinkSharedPtr> children = link->child_links;
    std::sort(children.begin(), children.end(),
              [](const auto& a, const auto& b) { return a->name < b->name; });
    for (const auto& child : children) {
      const Link l = LinkOf(*child, static_cast<int>(i), source);
      index[l.name] = static_cast<int>(arm.links_.size());
      arm.links_.push_back(l);
    }
  }

  const auto find = [&](const std::string& name, const char* role) {
    const auto it = index.find(name);
    if (it == index.end()) fail(std::string("no link '") + name + "' (the " + role + ")");
    return it->second;
  };
  arm.tip_ = find(options.tip_link, "tip");
  arm.flange_ = find(options.flange_link, "flange");

  // The arm: the moving joints from the root to the tip, all revolute.
  std::vector<int> chain;
  for (int l = arm.tip_; l > 0; l = arm.links_[l].parent) chain.push_back(l);
  std::reverse(chain.begin(), chain.end());
  for (int l : chain) {
    Link& link = arm.links_[l];
    if (link.type == JointType::kFixed) continue;
    if (link.type != JointType::kRevolute || link.mimic)
      fail("joint '" + link.joint + "': the joints from the root to link '" + options.tip_link +
           "' must be revolute and independent (no mimic)");
    link.dof = static_cast<int>(arm.arm_joint_links_.size());
    arm.arm_joint_links_.push_back(l);
  }
  if (static_cast<int>(arm.arm_joint_links_.size()) != options.num_arm_joints)
    fail("the chain from link '" + arm.links_[0].name + "' to link '" + options.tip_link +
         "' has " + std::to_string(arm.arm_joint_links_.size()) + " revolute joints, expected " +
         std::to_string(options.num_arm_joints));
  if (std::find(chain.begin(), chain.end(), arm.flange_) == chain.end())
    fail("link '" + options.flange_link + "' is not on the chain to link '" + options.tip_link +
         "'");

  // The gripper: exactly one independent prismatic joint off the arm chain;
  // any other moving joint must mimic a moving joint.
  for (size_t l = 1; l < arm.links_.size(); ++l) {
    Link& link = arm.links_[l];
    if (link.type == JointType::kFixed || link.dof >= 0 || link.mimic) continue;
    if (link.type != JointType::kPrismatic)
      fail("joint '" + link.joint + "': a moving joint off the arm chain must be prismatic " +
           "(the gripper) or mimic another joint");
    if (arm.gripper_ >= 0)
      fail("joint '" + link.joint + "': a second independent gripper joint (the first is '" +
           arm.links_[arm.gripper_].joint + "')");
    arm.gripper_ = static_cast<int>(l);
    link.dof = options.num_arm_joints;
  }
  if (arm.gripper_ < 0) fail("no independent prismatic joint (the gripper)");
  for (size_t l = 1; l < arm.links_.size(); ++l) {
    Link& link = arm.links_[l];
    if (!link.mimic) continue;
    const urdf::JointConstSharedPtr joint = model->getJoint(link.joint);
    const std::string& leader = joint->mimic->joint_name;
    const auto it = std::find_if(arm.links_.begin(), arm.links_.end(),
                                 [&](const Link& o) { return o.joint == leader && !o.mimic; });
    if (it == arm.links_.end() || it->dof < 0)
      fail("joint '" + link.joint + "': <mimic joint='" + leader +
           "'> does not name an independent moving joint");
    link.dof = it->dof;
  }
  return arm;
}

const std::string& ArmModel::name() const { return urdf_->getName(); }

int ArmModel::LinkIndex(const std::string& name) const {
  for (size_t i = 0; i < links_.size(); ++i)
    if (links_[i].name == name) return static_cast<int>(i);
  throw std::out_of_range(source_ + ": no link '" + name + "'");
}

Eigen::VectorXd ArmModel::LowerLimits() const {
  Eigen::VectorXd v(num_dofs());
  for (size_t i = 0; i < arm_joint_links_.size(); ++i) v[i] = links_[arm_joint_links_[i]].lower;
  v[num_dofs() - 1] = links_[gripper_].lower;
  return v;
}

Eigen::VectorXd ArmModel::UpperLimits() const {
  Eigen::VectorXd v(num_dofs());
  for (size_t i = 0; i < arm_joint_links_.size(); ++i) v[i] = links_[arm_joint_links_[i]].upper;
  v[num_dofs() - 1] = links_[gripper_].upper;
  return v;
}

Eigen::Isometry3d ArmModel::JointMotion(const Link& link, const Eigen::VectorXd& q) const {
  Eigen::Isometry3d m = Eigen::Isometry3d::Identity();
  if (link.dof < 0) return m;
  const double value = link.multiplier * q[link.dof] + link.offset;
  if (link.type == JointType::kRevolute)
    m.linear() = Eigen::AngleAxisd(value, link.axis).toRotationMatrix();
  else
    m.translation() = value * link.axis;
  return m;
}

Eigen::Isometry3d ArmModel::LinkPose(int link, const Eigen::VectorXd& q) const {
  if (q.size() != num_dofs())
    throw std::invalid_argument("ArmModel::LinkPose: q has " + std::to_string(q.size()) +
                                " values, expected " + std::to_string(num_dofs()));
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  for (int l = link; l > 0; l = links_[l].parent)
    pose = links_[l].origin * JointMotion(links_[l], q) * pose;
  return pose;
}

std::vector<Eigen::Isometry3d> ArmModel::LinkPoses(const Eigen::VectorXd& q) const {
  if (q.size() != num_dofs())
    throw std::invalid_argument("ArmModel::LinkPoses: q has " + std::to_string(q.size()) +
                                " values, expected " + std::to_string(num_dofs()));
  std::vector<Eigen::Isometry3d> poses(links_.size(), Eigen::Isometry3d::Identity());
  for (size_t l = 1; l < links_.size(); ++l)
    poses[l] = poses[links_[l].parent] * links_[l].origin * JointMotion(links_[l], q);
  return poses;
}

}  // namespace msspr::sim
