// The arm and the cube-single options the sim tests share.
#pragma once

#include <string>

#include "msspr_sim/cube_env.h"

namespace msspr::sim::testing_util {

// The package's arm (msspr_sim/urdf/ur5e_2f85.urdf).
inline std::string ArmUrdfPath() {
  return std::string(MSSPR_SOURCE_DIR) + "/msspr_sim/urdf/ur5e_2f85.urdf";
}

// CubeEnv's defaults on the package's arm.
inline CubeEnvOptions CubeOptions() {
  CubeEnvOptions o;
  o.urdf_path = ArmUrdfPath();
  return o;
}

}  // namespace msspr::sim::testing_util
