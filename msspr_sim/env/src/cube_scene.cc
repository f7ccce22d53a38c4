#include "msspr_sim/cube_scene.h"

#include <urdf_model/model.h>

#include <cmath>
#include <sstream>
#include <vector>

#include "urdf_util.h"

namespace msspr::sim {
namespace {

using internal::ToEigen;

using Link = ArmModel::Link;
using JointType = ArmModel::JointType;

// Full double precision so that MuJoCo's poses equal the URDF's to ~1e-15.
std::string Vec(const Eigen::Vector3d& v) {
  std::ostringstream s;
  s.precision(17);
  s << v.x() << ' ' << v.y() << ' ' << v.z();
  return s.str();
}

std::string PosQuat(const Eigen::Isometry3d& t) {
  const Eigen::Quaterniond q(t.linear());
  std::ostringstream s;
  s.precision(17);
  s << "pos=\"" << Vec(t.translation()) << "\" quat=\"" << q.w() << ' ' << q.x() << ' ' << q.y()
    << ' ' << q.z() << '"';
  return s.str();
}

std::string Num(double x) {
  std::ostringstream s;
  s.precision(17);
  s << x;
  return s.str();
}

class Generator {
 public:
  Generator(const ArmModel& arm, const CubeSceneOptions& options)
      : arm_(arm), options_(options), children_(arm.links().size()) {
    for (size_t l = 1; l < arm.links().size(); ++l) children_[arm.links()[l].parent].push_back(l);
  }

  [[noreturn]] void Fail(const std::string& what) const {
    throw UrdfError(arm_.source() + ": " + what);
  }

  // A link that MuJoCo does not need as a body: fixed, massless, shapeless.
  bool IsSite(int l) const {
    const urdf::LinkConstSharedPtr link = arm_.urdf().getLink(arm_.links()[l].name);
    return arm_.links()[l].type == JointType::kFixed && !link->inertial &&
           link->visual_array.empty() && link->collision_array.empty() && !link->visual &&
           !link->collision;
  }

  // Emits link l's children into the current body; `prefix` is the pose of
  // link l's frame in that body's frame (identity unless l is a site).
  void EmitChildren(int l, const Eigen::Isometry3d& prefix, std::ostream& out, int depth) {
    for (size_t c : children_[l]) EmitLink(static_cast<int>(c), prefix, out, depth);
  }

  void EmitLink(int l, const Eigen::Isometry3d& prefix, std::ostream& out, int depth) {
    const Link& link = arm_.links()[l];
    const std::string pad(2 * depth, ' ');
    const Eigen::Isometry3d frame = prefix * link.origin;
    if (IsSite(l)) {
      out << pad << "<site name=\"" << link.name << "\" " << PosQuat(frame)
          << " size=\"0.005\" group=\"4\"/>\n";
      EmitChildren(l, frame, out, depth);
      return;
    }
    out << pad << "<body name=\"" << link.name << "\" " << PosQuat(frame) << ">\n";
    EmitJoint(l, out, depth + 1);
    const urdf::LinkConstSharedPtr ul = arm_.urdf().getLink(link.name);
    if (ul->inertial) {
      const urdf::Inertial& in = *ul->inertial;
      if (!(in.mass > 0)) Fail("link '" + link.name + "': <inertial> mass must be positive");
      // MuJoCo's fullinertia is in the body frame and excludes a quat, so
      // the URDF's inertial-frame tensor is rotated into the link frame.
      Eigen::Matrix3d inertia;
      inertia << in.ixx, in.ixy, in.ixz, in.ixy, in.iyy, in.iyz, in.ixz, in.iyz, in.izz;
      const Eigen::Isometry3d frame_of_inertia = ToEigen(in.origin);
      const Eigen::Matrix3d r = frame_of_inertia.linear();
      const Eigen::Matrix3d i = r * inertia * r.transpose();
      // fullinertia order: ixx iyy izz ixy ixz iyz.
      out << pad << "  <inertial pos=\"" << Vec(frame_of_inertia.translation()) << "\" mass=\""
          << Num(in.mass) << "\" fullinertia=\"" << Num(i(0, 0)) << ' ' << Num(i(1, 1)) << ' '
          << Num(i(2, 2)) << ' ' << Num(i(0, 1)) << ' ' << Num(i(0, 2)) << ' ' << Num(i(1, 2))
          << "\"/>\n";
    } else if (link.type != JointType::kFixed) {
      Fail("link '" + link.name + "': a link on a moving joint needs an <inertial>");
    }
    for (const auto& c : ul->collision_array)
      EmitGeom(link.name, *c->geometry, c->origin, c->name, true, nullptr, out, depth + 1);
    for (const auto& v : ul->visual_array)
      EmitGeom(link.name, *v->geometry, v->origin, v->name, false, v->material.get(), out,
               depth + 1);
    EmitChildren(l, Eigen::Isometry3d::Identity(), out, depth + 1);
    out << pad << "</body>\n";
  }

