#!/usr/bin/env bash
# The same checkpoint on the same episodes gives the same outcomes over ROS (msspr_sim_node +
# msspr_policy_node + msspr_eval, demo.launch in lockstep) and in process
# (msspr_eval_inprocess): per task, the same success rate and the same mean steps of the
# successful episodes, for the shipped point-maze, cube-single, antmaze-medium and scene
# checkpoints.
#   tests/scripts/ros_equals_inprocess.sh   (from the repository root, after the build)
set -euo pipefail
cd "$(dirname "$0")/../.."
source scripts/ros_env.sh
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT
fail() { echo "ros_equals_inprocess: FAILED: $*" >&2; exit 1; }
C=msspr_policy_node/checkpoints
# env, checkpoint, episodes per task
for CASE in "pointmaze pointmaze-medium-state.pt 3" "cube-single cube-single-state.pt 3" \
            "antmaze-medium antmaze-medium-state.pt 2" "scene scene-state.pt 2"; do
  read -r ENV CKPT EPISODES <<<"$CASE"
  timeout 300 roslaunch -p "$MSSPR_PORT" msspr demo.launch env:="$ENV" episodes:="$EPISODES" \
    out_dir:="$TMP/$ENV" >"$TMP/$ENV.log" 2>&1 || { rc=$?; tail -20 "$TMP/$ENV.log" >&2; fail "$ENV: demo.launch exited $rc"; }
  [ -s "$TMP/$ENV/results.json" ] || { tail -20 "$TMP/$ENV.log" >&2; fail "$ENV: no results.json over ROS"; }
  rosrun msspr msspr_eval_inprocess --policy "$C/$CKPT" --env "$ENV" --episodes "$EPISODES" --threads 1 \
    --out "$TMP/$ENV-inprocess.json" >"$TMP/$ENV-inprocess.log" 2>&1 ||
    { rc=$?; cat "$TMP/$ENV-inprocess.log" >&2; fail "$ENV: msspr_eval_inprocess exited $rc"; }
  python3 - "$ENV" "$TMP/$ENV/results.json" "$TMP/$ENV-inprocess.json" <<'PY' || fail "$ENV: the outcomes differ"
import json, sys
env, ros, inproc = sys.argv[1], json.load(open(sys.argv[2])), json.load(open(sys.argv[3]))
assert len(ros["tasks"]) == len(inproc["tasks"]) == 5, (len(ros["tasks"]), len(inproc["tasks"]))
for a, b in zip(ros["tasks"], inproc["tasks"]):
    assert a["task_id"] == b["task_id"], (a["task_id"], b["task_id"])
    assert a["episodes"] == b["episodes"], (a, b)
    assert abs(a["success"] - b["success"]) < 1e-6, f"task {a['task_id']}: {a['success']} over ROS, {b['success']} in process"
    sa, sb = a.get("mean_steps_successful"), b.get("mean_steps_successful")
    assert (sa is None) == (sb is None) and (sa is None or abs(sa - sb) < 1e-3), \
        f"task {a['task_id']}: mean steps {sa} over ROS, {sb} in process"
print(f"{env}: the same outcomes over ROS and in process, per task: "
      + " ".join(f"{100 * t['success']:.0f}%" for t in ros["tasks"]))
PY
done
echo "ros_equals_inprocess: passed"
