// The msspr tools' command-line parser lives in the ROS-free core headers
// (msspr_core/cli_args.h, header-only) so that every tool shares it.
#pragma once

#include "msspr_core/cli_args.h"

namespace msspr::ros_bridge {
using cli::CliArgs;
using cli::CliError;
}  // namespace msspr::ros_bridge