  void EmitJoint(int l, std::ostream& out, int depth) {
    const Link& link = arm_.links()[l];
    if (link.type == JointType::kFixed) return;
    const std::string pad(2 * depth, ' ');
    // Arm joints (and any mimic of one) get the arm's armature; the fingers
    // the 2F-85 driver's, in finger coordinates.
    const bool arm_joint =
        link.dof >= 0 && link.dof < static_cast<int>(arm_.arm_joint_links().size());
    out << pad << "<joint name=\"" << link.joint << "\" type=\""
        << (link.type == JointType::kRevolute ? "hinge" : "slide") << "\" axis=\"" << Vec(link.axis)
        << "\" range=\"" << Num(link.lower) << ' ' << Num(link.upper) << '"';
    if (arm_joint) {
      out << " armature=\"" << Num(options_.arm_armature) << '"';
    } else {
      const double s = FingerScale();
      out << " armature=\"" << Num(kDriverArmature / (s * s)) << "\" damping=\""
          << Num(kDriverDamping / (s * s)) << '"';
    }
    out << "/>\n";
  }

  void EmitGeom(const std::string& link, const urdf::Geometry& g, const urdf::Pose& origin,
                const std::string& name, bool collision, const urdf::Material* material,
                std::ostream& out, int depth) {
    std::ostringstream type;
    switch (g.type) {
      case urdf::Geometry::BOX: {
        const auto& d = static_cast<const urdf::Box&>(g).dim;
        type << "type=\"box\" size=\"" << Vec(Eigen::Vector3d(d.x, d.y, d.z) / 2) << '"';
        break;
      }
      case urdf::Geometry::CYLINDER: {
        const auto& c = static_cast<const urdf::Cylinder&>(g);
        type << "type=\"cylinder\" size=\"" << Num(c.radius) << ' ' << Num(c.length / 2) << '"';
        break;
      }
      case urdf::Geometry::SPHERE:
        type << "type=\"sphere\" size=\"" << Num(static_cast<const urdf::Sphere&>(g).radius) << '"';
        break;
      default:
        Fail("link '" + link + "': " + (collision ? "<collision>" : "<visual>") +
             " geometry must be a box, cylinder or sphere (meshes are not supported)");
    }
    const std::string pad(2 * depth, ' ');
    out << pad << "<geom";
    if (!name.empty()) out << " name=\"" << name << '"';
    out << ' ' << type.str() << ' ' << PosQuat(ToEigen(origin));
    if (collision) {
      out << " group=\"3\" contype=\"1\" conaffinity=\"1\" rgba=\"0.5 0.5 0.5 0.3\"";
      for (const auto& p : options_.pad_geoms) {
        if (name != p) continue;
        // The 2F-85 pad contact (2f85.xml): stiff, grippy, and it decides the
        // contact parameters against anything (priority).
        out << " friction=\"0.7 0.005 0.0001\" priority=\"1\" solref=\"0.004 1\""
               " solimp=\"0.95 0.99 0.001\"";
        ++pads_found_;
      }
    } else {
      out << " group=\"2\" contype=\"0\" conaffinity=\"0\"";
      double rgba[4] = {0.5, 0.5, 0.5, 1.0};
      if (material != nullptr)
        rgba[0] = material->color.r, rgba[1] = material->color.g, rgba[2] = material->color.b,
        rgba[3] = material->color.a;
      if (options_.pixel_style) {
        const std::string mat = material != nullptr ? material->name : "";
        if (mat == options_.purple_materials[0] || mat == options_.purple_materials[1])
          rgba[0] = 0.61, rgba[1] = 0.28, rgba[2] = 0.82;
        rgba[3] = mat == options_.pad_material ? 0.5 : 0.1;
      }
      out << " rgba=\"" << Num(rgba[0]) << ' ' << Num(rgba[1]) << ' ' << Num(rgba[2]) << ' '
          << Num(rgba[3]) << '"';
    }
    out << "/>\n";
  }

  double FingerScale() const { return options_.gripper_travel / options_.driver_range; }

