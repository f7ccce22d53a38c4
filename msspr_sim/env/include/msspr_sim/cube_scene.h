// The MuJoCo model (MJCF) of OGBench's cube-single scene, generated from the
// arm's URDF (ArmModel) so that the robot has one source of truth. Values
// follow OGBench's cube-single scene (manipspace).
//
// Model layout: qpos = 6 arm joints (ArmModel's dof order), the gripper
// joints (the independent one, then its mimics, in ArmModel link order), the
// cube's free joint (xyz, quat wxyz). Every link with mass or geometry is a
// body named after it; a massless, shapeless link on a fixed joint (flange,
// pinch) becomes a site of that name in the nearest body above it. Each URDF
// <collision> is a colliding geom (contype 1, group 3), each <visual> a
// non-colliding geom (group 2). Actuators: a position servo per arm joint,
// named after the joint, then "gripper" on the tendon "split".
#pragma once

#include <array>
#include <string>

#include "msspr_sim/arm_model.h"

namespace msspr::sim {

struct CubeSceneOptions {
  // Arm servos: torque = kp (ctrl - q) - kv qdot, clipped to +-force_limit.
  // kp as OGBench sets it after compiling; kv is the XML's, since OGBench's
  // kv write lands in a slot a fixed-gain actuator ignores (manipulation.md).
  std::array<double, 6> arm_kp{4500, 4500, 4500, 2000, 2000, 500};
  std::array<double, 6> arm_kv{400, 400, 400, 100, 100, 100};
  std::array<double, 6> arm_force_limit{150, 150, 150, 28, 28, 28};  // N m
  double arm_armature = 0.1;                                         // kg m^2

  // Gripper: OGBench drives the 2F-85's driver angle d in [0, 0.8] rad; our
  // fingers travel s in [0, travel] m. With s = d travel / 0.8, the driver's
  // servo (stiffness 100, damping 10, force 5 on the tendon), its joint
  // armature 0.005 and damping 0.1 become, in finger coordinates,
  // k / scale^2, b / scale^2, f / scale and armature / scale^2, so that the
  // closing motion has the same time course as OGBench's (before contact).
  double gripper_travel = 0.0425;  // m, the URDF's closing range
  double driver_range = 0.8;       // rad, the 2F-85 driver
  // Pad geoms (URDF <collision name>) that get the 2F-85 pad contact.
  std::array<std::string, 2> pad_geoms{"left_pad", "right_pad"};

  double timestep = 0.002;  // s
  // Shadow map size (px). MuJoCo's default, 4096, is what OGBench renders
  // with; for 64 x 64 frames 512 looks the same and, on a software GL
  // (llvmpipe), doubles collection speed with images (42 -> 90 rows/s).
  int shadow_size = 512;
  // Tessellation of the rounded geoms (cylinders, spheres) when rendered:
  // slices and stacks per geom, quads per flat face (MuJoCo's defaults are
  // 28 / 16 / 4). At 64 x 64 these frames differ from the defaults' by 0.4/255
  // per pixel on average (edges only) and render 2.8x faster on a software GL
  // (llvmpipe; 8.9 -> 3.2 ms per frame on an Intel Xeon).
  int render_slices = 8;
  int render_stacks = 4;
  int render_quads = 1;

  // OGBench's pixel-mode look (visual-cube-single): robot visuals at alpha
  // 0.1, the gripper's black and pad materials purple, the pads at alpha 0.5,
  // and the goal marker hidden (geom group 5).
  bool pixel_style = false;
  std::array<std::string, 2> purple_materials{"gripper_black", "pad_grey"};
  std::string pad_material = "pad_grey";
};

// Returns the scene's MJCF text. Throws UrdfError naming the URDF source and
// element when the arm uses something the generator cannot express (a mesh,
// a missing pad geom, fewer than 6 arm joints).
std::string CubeSceneMjcf(const ArmModel& arm, const CubeSceneOptions& options = {});

// cube-single's objects: the cube (object_0 on object_joint_0) and its goal marker
// (object_target_0, hidden with pixel_style).
std::string CubeObjectsMjcf(const CubeSceneOptions& options);

// The same scene with other objects: the arm, floor, walls, lights and cameras of
// CubeSceneMjcf, then `objects_xml` (bodies of the worldbody) in place of the cube and its
// goal marker. The model is named `model_name`. Throws as CubeSceneMjcf.
std::string ArmSceneMjcf(const ArmModel& arm, const CubeSceneOptions& options,
                         const std::string& model_name, const std::string& objects_xml);

}  // namespace msspr::sim
