#include "msspr_sim_nodes/ant_robot_model.h"

#include <mujoco/mujoco.h>
#include <urdf_parser/urdf_parser.h>

#include <cmath>
#include <functional>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <stdexcept>

#include "msspr_sim_nodes/robot_model.h"

namespace msspr::ros_bridge {

namespace {

bool IsUnrotated(const urdf::Rotation& r) {
  return std::abs(r.w) > 1 - 1e-9 && std::abs(r.x) < 1e-9 && std::abs(r.y) < 1e-9 &&
         std::abs(r.z) < 1e-9;
}

}  // namespace

Eigen::Isometry3d AntRobotModel::ChildPose(const AntUrdfJoint& j,
                                           const Eigen::VectorXd& hinges) const {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = j.origin;
  if (j.revolute) t.linear() = Eigen::AngleAxisd(hinges[j.hinge], j.axis).toRotationMatrix();
  return t;
}

AntRobotModel CheckAntUrdf(const std::string& urdf_xml, const std::string& source,
                           const sim::AntMaze& env, const std::string& base_frame) {
  auto fail = [&](const std::string& what) { throw std::runtime_error(source + ": " + what); };
  if (urdf_xml.find_first_not_of(" \t\r\n") == std::string::npos)
    fail("the robot description is empty");
  const urdf::ModelInterfaceSharedPtr urdf = urdf::parseURDF(urdf_xml);
  if (!urdf) fail("not a valid URDF (urdfdom could not parse it)");
  const urdf::LinkConstSharedPtr root = urdf->getRoot();
  if (!root || root->name != base_frame)
    fail("the root link is '" + (root ? root->name : std::string()) + "', expected '" + base_frame +
         "' (the ant's torso, which tf2 places in the world)");

  AntRobotModel model;
  model.name = urdf->getName();
  model.base = base_frame;
  const mjModel* m = env.model();
  std::map<std::string, int> hinge_index;
  for (size_t k = 0; k < sim::kAntHingeJoints.size(); ++k)
    hinge_index[sim::kAntHingeJoints[k]] = static_cast<int>(k);
  // Depth first from the torso: parents before children.
  std::function<void(const urdf::Link&)> visit = [&](const urdf::Link& link) {
    for (const auto& child : link.child_links) {
      const urdf::Joint& uj = *child->parent_joint;
      AntUrdfJoint j;
      j.name = uj.name;
      j.parent = link.name;
      j.child = child->name;
      j.origin = ToEigen(uj.parent_to_joint_origin_transform.position);
      if (!IsUnrotated(uj.parent_to_joint_origin_transform.rotation))
        fail("joint '" + j.name +
             "': its origin must not rotate (the MuJoCo bodies are unrotated)");
      const auto it = hinge_index.find(j.name);
      if (it == hinge_index.end()) {
        if (uj.type != urdf::Joint::FIXED)
          fail("joint '" + j.name +
               "' moves, but the ant's only moving joints are its eight hinges");
      } else {
        if (uj.type != urdf::Joint::REVOLUTE)
          fail("joint '" + j.name + "' must be revolute (a MuJoCo hinge)");
        j.revolute = true;
        j.hinge = it->second;
        j.axis = ToEigen(uj.axis);
        if (std::abs(j.axis.norm() - 1.0) > 1e-6)
          fail("joint '" + j.name + "': its axis " + FormatVector(j.axis) +
               " is not a unit vector");
        const int id = mj_name2id(m, mjOBJ_JOINT, j.name.c_str());
        if (id < 0 || m->jnt_type[id] != mjJNT_HINGE)
          fail("the simulation has no hinge '" + j.name + "'");
        const Eigen::Vector3d mj_axis(m->jnt_axis[3 * id], m->jnt_axis[3 * id + 1],
                                      m->jnt_axis[3 * id + 2]);
        if ((mj_axis - j.axis).norm() > 1e-6)
          fail("joint '" + j.name + "': axis " + FormatVector(j.axis) + ", the simulation's is " +
               FormatVector(mj_axis));
        const double lo = m->jnt_range[2 * id], hi = m->jnt_range[2 * id + 1];
        if (!uj.limits || std::abs(uj.limits->lower - lo) > 1e-6 ||
            std::abs(uj.limits->upper - hi) > 1e-6) {
          std::ostringstream s;
          s << "joint '" << j.name << "': limits must be the simulation's [" << lo << ", " << hi
            << "] rad";
          if (uj.limits) s << ", got [" << uj.limits->lower << ", " << uj.limits->upper << "]";
          fail(s.str());
        }
        hinge_index.erase(it);
      }
      model.joints.push_back(j);
      visit(*child);
    }
  };
  visit(*root);
  if (!hinge_index.empty())
    fail("no joint '" + hinge_index.begin()->first + "' (the ant has eight hinges)");

  // Forward kinematics against MuJoCo's, for the torso at the origin and
  // seeded random hinge angles within the limits.
  std::unique_ptr<mjData, decltype(&mj_deleteData)> d(mj_makeData(m), mj_deleteData);
  std::mt19937_64 rng(7);
  const int torso = mj_name2id(m, mjOBJ_BODY, "torso");
  for (int trial = 0; trial < 4; ++trial) {
    Eigen::VectorXd hinges(8);
    for (int k = 0; k < 8; ++k) {
      const int id = mj_name2id(m, mjOBJ_JOINT, sim::kAntHingeJoints[static_cast<size_t>(k)]);
      std::uniform_real_distribution<double> u(m->jnt_range[2 * id], m->jnt_range[2 * id + 1]);
      hinges[k] = trial == 0 ? 0.0 : u(rng);
    }
    mju_copy(d->qpos, m->qpos0, m->nq);
    for (int k = 0; k < 8; ++k) d->qpos[7 + k] = hinges[k];
    mj_kinematics(m, d.get());
    const Eigen::Vector3d torso_pos(d->xpos[3 * torso], d->xpos[3 * torso + 1],
                                    d->xpos[3 * torso + 2]);
    std::map<std::string, Eigen::Isometry3d> pose{{base_frame, Eigen::Isometry3d::Identity()}};
    for (const auto& j : model.joints) {
      pose[j.child] = pose.at(j.parent) * model.ChildPose(j, hinges);
      const int body = mj_name2id(m, mjOBJ_BODY, j.child.c_str());
      if (body < 0) continue;  // a link the simulation does not have
      const Eigen::Vector3d mj(d->xpos[3 * body] - torso_pos.x(),
                               d->xpos[3 * body + 1] - torso_pos.y(),
                               d->xpos[3 * body + 2] - torso_pos.z());
      if ((pose[j.child].translation() - mj).norm() > 1e-6)
        fail("link '" + j.child + "' lies at " + FormatVector(pose[j.child].translation()) +
             " from the torso, the simulation's body at " + FormatVector(mj));
    }
  }
  return model;
}

}  // namespace msspr::ros_bridge
