#include "msspr_sim/package_files.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

#ifndef MSSPR_PACKAGE_SOURCE_DIR
#error "MSSPR_PACKAGE_SOURCE_DIR (the package's source tree) must be defined by the build"
#endif

namespace msspr::sim {
namespace {

namespace fs = std::filesystem;

// True when dir/package.xml declares the package msspr.
bool IsMssprPackage(const fs::path& dir) {
  std::ifstream in(dir / "package.xml");
  if (!in) return false;
  std::stringstream text;
  text << in.rdbuf();
  return text.str().find("<name>msspr</name>") != std::string::npos;
}

bool IsFile(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

}  // namespace

std::vector<std::string> PackageDirCandidates() {
  std::vector<std::string> dirs;
  if (const char* env = std::getenv("MSSPR_PACKAGE_DIR"); env && *env) dirs.emplace_back(env);
  if (const char* rpp = std::getenv("ROS_PACKAGE_PATH"); rpp && *rpp) {
    std::stringstream entries(rpp);
    std::string entry;
    while (std::getline(entries, entry, ':')) {
      if (entry.empty()) continue;
      for (const fs::path& d : {fs::path(entry), fs::path(entry) / "msspr"})
        if (IsMssprPackage(d)) dirs.push_back(d.string());
    }
  }
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path bin = exe.parent_path();
    // lib/msspr/TOOL (catkin's CATKIN_PACKAGE_BIN_DESTINATION) or bin/TOOL.
    for (const fs::path& d : {bin.parent_path().parent_path() / "share" / "msspr",
                              bin.parent_path() / "share" / "msspr"})
      if (IsMssprPackage(d)) dirs.push_back(d.string());
  }
  dirs.emplace_back(MSSPR_PACKAGE_SOURCE_DIR);
  return dirs;
}

std::string PackageFile(const std::string& relative) {
  for (const std::string& d : PackageDirCandidates()) {
    const fs::path p = fs::path(d) / relative;
    if (IsFile(p)) return p.string();
  }
  return (fs::path(MSSPR_PACKAGE_SOURCE_DIR) / relative).string();
}

std::string DefaultArmUrdf() { return PackageFile("msspr_sim/urdf/ur5e_2f85.urdf"); }

std::string DefaultAntExpert() { return PackageFile("msspr_sim/experts/ant_xy_expert.pt"); }

}  // namespace msspr::sim
