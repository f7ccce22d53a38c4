#!/usr/bin/env bash
# Installs the built package into a temporary directory (DESTDIR=DIR cmake
# --install BUILD: the configured CMAKE_INSTALL_PREFIX under DIR, where catkin
# also writes setup.bash) and runs the demo from that install space: the sim
# and msspr_policy_node serving the installed state checkpoint, evaluated by
# msspr_eval, one episode per task. The demo runs in an environment that holds
# only the install space (env -i, then PREFIX/setup.bash), from a directory
# outside the source tree. Checks: the installed files, the executables' shared
# libraries (none from the devel space), no installed text file naming the
# source tree, `rospack find msspr`, the checkpoint the policy node loaded
# (under PREFIX), results.json (five tasks, one episode each), and an in-process
# cube-single episode on the installed arm URDF. Registered as
# the ctest check_install; needs the package built (make build).
#
#   scripts/check_install.sh [BUILD_DIR]       (default: build)
#   MSSPR_KEEP_INSTALL=1 scripts/check_install.sh    keep the prefix and logs
set -uo pipefail
export PATH=/usr/bin:/bin:$PATH
SRC=$(cd "$(dirname "$0")/.." && pwd)
BUILD=$(cd "${1:-$SRC/build}" && pwd) || exit 1
WORK=$(mktemp -d /tmp/msspr-install-check.XXXXXX)
CONFIGURED=$(sed -n 's/^CMAKE_INSTALL_PREFIX:PATH=//p' "$BUILD/CMakeCache.txt")
[ -n "$CONFIGURED" ] || { echo "check_install: no CMAKE_INSTALL_PREFIX in $BUILD/CMakeCache.txt" >&2; exit 1; }
PREFIX=$WORK/root$CONFIGURED
if [ "${MSSPR_KEEP_INSTALL:-0}" = 1 ]; then
  echo "check_install: keeping $WORK"
else
  trap 'rm -rf "$WORK"' EXIT
fi
fail() {
  echo "check_install: FAILED: $*" >&2
  exit 1
}

# 1. The install space.
if ! DESTDIR=$WORK/root cmake --install "$BUILD" >"$WORK/install.log" 2>&1; then
  tail -20 "$WORK/install.log" >&2
  fail "DESTDIR=$WORK/root cmake --install $BUILD"
fi
outside=$(grep -E '^-- (Installing|Up-to-date): ' "$WORK/install.log" | grep -v -- "$WORK/root/")
[ -z "$outside" ] || fail "installed outside DESTDIR:"$'\n'"$outside"
SHARE=$PREFIX/share/msspr
for f in setup.bash _setup_util.py \
  lib/msspr/msspr_sim_node lib/msspr/msspr_policy_node lib/msspr/msspr_eval lib/msspr/msspr_expert_node \
  lib/msspr/msspr_cube_oracle_node lib/msspr/msspr_collect lib/msspr/msspr_bag_info lib/msspr/msspr_train \
  lib/msspr/msspr_eval_inprocess lib/msspr/msspr_value_map lib/msspr/msspr_collect_npz \
  lib/msspr/msspr_bench_core lib/msspr/msspr_average_policies lib/msspr/msspr_make_tasks lib/msspr/msspr_train_expert lib/msspr/msspr_eval_ant_expert \
  lib/msspr/msspr_compare share/msspr/config/grids/hard_tasks.yaml \
  lib/libmsspr_core.so lib/libmsspr_env.so lib/libmsspr_eval_core.so lib/libmsspr_bridge.so lib/libmsspr_bags.so lib/libmsspr_robot_interface.so lib/libmsspr_sim_nodes.so lib/libmsspr_maze_map.so \
  include/msspr/Observation.h include/msspr/Reset.h include/msspr_core/policy.h \
  include/msspr_bridge/msg_conversion.h include/msspr_bags/dataset_bag.h \
  include/msspr_robot_interface/spec_bag.h include/msspr_sim_nodes/sim_node_base.h \
  include/msspr_sim/point_maze.h include/msspr_eval/maze_evaluator.h \
  share/msspr/package.xml share/msspr/msgs/msg/Observation.msg share/msspr/msgs/srv/Reset.srv \
  share/msspr/launch/demo.launch share/msspr/launch/sim.launch share/msspr/launch/policy.launch \
  share/msspr/launch/msspr.rviz share/msspr/config/pointmaze_cpu.yaml \
  share/msspr/config/robots/pointmaze_base.yaml share/msspr/config/robots/ur5e_cube.yaml \
  share/msspr/config/robots/pointmaze_camera.yaml \
  share/msspr/msspr_sim/urdf/point_robot.urdf share/msspr/msspr_sim/urdf/ur5e_2f85.urdf \
  share/msspr/msspr_sim/urdf/ant.urdf share/msspr/msspr_sim/experts/ant_xy_expert.pt \
  share/msspr/msspr_policy_node/checkpoints/pointmaze-medium-state.pt \
  share/msspr/msspr_policy_node/checkpoints/pointmaze-medium-pixels.pt \
  share/msspr/msspr_policy_node/checkpoints/cube-single-state.pt \
  share/msspr/msspr_policy_node/checkpoints/antmaze-medium-state.pt \
  share/msspr/config/locomotion_cpu.yaml; do
  [ -e "$PREFIX/$f" ] || fail "not installed: $f"
