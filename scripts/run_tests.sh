#!/usr/bin/env bash
# Runs every test (gtest units, rostest scenarios, checks) through ctest and
# ends with the line "N passed, N failed".
set -uo pipefail
BUILD=${1:-build}
. "$(dirname "$0")/bench_lib.sh"  # tool_blas_core
cd "$BUILD" || { echo "no build dir $BUILD (run make build)"; echo "0 passed, 1 failed"; exit 1; }
export PATH=/usr/bin:/bin:$PATH
export ROS_HOME=${ROS_HOME:-$PWD/ros_home}
export ROS_LOG_DIR=${ROS_LOG_DIR:-$ROS_HOME/log}
export OMP_NUM_THREADS=${OMP_NUM_THREADS:-2}
mkdir -p "$ROS_LOG_DIR"
# Every process of the run gets the environment msspr's tools give themselves
# (msspr_core/process_env.h): OMP_WAIT_POLICY=PASSIVE, and OpenBLAS's kernels for this CPU
# where it would pick its generic ones. Set once here, so that no LibTorch-linked test
# re-executes itself to get them (tests/core/tool_env_gtest_main.cc).
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY-PASSIVE}
devel=$(sed -n 's/^CATKIN_DEVEL_PREFIX:[A-Z]*=//p' CMakeCache.txt 2>/dev/null)
tool=${devel:-$PWD/devel}/lib/msspr/msspr_bench_core
if [ -z "${OPENBLAS_CORETYPE+x}" ] && [ -x "$tool" ]; then
  core=$(tool_blas_core "$tool")
  if [ -n "$core" ]; then
    export OPENBLAS_CORETYPE=$core
    echo "run_tests: OPENBLAS_CORETYPE=$core (the OpenBLAS kernels msspr's tools use on this CPU)"
  fi
fi
log=$PWD/ctest.log
# One test more than there are cores (MSSPR_TEST_JOBS=N to change it): many tests wait for a
# while (ROS masters and nodes starting, lockstep round trips, child processes), and at one
# test per core the suite used about 1.42 of 2 cores (734 CPU-seconds; 517 s; 2-core Intel
# Xeon, family 6, model 207). The tests that step a sim in real time are RUN_SERIAL and run alone.
JOBS=${MSSPR_TEST_JOBS:-$(($(nproc 2>/dev/null || echo 1) + 1))}
ctest --output-on-failure --timeout 900 -j "$JOBS" "${@:2}" 2>&1 | tee "$log"
rc=${PIPESTATUS[0]}
total=$(grep -oE 'tests failed out of [0-9]+' "$log" | tail -1 | grep -oE '[0-9]+$')
failed=$(grep -oE '[0-9]+ tests failed out of' "$log" | tail -1 | grep -oE '^[0-9]+')
if [ -z "$total" ]; then
  echo "ctest gave no summary (exit $rc)"
  echo "0 passed, 1 failed"
  exit 1
fi
echo "$((total - failed)) passed, ${failed} failed"
[ "$rc" -eq 0 ] && [ "$failed" -eq 0 ]
