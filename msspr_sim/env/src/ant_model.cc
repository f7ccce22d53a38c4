#include "msspr_sim/ant_model.h"

#include <cstdio>
#include <sstream>
#include <stdexcept>

namespace msspr::sim {
namespace {

std::string MjcfNumber(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.6g", v);
  return buf;
}

// One leg: the thigh capsule on the torso, the hip hinge and leg capsule, the
// ankle hinge and the foot capsule. (sx, sy): the leg's diagonal signs.
struct Leg {
  const char* body;
  int index;  // 1..4: joint names hip_N, ankle_N
  int sx, sy;
  const char* ankle_axis;
  double ankle_lo, ankle_hi;  // degrees
};
constexpr Leg kLegs[4] = {
    {"front_left_leg", 1, 1, 1, "-1 1 0", 30, 70},
    {"front_right_leg", 2, -1, 1, "1 1 0", -70, -30},
    {"back_leg", 3, -1, -1, "-1 1 0", -70, -30},
    {"right_back_leg", 4, 1, -1, "1 1 0", 30, 70},
};

void WriteLeg(std::ostringstream& x, const Leg& leg) {
  const std::string a = MjcfNumber(0.2 * leg.sx) + ' ' + MjcfNumber(0.2 * leg.sy);
  const std::string f = MjcfNumber(0.4 * leg.sx) + ' ' + MjcfNumber(0.4 * leg.sy);
  const std::string n = std::to_string(leg.index);
  x << "      <body name=\"" << leg.body << "\" pos=\"0 0 0\">\n"
    << "        <geom name=\"aux_" << n << "_geom\" type=\"capsule\" size=\"0.08\" fromto=\"0 0 0 "
    << a << " 0\"/>\n"
    << "        <body name=\"aux_" << n << "\" pos=\"" << a << " 0\">\n"
    << "          <joint name=\"hip_" << n
    << "\" type=\"hinge\" pos=\"0 0 0\" axis=\"0 0 1\" range=\"-30 30\"/>\n"
    << "          <geom name=\"leg_" << n
    << "_geom\" type=\"capsule\" size=\"0.08\" fromto=\"0 0 0 " << a << " 0\"/>\n"
    << "          <body name=\"foot_" << n << "\" pos=\"" << a << " 0\">\n"
    << "            <joint name=\"ankle_" << n << "\" type=\"hinge\" pos=\"0 0 0\" axis=\""
    << leg.ankle_axis << "\" range=\"" << MjcfNumber(leg.ankle_lo) << ' '
    << MjcfNumber(leg.ankle_hi) << "\"/>\n"
    << "            <geom name=\"ankle_" << n
    << "_geom\" type=\"capsule\" size=\"0.08\" fromto=\"0 0 0 " << f << " 0\"/>\n"
    << "          </body>\n"
    << "        </body>\n"
    << "      </body>\n";
}

}  // namespace

Eigen::Matrix<double, kAntQposDim, 1> AntQpos0() {
  Eigen::Matrix<double, kAntQposDim, 1> q = Eigen::Matrix<double, kAntQposDim, 1>::Zero();
  q[2] = kAntTorsoHeight;
  q[3] = 1.0;
  return q;
}

std::string AntMjcf(const MazeMap* maze, double open_floor_half_size) {
  if (maze == nullptr && !(open_floor_half_size > 0.0)) {
    throw std::invalid_argument("AntMjcf: open_floor_half_size must be > 0");
  }
  std::ostringstream x;
  x << "<mujoco model=\"" << (maze ? "antmaze_" + maze->name() : std::string("ant")) << "\">\n"
    << "  <compiler angle=\"degree\" inertiafromgeom=\"true\"/>\n"
    << "  <option timestep=\"" << MjcfNumber(kAntTimestep) << "\" integrator=\"RK4\"/>\n"
    << "  <visual>\n"
    << "    <quality shadowsize=\"0\"/>\n"
    << "  </visual>\n"
    // OGBench's defaults: every geom gets these contact parameters; the
    // ant's geoms have conaffinity 0 (no self-collision), floor and walls 1.
    << "  <default>\n"
    << "    <joint armature=\"1\" damping=\"1\" limited=\"true\"/>\n"
    << "    <geom conaffinity=\"0\" condim=\"3\" density=\"5.0\" friction=\"1 0.5 0.5\""
    << " margin=\"0.01\" rgba=\"0.8 0.6 0.4 1\" solimp=\".8 .8 .01\" solref=\".02 1\"/>\n"
    << "  </default>\n"
    << "  <worldbody>\n"
    << "    <light directional=\"true\" castshadow=\"false\" pos=\"0 0 20\" dir=\"0.2 0.3 -1\""
    << " diffuse=\"0.6 0.6 0.6\" specular=\"0 0 0\"/>\n";
  if (maze != nullptr) {
    const int w = maze->cols(), h = maze->rows();
    const double half = kCellSize / 2;
    x << "    <geom name=\"floor\" type=\"plane\" conaffinity=\"1\" pos=\""
      << MjcfNumber(half * (w - 3)) << ' ' << MjcfNumber(half * (h - 3)) << " 0\" size=\""
      << MjcfNumber(half * w) << ' ' << MjcfNumber(half * h) << " 0.1\" rgba=\"0.8 0.9 0.8 1\"/>\n";
    for (int i = 0; i < h; ++i) {
      for (int j = 0; j < w; ++j) {
        if (!maze->IsWall({i, j})) continue;
        const Eigen::Vector2d c = maze->CellCenter({i, j});
        x << "    <geom name=\"block_" << i << '_' << j << "\" type=\"box\" pos=\""
          << MjcfNumber(c.x()) << ' ' << MjcfNumber(c.y()) << ' ' << MjcfNumber(kWallHeight / 2)
          << "\" size=\"" << MjcfNumber(half) << ' ' << MjcfNumber(half) << ' '
          << MjcfNumber(kWallHeight / 2)
          << "\" contype=\"1\" conaffinity=\"1\" rgba=\"0.7 0.5 0.3 1\"/>\n";
      }
    }
  } else {
    x << "    <geom name=\"floor\" type=\"plane\" conaffinity=\"1\" pos=\"0 0 0\" size=\""
      << MjcfNumber(open_floor_half_size) << ' ' << MjcfNumber(open_floor_half_size)
      << " 40\" rgba=\"0.8 0.9 0.8 1\"/>\n";
  }
  x << "    <body name=\"torso\" pos=\"0 0 " << MjcfNumber(kAntTorsoHeight) << "\">\n"
    << "      <camera name=\"track\" mode=\"trackcom\" pos=\"0 -3 0.3\" xyaxes=\"1 0 0 0 0 1\"/>\n"
    << "      <geom name=\"torso_geom\" type=\"sphere\" size=\"0.25\" pos=\"0 0 0\"/>\n"
    << "      <joint name=\"root\" type=\"free\" pos=\"0 0 0\" armature=\"0\" damping=\"0\""
    << " limited=\"false\"/>\n";
  for (const Leg& leg : kLegs) WriteLeg(x, leg);
  x << "    </body>\n"
    << "  </worldbody>\n"
    << "  <actuator>\n";
  for (const char* joint : kAntActuatorJoints) {
    x << "    <motor joint=\"" << joint << "\" ctrllimited=\"true\" ctrlrange=\"-1 1\" gear=\""
      << MjcfNumber(kAntGear) << "\"/>\n";
  }
  x << "  </actuator>\n"
    << "</mujoco>\n";
  return x.str();
}

}  // namespace msspr::sim
