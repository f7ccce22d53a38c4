#!/usr/bin/env bash
# collect.launch env:=cube-single robot:=ROBOT records the arm's standard topics while the play
# oracle drives it through ee_twist and gripper_command (the sim in real time, 1.5 s of sim
# time between episodes): msspr_bag_info --robot config/robots/ROBOT.yaml finds every episode
# whole (split by the gap), and msspr_train --robot trains on the bag.
#   tests/scripts/collect_robot_cube.sh [ur5e_cube]   (from the repository root, after the build)
#   tests/scripts/collect_robot_cube.sh ur5e_cube_camera
# With ur5e_cube_camera the bag also holds the front camera's images: every tick has its
# image, a pixels policy is trained through the camera spec, then served through it over ROS
# (demo.launch robot:=ur5e_cube_camera, one episode per task) from images only.
set -euo pipefail
cd "$(dirname "$0")/../.."
ROBOT=${1:-ur5e_cube}
case "$ROBOT" in
  ur5e_cube | ur5e_cube_camera) ;;
  *) echo "collect_robot_cube: ROBOT must be ur5e_cube or ur5e_cube_camera, not '$ROBOT'" >&2; exit 2 ;;
esac
SPEC=config/robots/$ROBOT.yaml
source scripts/ros_env.sh
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
fail() { echo "collect_robot_cube ($ROBOT): FAILED: $*" >&2; exit 1; }
timeout 240 roslaunch -p "$MSSPR_PORT" msspr collect.launch env:=cube-single robot:="$ROBOT" \
  episodes:=2 val_episodes:=0 episode_length:=50 seed:=3 bag:="$TMP/arm.bag" >"$TMP/launch.log" 2>&1 ||
  { rc=$?; tail -20 "$TMP/launch.log" >&2; fail "collect.launch exited $rc"; }
[ -s "$TMP/arm.bag" ] || { tail -20 "$TMP/launch.log" >&2; fail "no bag written"; }
# Exit 1 (problems, e.g. a command that missed its tick in real time) still reads the bag;
# 2 is nothing usable.
STATUS=0
INFO=$(rosrun msspr msspr_bag_info --robot "$SPEC" "$TMP/arm.bag" 2>&1) || STATUS=$?
echo "$INFO"
[ "$STATUS" -le 1 ] || fail "msspr_bag_info exited $STATUS"
# 2 episodes of 50 steps, found by the gap between them; in real time on a loaded machine a
# command may miss its tick, so at least 95% of the ticks are complete.
LINE=$(grep "^episodes:" <<<"$INFO")
[[ $LINE =~ ^episodes:\ +2\ \(split\ by\ gap\),\ 100\ ticks,\ ([0-9]+)\ with ]] ||
  fail "expected 2 episodes of 50 ticks split by the gap, got: $LINE"
[ "${BASH_REMATCH[1]}" -ge 95 ] || fail "only ${BASH_REMATCH[1]} of 100 ticks complete: $LINE"
TRAIN=(--scale cpu)
if [ "$ROBOT" = ur5e_cube_camera ]; then
  # The camera's row: about one image per tick (20 Hz), none rejected.
  IMAGE=$(grep "^image:" <<<"$INFO") || fail "msspr_bag_info printed no image line"
  [[ $IMAGE =~ :\ ([0-9]+)\ images\ at ]] || fail "no image count in: $IMAGE"
  [ "${BASH_REMATCH[1]}" -ge 95 ] || fail "only ${BASH_REMATCH[1]} camera images for 100 ticks: $IMAGE"
  [[ $IMAGE =~ \ 0\ bad\ images ]] || fail "bad images in the recording: $IMAGE"
  TRAIN=(--observation-mode pixels --config config/cube_pixels_cpu.yaml)
fi
rosrun msspr msspr_train --data "$TMP/arm.bag" --robot "$SPEC" "${TRAIN[@]}" \
  --steps 2 --batch 16 --eval-every 0 --threads 1 --quiet --out "$TMP/run" >"$TMP/train.log" 2>&1 ||
  { rc=$?; cat "$TMP/train.log" >&2; fail "msspr_train exited $rc"; }
[ -s "$TMP/run/policy.pt" ] || fail "msspr_train wrote no policy"
if [ "$ROBOT" = ur5e_cube_camera ]; then
  # Served through the camera spec: the sim's camera and goal images in, ee_twist and
  # gripper_command out; one episode of each of the five tasks.
  timeout 240 roslaunch -p "$MSSPR_PORT" msspr demo.launch env:=cube-single robot:="$ROBOT" observation_mode:=pixels \
    cube_pixel_checkpoint:="$TMP/run/policy.pt" episodes:=1 out_dir:="$TMP/demo" >"$TMP/demo.log" 2>&1 ||
    { rc=$?; tail -20 "$TMP/demo.log" >&2; fail "demo.launch exited $rc"; }
  RESULTS=$TMP/demo/results.json
  [ -s "$RESULTS" ] || { tail -20 "$TMP/demo.log" >&2; fail "no results.json"; }
  python3 - "$RESULTS" <<'PY' || fail "results.json: $(cat "$RESULTS")"
import json, sys
r = json.load(open(sys.argv[1]))
assert r["robot"] == "ur5e_cube_camera", r.get("robot")
assert r["observation_mode"] == "pixels", r.get("observation_mode")
assert len(r["tasks"]) == 5, len(r["tasks"])
assert all(t["episodes"] == 1 for t in r["tasks"]), r["tasks"]
print("served through the camera spec: %d tasks, mean success %.2f" % (len(r["tasks"]), r["mean_success"]))
PY
fi
echo "collect_robot_cube ($ROBOT): passed"
