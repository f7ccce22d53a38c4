// The files the msspr package ships (URDFs, configs, checkpoints), found
// without ROS both in the source tree and in an install space, where catkin
// puts them under share/msspr (CATKIN_PACKAGE_SHARE_DESTINATION) with the
// same relative paths (e.g. msspr_sim/urdf/ur5e_2f85.urdf).
#ifndef MSSPR_SIM_PACKAGE_FILES_H_
#define MSSPR_SIM_PACKAGE_FILES_H_

#include <string>
#include <vector>

namespace msspr::sim {

// The package directories to look in, in this order:
//  1. $MSSPR_PACKAGE_DIR, when set;
//  2. the msspr package on ROS_PACKAGE_PATH (an entry, or its msspr/ child,
//     whose package.xml names msspr), as `rospack find msspr` would;
//  3. share/msspr beside the running executable's prefix (an installed tool in
//     lib/msspr/ or bin/);
//  4. the source tree the library was built from.
std::vector<std::string> PackageDirCandidates();

// The first candidate that holds `relative`; when none does, `relative` in the
// source tree (so that an error names a path).
std::string PackageFile(const std::string& relative);

// The cube-single arm: PackageFile("msspr_sim/urdf/ur5e_2f85.urdf").
std::string DefaultArmUrdf();

// The ant's shipped direction-following expert (sac_policy.pt of
// msspr_train_expert, seed 0, 400k steps): PackageFile("msspr_sim/experts/ant_xy_expert.pt").
std::string DefaultAntExpert();

}  // namespace msspr::sim

#endif  // MSSPR_SIM_PACKAGE_FILES_H_
