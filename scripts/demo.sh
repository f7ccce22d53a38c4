#!/usr/bin/env bash
# make demo: sim + agent on pointmaze-medium over roslaunch, evaluated on the five
# tasks; prints the per-task table and writes build/demo/{results.json,trajectories.png}.
set -euo pipefail
BUILD=${1:-build}
cd "$(dirname "$0")/.."
source scripts/ros_env.sh
OUT=$PWD/$BUILD/demo
mkdir -p "$OUT"
rm -f "$OUT/results.json"
echo "[demo] pointmaze-medium, scripted expert (noise-free) in lockstep over ROS; master on $ROS_MASTER_URI"
LOG=$OUT/roslaunch.log
echo "[demo] running sim + agent + evaluator (log: $LOG) ..."
roslaunch -p "$MSSPR_PORT" msspr expert_demo.launch out_dir:="$OUT" episodes:="${DEMO_EPISODES:-20}" >"$LOG" 2>&1 || true
grep -E "msspr_eval: task" "$LOG" | sed -E 's/^.*(msspr_eval: task)/[demo] \1/; s/\x1b\[[0-9;]*m//g' || true
if [ ! -s "$OUT/results.json" ]; then
  echo "[demo] failed: no $OUT/results.json (see logs in $ROS_LOG_DIR)" >&2
  exit 1
fi
python3 scripts/print_results.py "$OUT/results.json"
echo "[demo] wrote $OUT/results.json and $OUT/trajectories.png"
