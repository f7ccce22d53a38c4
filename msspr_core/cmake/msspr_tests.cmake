# What every test directory of the package shares (include it in each: the variable below is
# directory-scoped).
#
# MSSPR_TEST_COMPILE_OPTIONS: the test executables' own code compiles at -O1 in optimised builds.
# The code under test lives in the libraries, built as configured (-O3 in Release); -O1 took
# about a quarter less time than -O3 on a test translation unit (21.3 s against 29.3 s) and
# still uses the precompiled <torch/torch.h> (the same __OPTIMIZE__ macros).
set(MSSPR_TEST_COMPILE_OPTIONS $<$<CONFIG:Release,RelWithDebInfo,MinSizeRel>:-O1>)

# msspr_gtest_suites(TARGET [TEST_PREFIX P] [LONG_SUITES SUITE...] [PROPERTIES NAME VALUE...])
#
# Registers a gtest executable's tests with ctest, one ctest test per test suite
# (`TARGET --gtest_filter=Suite.*`, named P + Suite), and one per case for the suites named
# in LONG_SUITES (long cases, so that ctest -j spreads them over the cores; they also get a
# high COST, so that a first run without timing history starts them early).
#
# Why not gtest_discover_tests (one process per case): every process of a LibTorch-linked
# test pays LibTorch's start-up, about half a second of CPU (11 cases of one suite took 8.2
# CPU-seconds as 11 processes, 0.7 as one). The cases of a suite share one process instead.
#
# As with gtest_discover_tests(... DISCOVERY_MODE PRE_TEST), the executable is asked for its
# tests (--gtest_list_tests) when ctest runs, so the list is never stale; an executable that
# is not built registers one failing test that says so. PROPERTIES are set on every test
# (values must not contain ';'). Tests run in the calling directory's binary directory.
function(msspr_gtest_suites target)
  cmake_parse_arguments(A "" "TEST_PREFIX" "LONG_SUITES;PROPERTIES" ${ARGN})
  set(props "")
  foreach(p IN LISTS A_PROPERTIES)
    string(APPEND props " [==[${p}]==]")
  endforeach()
  set(per_case "")
  foreach(s IN LISTS A_LONG_SUITES)
    string(APPEND per_case " [==[${s}]==]")
  endforeach()
  set(script "${CMAKE_CURRENT_BINARY_DIR}/${target}_ctest_suites.cmake")
  file(GENERATE OUTPUT "${script}" CONTENT
"set(_msspr_exe [==[$<TARGET_FILE:${target}>]==])
set(_msspr_prefix [==[${A_TEST_PREFIX}]==])
set(_msspr_per_case${per_case})
set(_msspr_props${props})
set(_msspr_workdir [==[${CMAKE_CURRENT_BINARY_DIR}]==])
include([==[${CMAKE_CURRENT_FUNCTION_LIST_DIR}/msspr_gtest_suites_add.cmake]==])
")
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES "${script}")
endfunction()