  std::string Generate(const std::string& model_name, const std::string& objects_xml) {
    if (arm_.arm_joint_links().size() != 6)
      Fail("the cube scene needs 6 arm joints, the model has " +
           std::to_string(arm_.arm_joint_links().size()));
    const Link& grip = arm_.links()[arm_.gripper_link()];
    if (std::abs(grip.lower) > 1e-12 || std::abs(grip.upper - options_.gripper_travel) > 1e-9)
      Fail("joint '" + grip.joint + "': its <limit> must be 0 to " + Num(options_.gripper_travel) +
           " m (the gripper travel)");

    std::ostringstream arm_xml;
    EmitChildren(0, Eigen::Isometry3d::Identity(), arm_xml, 2);
    if (pads_found_ != static_cast<int>(options_.pad_geoms.size()))
      Fail("the pad collision geoms '" + options_.pad_geoms[0] + "' and '" + options_.pad_geoms[1] +
           "' must each appear once");

    std::ostringstream x;
    x << "<mujoco model=\"" << model_name << "\">\n"
      << "  <!-- Generated from " << arm_.source()
      << " by msspr_env (cube_scene.cc). -->\n"
      // implicitfast (OGBench's) does not exist in MuJoCo 2.2; implicit is the nearest.
      << "  <compiler angle=\"radian\" autolimits=\"true\"/>\n"
      << "  <option timestep=\"" << Num(options_.timestep)
      << "\" integrator=\"implicit\" cone=\"elliptic\" impratio=\"10\"/>\n"
      << "  <statistic center=\"0.3 0 0.15\" extent=\"0.7\" meansize=\"0.04\"/>\n"
      << "  <visual>\n"
      << "    <headlight diffuse=\"0.6 0.6 0.6\" ambient=\"0.1 0.1 0.1\" specular=\"0 0 0\"/>\n"
      << "    <map znear=\"0.1\" zfar=\"10\"/>\n"
      << "    <quality shadowsize=\"" << options_.shadow_size << "\" numslices=\""
      << options_.render_slices << "\" numstacks=\"" << options_.render_stacks << "\" numquads=\""
      << options_.render_quads << "\"/>\n"
      << "  </visual>\n"
      << "  <asset>\n"
      << "    <texture name=\"grid\" type=\"2d\" builtin=\"checker\" rgb1=\"0.08 0.11 0.16\""
         " rgb2=\"0.15 0.18 0.25\" mark=\"cross\" markrgb=\"0.8 0.8 0.8\" width=\"512\""
         " height=\"512\"/>\n"
      << "    <material name=\"floor\" texture=\"grid\" texuniform=\"true\" texrepeat=\"1 1\"/>\n"
      << "    <texture name=\"sky\" type=\"skybox\" builtin=\"gradient\" rgb1=\"0.15 0.18 0.25\""
         " rgb2=\"0 0 0\" width=\"512\" height=\"512\"/>\n"
      << "  </asset>\n"
      << "  <worldbody>\n"
      << "    <light pos=\"0 0 2\" dir=\"0 0 -1\" directional=\"true\"/>\n"
      << "    <light pos=\"0.25 0 0.5\" dir=\"0 0 -1\" cutoff=\"100\" diffuse=\"0.3 0.3 0.3\""
         " castshadow=\"false\"/>\n"
      << "    <geom name=\"floor\" type=\"plane\" size=\"1 1 0.05\" material=\"floor\""
         " group=\"1\"/>\n"
      // Walls keep the cube (contype 3 has bit 2) in the workspace but not the
      // arm (contype 1): contype 0, conaffinity 2, never rendered (group 3).
      << "    <geom name=\"wall_near\" type=\"box\" pos=\"0.22 0 0.1\" size=\"0.003 0.38 0.2\""
         " contype=\"0\" conaffinity=\"2\" group=\"3\" rgba=\"1 1 1 0.1\"/>\n"
      << "    <geom name=\"wall_far\" type=\"box\" pos=\"0.63 0 0.1\" size=\"0.003 0.38 0.2\""
         " contype=\"0\" conaffinity=\"2\" group=\"3\" rgba=\"1 1 1 0.1\"/>\n"
      << "    <geom name=\"wall_right\" type=\"box\" pos=\"0.425 -0.38 0.1\""
         " size=\"0.205 0.003 0.2\" contype=\"0\" conaffinity=\"2\" group=\"3\""
         " rgba=\"1 1 1 0.1\"/>\n"
      << "    <geom name=\"wall_left\" type=\"box\" pos=\"0.425 0.38 0.1\""
         " size=\"0.205 0.003 0.2\" contype=\"0\" conaffinity=\"2\" group=\"3\""
         " rgba=\"1 1 1 0.1\"/>\n"
      << "    <camera name=\"front\" pos=\"1.287 0 0.509\" xyaxes=\"0 1 0 -0.342 0 0.940\"/>\n"
      << "    <camera name=\"front_pixels\" pos=\"1.053 -0.014 0.639\""
         " xyaxes=\"0 1 0 -0.628 0.001 0.778\"/>\n"
      << arm_xml.str() << objects_xml << "  </worldbody>\n";

    // The fingers: mimic joints as equalities, the servo on their mean
    // (OGBench: 0.5 right driver + 0.5 left driver).
    std::vector<const Link*> fingers;
    for (const Link& l : arm_.links())
      if (l.dof == grip.dof && l.type != JointType::kFixed) fingers.push_back(&l);
    std::ostringstream tendon, equality;
    for (const Link* l : fingers) {
      tendon << "      <joint joint=\"" << l->joint << "\" coef=\"" << Num(1.0 / fingers.size())
             << "\"/>\n";
      if (l->mimic)
        equality << "    <joint joint1=\"" << l->joint << "\" joint2=\"" << grip.joint
                 << "\" polycoef=\"" << Num(l->offset) << ' ' << Num(l->multiplier)
                 << " 0 0 0\"/>\n";
    }
    const std::string tendon_text = tendon.str();
    x << "  <tendon>\n    <fixed name=\"split\">\n" << tendon_text << "    </fixed>\n  </tendon>\n";
    if (!equality.str().empty()) x << "  <equality>\n" << equality.str() << "  </equality>\n";

    x << "  <actuator>\n";
    for (int i = 0; i < 6; ++i) {
      const Link& l = arm_.links()[arm_.arm_joint_links()[i]];
      const double kp = options_.arm_kp[i], kv = options_.arm_kv[i];
      x << "    <general name=\"" << l.joint << "\" joint=\"" << l.joint << "\" ctrlrange=\""
        << Num(l.lower) << ' ' << Num(l.upper) << "\" forcerange=\""
        << Num(-options_.arm_force_limit[i]) << ' ' << Num(options_.arm_force_limit[i])
        << "\" gainprm=\"" << Num(kp) << "\" biastype=\"affine\" biasprm=\"0 " << Num(-kp) << ' '
        << Num(-kv) << "\"/>\n";
    }
    const double s = FingerScale();
    const double kp = kDriverStiffness / (s * s), kv = kDriverServoDamping / (s * s);
    // ctrl 0 (open) to 255 (closed), as OGBench's; it settles at travel ctrl / 255.
    x << "    <general name=\"gripper\" tendon=\"split\" ctrlrange=\"0 255\" forcerange=\""
      << Num(-kDriverForce / s) << ' ' << Num(kDriverForce / s) << "\" gainprm=\""
      << Num(kp * options_.gripper_travel / 255.0) << "\" biastype=\"affine\" biasprm=\"0 "
      << Num(-kp) << ' ' << Num(-kv) << "\"/>\n"
      << "  </actuator>\n</mujoco>\n";
    return x.str();
  }

