# Install destinations of the ROS-free subprojects (msspr_core, msspr_sim/env,
# msspr_sim/eval). Built inside the ROS package, its top-level CMakeLists sets
# them (tools in lib/msspr); standalone, GNU's bin, lib and include.
if(NOT DEFINED MSSPR_INSTALL_BIN_DIR)
  include(GNUInstallDirs)
  set(MSSPR_INSTALL_BIN_DIR ${CMAKE_INSTALL_BINDIR})
  set(MSSPR_INSTALL_LIB_DIR ${CMAKE_INSTALL_LIBDIR})
  set(MSSPR_INSTALL_INCLUDE_DIR ${CMAKE_INSTALL_INCLUDEDIR})
endif()
