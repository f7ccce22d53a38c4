#!/usr/bin/env bash
# collect.launch env:=cube-single robot:=ur5e_cube records the arm's standard topics while the
# play oracle drives it through ee_twist and gripper_command (the sim in real time, 1.5 s of sim
# time between episodes): msspr_bag_info --robot config/robots/ur5e_cube.yaml finds every
# episode whole (split by the gap), and msspr_train --robot trains on the bag.
#   tests/scripts/collect_robot_cube.sh   (from the repository root, after the build)
set -euo pipefail
cd "$(dirname "$0")/../.."
source scripts/ros_env.sh
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
fail() { echo "collect_robot_cube: FAILED: $*" >&2; exit 1; }
timeout 240 roslaunch -p "$MSSPR_PORT" msspr collect.launch env:=cube-single robot:=ur5e_cube \
  episodes:=3 val_episodes:=0 episode_length:=60 seed:=3 bag:="$TMP/arm.bag" >"$TMP/launch.log" 2>&1 ||
  { tail -20 "$TMP/launch.log" >&2; fail "collect.launch exited $?"; }
[ -s "$TMP/arm.bag" ] || { tail -20 "$TMP/launch.log" >&2; fail "no bag written"; }
# Exit 1 (problems, e.g. a command that missed its tick in real time) still reads the bag;
# 2 is nothing usable.
STATUS=0
INFO=$(rosrun msspr msspr_bag_info --robot config/robots/ur5e_cube.yaml "$TMP/arm.bag" 2>&1) || STATUS=$?
echo "$INFO"
[ "$STATUS" -le 1 ] || fail "msspr_bag_info exited $STATUS"
# 3 episodes of 60 steps, each found by the gap; in real time on a loaded machine a command
# may miss its tick, so at least 95% of the ticks are complete.
LINE=$(grep "^episodes:" <<<"$INFO")
[[ $LINE =~ ^episodes:\ +3\ \(split\ by\ gap\),\ 180\ ticks,\ ([0-9]+)\ with ]] ||
  fail "expected 3 episodes of 60 ticks split by the gap, got: $LINE"
[ "${BASH_REMATCH[1]}" -ge 171 ] || fail "only ${BASH_REMATCH[1]} of 180 ticks complete: $LINE"
rosrun msspr msspr_train --data "$TMP/arm.bag" --robot config/robots/ur5e_cube.yaml --scale cpu \
  --steps 2 --batch 16 --eval-every 0 --threads 1 --quiet --out "$TMP/run" >"$TMP/train.log" 2>&1 ||
  { cat "$TMP/train.log" >&2; fail "msspr_train exited $?"; }
[ -s "$TMP/run/policy.pt" ] || fail "msspr_train wrote no policy"
echo "collect_robot_cube: passed"
