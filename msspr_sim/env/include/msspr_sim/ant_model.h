// OGBench's ant (locomaze/assets/ant.xml) as MJCF text built in code, alone
// on an open floor (online-ant-xy) or inside a maze of maze_map.h
// (antmaze-*): timestep 0.02 s, RK4, 5 physics steps per control step.
#ifndef MSSPR_SIM_ANT_MODEL_H_
#define MSSPR_SIM_ANT_MODEL_H_

#include <Eigen/Core>
#include <array>
#include <string>

#include "msspr_sim/maze_map.h"

namespace msspr::sim {

// qpos: x, y, z, quaternion (w, x, y, z), then the 8 hinges (kAntHingeJoints).
inline constexpr int kAntQposDim = 15;
// qvel: 6 root velocities (linear, then angular), then the 8 hinges.
inline constexpr int kAntQvelDim = 14;
inline constexpr int kAntActionDim = 8;
// Physics timestep (s) and physics steps per control step: 10 Hz control.
inline constexpr double kAntTimestep = 0.02;
inline constexpr int kAntFrameSkip = 5;
// Height of the torso's centre in qpos0 (m).
inline constexpr double kAntTorsoHeight = 0.75;
// Motor gear (N m per unit control).
inline constexpr double kAntGear = 30.0;

// The hinges in qpos / qvel order (the order of the body tree): qpos[7 + k],
// qvel[6 + k].
inline constexpr std::array<const char*, 8> kAntHingeJoints = {
    "hip_1", "ankle_1", "hip_2", "ankle_2", "hip_3", "ankle_3", "hip_4", "ankle_4"};
// The joint each actuator drives, in OGBench's actuator (= action) order,
// which is not the qpos order.
inline constexpr std::array<const char*, 8> kAntActuatorJoints = {
    "hip_4", "ankle_4", "hip_1", "ankle_1", "hip_2", "ankle_2", "hip_3", "ankle_3"};

// qpos0 = (0, 0, 0.75, 1, 0, 0, 0, 0 x 8); OGBench's XML `init_qpos` is not used.
Eigen::Matrix<double, kAntQposDim, 1> AntQpos0();

// The MJCF of the ant. With a maze: a box wall (name "block_I_J") per wall
// cell at (4j - 4, 4i - 4, 1), half-size (2, 2, 1), and the floor plane
// centred at (2(W - 3), 2(H - 3)) with half-size (2W, 2H) (W columns, H rows).
// Without one (maze == nullptr): the floor plane alone, centred at the
// origin with half-size open_floor_half_size. Body "torso" on free joint
// "root"; the floor geom is "floor".
std::string AntMjcf(const MazeMap* maze, double open_floor_half_size = 40.0);

}  // namespace msspr::sim

#endif  // MSSPR_SIM_ANT_MODEL_H_