 private:
  // The 2F-85 driver (2f85.xml), in driver coordinates (rad, N m).
  static constexpr double kDriverStiffness = 100.0;    // servo bias, N m / rad
  static constexpr double kDriverServoDamping = 10.0;  // servo bias, N m s / rad
  static constexpr double kDriverForce = 5.0;          // N m
  static constexpr double kDriverArmature = 0.005;     // kg m^2
  static constexpr double kDriverDamping = 0.1;        // N m s / rad

  const ArmModel& arm_;
  const CubeSceneOptions& options_;
  std::vector<std::vector<size_t>> children_;
  int pads_found_ = 0;
};

}  // namespace

// The cube-single objects: the cube on its free joint and the goal marker (a mocap body).
std::string CubeObjectsMjcf(const CubeSceneOptions& options) {
  std::ostringstream x;
  x << "    <body name=\"object_0\" pos=\"0.3 0 0.02\">\n"
    << "      <freejoint name=\"object_joint_0\"/>\n"
    << "      <geom name=\"cube\" type=\"box\" size=\"0.02 0.02 0.02\" density=\"1240\""
       " solref=\"0.004 1\" contype=\"3\" conaffinity=\"1\" group=\"1\""
       " rgba=\"0.96 0.26 0.33 1\"/>\n"
    << "    </body>\n"
    << "    <body name=\"object_target_0\" mocap=\"true\" pos=\"0.425 0 0.02\">\n"
    << "      <geom name=\"goal\" type=\"box\" size=\"0.02 0.02 0.02\" contype=\"0\""
       " conaffinity=\"0\" group=\""
    << (options.pixel_style ? 5 : 1) << "\" rgba=\"0.96 0.26 0.33 0.2\"/>\n"
    << "    </body>\n";
  return x.str();
}

std::string ArmSceneMjcf(const ArmModel& arm, const CubeSceneOptions& options,
                         const std::string& model_name, const std::string& objects_xml) {
  return Generator(arm, options).Generate(model_name, objects_xml);
}

std::string CubeSceneMjcf(const ArmModel& arm, const CubeSceneOptions& options) {
  return ArmSceneMjcf(arm, options, "cube_single_" + arm.name(), CubeObjectsMjcf(options));
}

}  // namespace msspr::sim