done
for f in "$SHARE"/launch/*.launch; do
  cmp -s "$f" "$SRC/launch/$(basename "$f")" || fail "installed $(basename "$f") differs from launch/"
done
echo "check_install: installed into $PREFIX ($(find "$PREFIX" -type f | wc -l) files)"

# 2. Nothing installed points back into the source tree or the devel space.
# The default prefix is SRC/install (a fresh configure), so paths inside the
# install prefix (as configured, or under DESTDIR) are masked before looking
# for SRC: only a path into the rest of the source tree counts.
names_src() {  # stdin: text; prints the lines naming SRC outside the prefix
  local line
  while IFS= read -r line; do
    line=${line//"$PREFIX"/@PREFIX@}
    line=${line//"$CONFIGURED"/@PREFIX@}
    [[ $line == *"$SRC"* ]] && printf '%s\n' "$line"
  done
  return 0
}
hits=""
while IFS= read -r f; do
  [ -n "$(names_src <"$f")" ] && hits+="$f: $(names_src <"$f" | head -1)"$'\n'
done < <(grep -rIl -- "$SRC" "$PREFIX" 2>/dev/null)
[ -z "$hits" ] || fail "installed text files name the source tree $SRC:"$'\n'"$hits"
for exe in "$PREFIX"/lib/msspr/*; do
  libs=$(env -i PATH=/usr/bin:/bin LD_LIBRARY_PATH="$PREFIX/lib" ldd "$exe" 2>&1)
  if grep -q 'not found' <<<"$libs"; then fail "$exe: $(grep 'not found' <<<"$libs" | head -3)"; fi
  from_src=$(names_src <<<"$libs")
  [ -z "$from_src" ] || fail "$exe links from the source tree: $(head -3 <<<"$from_src")"
done

# 3. The demo from the install space alone.
PORT=$(python3 "$SRC/scripts/free_port.py" $$) || fail "no free port for the ROS master"
mkdir -p "$WORK/run" "$WORK/ros_home/log"
env -i HOME="$WORK/run" PATH=/usr/bin:/bin LANG=C.UTF-8 OMP_NUM_THREADS=1 \
  ROS_HOME="$WORK/ros_home" ROS_LOG_DIR="$WORK/ros_home/log" \
  ROS_MASTER_URI="http://127.0.0.1:$PORT" ROS_IP=127.0.0.1 \
  bash -c '
    source "$1/setup.bash" || exit 1
    cd "$2" || exit 1
    env | grep -E "^(ROS_PACKAGE_PATH|CMAKE_PREFIX_PATH|LD_LIBRARY_PATH)=" > env.txt
    rospack find msspr > rospack_find.txt 2>&1
    timeout -k 10 150 roslaunch -p "$3" msspr demo.launch episodes:=1 out_dir:="$2/demo"
    rc=$?
    # The arm of cube-single, found without ROS through the package path (sim::DefaultArmUrdf).
    timeout 120 rosrun msspr msspr_eval_inprocess --env cube-single --tasks 1 --episodes 1 --threads 1 \
      --policy "$(rospack find msspr)/msspr_policy_node/checkpoints/cube-single-state.pt" >cube_eval.log 2>&1 ||
      echo "msspr_eval_inprocess --env cube-single failed: $?" >>cube_eval.log
    exit $rc
  ' _ "$PREFIX" "$WORK/run" "$PORT" >"$WORK/roslaunch.log" 2>&1
rc=$?
show_log() { tail -40 "$WORK/roslaunch.log" >&2; }
[ "$(cat "$WORK/run/rospack_find.txt")" = "$SHARE" ] ||
  fail "rospack find msspr gave '$(cat "$WORK/run/rospack_find.txt")', not $SHARE"
[ -z "$(names_src <"$WORK/run/env.txt")" ] || fail "the environment names the source tree: $(cat "$WORK/run/env.txt")"
[ "$rc" -ne 124 ] && [ "$rc" -ne 137 ] || { show_log; fail "the demo did not finish within 150 s"; }
RESULTS=$WORK/run/demo/results.json
[ -s "$RESULTS" ] || { show_log; fail "the demo wrote no results.json (roslaunch exit $rc)"; }
grep -q "loaded $SHARE/msspr_policy_node/checkpoints/pointmaze-medium-state.pt" "$WORK/roslaunch.log" ||
  { show_log; fail "the policy node did not load the installed checkpoint"; }
grep -q "; arm $SHARE/msspr_sim/urdf/ur5e_2f85.urdf)" "$WORK/run/cube_eval.log" &&
  ! grep -q failed "$WORK/run/cube_eval.log" ||
  { cat "$WORK/run/cube_eval.log" >&2; fail "msspr_eval_inprocess --env cube-single did not run on the installed arm"; }
python3 - "$RESULTS" <<'EOF' || { show_log; fail "results.json"; }
import json, sys
r = json.load(open(sys.argv[1]))
assert r["env"].startswith("pointmaze"), r["env"]
assert r["agent"] == "msspr-state", r["agent"]
assert r["episodes_per_task"] == 1, r["episodes_per_task"]
assert [t["task_id"] for t in r["tasks"]] == [1, 2, 3, 4, 5], r["tasks"]
assert all(t["episodes"] == 1 for t in r["tasks"]), r["tasks"]
assert 0.0 <= r["mean_success"] <= 1.0
print(f"check_install: demo from the install space: {r['env']} / {r['agent']}, "
      f"mean success {100 * r['mean_success']:.0f}% over 5 tasks x 1 episode, {r['wall_time_s']:.1f} s")
EOF
echo "check_install: passed"
