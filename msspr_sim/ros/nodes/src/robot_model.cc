#include "msspr_sim_nodes/robot_model.h"

#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

namespace msspr::ros_bridge {

Eigen::Vector3d ToEigen(const urdf::Vector3& v) { return Eigen::Vector3d(v.x, v.y, v.z); }

namespace {

// The sphere radii of a link's visual and collision shapes; throws when a shape is not a sphere.
std::vector<double> SphereRadii(const urdf::Link& link, const std::string& where) {
  std::vector<double> radii;
  auto add = [&](const urdf::GeometrySharedPtr& g, const char* what) {
    if (!g) return;
    if (g->type != urdf::Geometry::SPHERE)
      throw std::runtime_error(where + ": link '" + link.name + "': its " + what +
                               " geometry must be a sphere (the simulated agent is one)");
    radii.push_back(static_cast<const urdf::Sphere&>(*g).radius);
  };
  for (const auto& v : link.visual_array) add(v ? v->geometry : nullptr, "visual");
  for (const auto& c : link.collision_array) add(c ? c->geometry : nullptr, "collision");
  if (link.visual_array.empty() && link.visual) add(link.visual->geometry, "visual");
  if (link.collision_array.empty() && link.collision) add(link.collision->geometry, "collision");
  return radii;
}

}  // namespace

std::string FormatVector(const Eigen::Vector3d& v) {
  std::ostringstream s;
  s << "(" << v.x() << " " << v.y() << " " << v.z() << ")";
  return s.str();
}

RobotDescription LoadRobotDescription(ros::NodeHandle& nh, const std::string& param,
                                      const std::string& urdf) {
  RobotDescription d;
  if (!param.empty() && nh.searchParam(param, d.key) && nh.getParam(d.key, d.xml)) {
    d.source = "parameter " + d.key;
    return d;
  }
  d.xml = ReadTextFile(urdf);
  d.source = urdf;
  d.key.clear();
  if (!param.empty()) {
    d.key = nh.resolveName(param);
    nh.setParam(d.key, d.xml);
  }
  return d;
}

std::string ReadTextFile(const std::string& path) {
  std::ifstream f(path);
  if (!f) throw std::runtime_error(path + ": cannot open the file");
  std::stringstream s;
  s << f.rdbuf();
  return s.str();
}

PointRobotModel CheckPointRobotUrdf(const std::string& urdf_xml, const std::string& source,
                                    const sim::PointMaze& env, const std::string& world_frame,
                                    const std::string& agent_frame) {
  if (urdf_xml.find_first_not_of(" \t\r\n") == std::string::npos)
    throw std::runtime_error(source + ": the robot description is empty");
  urdf::ModelInterfaceSharedPtr model = urdf::parseURDF(urdf_xml);
  if (!model)
    throw std::runtime_error(
        source + ": urdfdom could not parse the robot description (see its message above)");
  PointRobotModel out;
  out.name = model->getName();
  const auto root = model->getRoot();
  if (!root || root->name != world_frame)
    throw std::runtime_error(source + ": the root link is '" + (root ? root->name : "") +
                             "', expected the world frame '" + world_frame + "'");
  const auto agent = model->getLink(agent_frame);
  if (!agent)
    throw std::runtime_error(source + ": no link '" + agent_frame + "' (the agent frame)");

  // The chain, from the agent up to the root.
  std::vector<urdf::JointConstSharedPtr> chain;
  for (auto link = agent; link && link->name != world_frame;) {
    const auto j = link->parent_joint;
    if (!j) throw std::runtime_error(source + ": link '" + link->name + "' has no parent joint");
    chain.insert(chain.begin(), j);
    link = model->getLink(j->parent_link_name);
  }
  const auto sim_joints = env.AgentJoints();
  if (chain.size() != sim_joints.size()) {
    std::string names;
    for (const auto& j : sim_joints) names += (names.empty() ? "" : ", ") + j.name;
    throw std::runtime_error(source + ": " + std::to_string(chain.size()) + " joints between '" +
                             world_frame + "' and '" + agent_frame + "', the simulation has " +
                             std::to_string(sim_joints.size()) + " (" + names + ")");
  }
  // The maze's extent, for unlimited MuJoCo joints.
  const auto& map = env.map();
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = Eigen::Vector3d::Constant(-1e300);
  for (const auto& c : map.FreeCells()) {
    const Eigen::Vector2d p = map.CellCenter(c);
    const Eigen::Vector3d q(p.x(), p.y(), 0.0);
    lo = lo.cwiseMin(q - Eigen::Vector3d(sim::kCellSize / 2, sim::kCellSize / 2, 0));
    hi = hi.cwiseMax(q + Eigen::Vector3d(sim::kCellSize / 2, sim::kCellSize / 2, 0));
  }
  double lift = 0;
  for (size_t k = 0; k < chain.size(); ++k) {
    const auto& j = *chain[k];
    const auto& s = sim_joints[k];
    const std::string where = source + ": joint '" + j.name + "'";
    if (j.name != s.name)
      throw std::runtime_error(where + ": joint " + std::to_string(k + 1) +
                               " of the chain must be the simulation's '" + s.name + "'");
    if (j.type != urdf::Joint::PRISMATIC || s.type != "slide")
      throw std::runtime_error(where + ": must be prismatic (the simulation's joint is a " +
                               s.type + " joint)");
    const Eigen::Vector3d axis = ToEigen(j.axis);
    if (axis.norm() < 1e-12 || (axis.normalized() - s.axis.normalized()).norm() > 1e-9)
      throw std::runtime_error(where + ": axis " + FormatVector(axis) +
                               " differs from the simulation's " + FormatVector(s.axis));
    double roll = 0, pitch = 0, yaw = 0;
    j.parent_to_joint_origin_transform.rotation.getRPY(roll, pitch, yaw);
    if (std::abs(roll) + std::abs(pitch) + std::abs(yaw) > 1e-9)
      throw std::runtime_error(where + ": origin rpy must be 0 0 0");
    const Eigen::Vector3d origin = ToEigen(j.parent_to_joint_origin_transform.position);
    if (!j.limits) throw std::runtime_error(where + ": a prismatic joint needs <limit>");
    const Eigen::Vector3d u = s.axis.normalized();
    if (s.limited) {
      if (std::abs(j.limits->lower - s.lower) > 1e-9 || std::abs(j.limits->upper - s.upper) > 1e-9)
        throw std::runtime_error(where + ": limits [" + std::to_string(j.limits->lower) + ", " +
                                 std::to_string(j.limits->upper) +
                                 "] differ from the simulation's [" + std::to_string(s.lower) +
                                 ", " + std::to_string(s.upper) + "]");
    } else {
      // Where the maze lets the agent go along this axis.
      // Where the maze lets the agent go along this axis: the free cells' box, projected.
      double a = 0, b = 0;
      for (int i = 0; i < 3; ++i) {
        a += std::min(u[i] * lo[i], u[i] * hi[i]);
        b += std::max(u[i] * lo[i], u[i] * hi[i]);
      }
      if (j.limits->lower > a || j.limits->upper < b)
        throw std::runtime_error(where + ": limits [" + std::to_string(j.limits->lower) + ", " +
                                 std::to_string(j.limits->upper) + "] do not cover maze " +
                                 map.name() + " (" + std::to_string(a) + " to " +
                                 std::to_string(b) + " m along the axis)");
    }
    RobotChainJoint rj;
    rj.name = j.name;
    rj.parent = j.parent_link_name;
    rj.child = j.child_link_name;
    rj.origin = origin;
    rj.axis = u;
    out.chain.push_back(rj);
    lift += origin.z();
  }
  const auto radii = SphereRadii(*agent, source);
  if (radii.empty())
    throw std::runtime_error(source + ": link '" + agent_frame +
                             "' has no sphere (visual or collision)");
  const double r = env.AgentRadius();
  for (double x : radii)
    if (std::abs(x - r) > 1e-9)
      throw std::runtime_error(source + ": link '" + agent_frame + "': sphere radius " +
                               std::to_string(x) + " differs from the simulation's " +
                               std::to_string(r));
  if (std::abs(lift - r) > 1e-9)
    throw std::runtime_error(source + ": the joint origins lift the agent by " +
                             std::to_string(lift) +
                             " m; the simulated sphere's centre is one radius (" +
                             std::to_string(r) + " m) above the floor");
  out.radius = r;
  return out;
}

}  // namespace msspr::ros_bridge
