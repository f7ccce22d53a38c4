#!/usr/bin/env bash
# Soak: msspr_sim_node stepping in real time at 100 Hz (random episodes, auto
# reset) driven by msspr_policy_node (lockstep: one command per observation)
# for SECONDS (default 600), sampling every few seconds the resident memory of
# both nodes and the served rate (the policy node's commands per second, counted
# on its command topic by scripts/soak_sampler.py).
#   native: msspr/Observation in, msspr/Action out (the shipped state checkpoint);
#   robot:  the same checkpoint served through config/robots/pointmaze_base.yaml,
#           nav_msgs/Odometry + goal_pose in, geometry_msgs/Twist on cmd_vel out.
# Writes build/bench/soak_PATH.json (per node the RSS at the start, after a
# warm-up, at the end, the peak and the growth per hour; the served rate's mean,
# minimum and 5th percentile over the windows after the warm-up) and
# soak_samples_PATH.csv. Each run has a private ROS master, so two run side by side.
#   scripts/soak.sh [BUILD] [SECONDS] [native|robot]
#   MSSPR_SOAK_BIN=DIR: the node executables from DIR (a copy, so that a rebuild
#   during a long soak does not replace them); default the devel space's.
#   MSSPR_SOAK_S=600 make bench    runs both paths, one after the other
set -euo pipefail
BUILD=${1:-build}
SOAK_S=${2:-${MSSPR_SOAK_S:-600}}
SOAK_PATH=${3:-native}
cd "$(dirname "$0")/.."
source scripts/ros_env.sh
OUT=$PWD/$BUILD/bench
BIN=${MSSPR_SOAK_BIN:-$DEVEL/lib/msspr}
CKPT=$PWD/msspr_policy_node/checkpoints/pointmaze-medium-state.pt
SPEC=$PWD/config/robots/pointmaze_base.yaml
RATE=100
case "$SOAK_PATH" in
  native) TOPIC=/msspr/action; POLICY_ARGS=() ;;
  robot) TOPIC=/msspr/cmd_vel; POLICY_ARGS=(_robot:="$SPEC") ;;
  *) echo "[soak] path must be native or robot, got '$SOAK_PATH'" >&2; exit 2 ;;
esac
mkdir -p "$OUT"
[ -x "$BIN/msspr_policy_node" ] && [ -f "$CKPT" ] || { echo "[soak] needs msspr_policy_node and $CKPT" >&2; exit 1; }
PIDS=()
trap 'for p in "${PIDS[@]}"; do kill "$p" 2>/dev/null || true; done' EXIT
rosmaster --core -p "$MSSPR_PORT" >/dev/null 2>&1 &
PIDS+=($!)
for _ in $(seq 50); do rostopic list >/dev/null 2>&1 && break; sleep 0.2; done
LOG=$OUT/soak_$SOAK_PATH.log
ROS_NAMESPACE=msspr "$BIN/msspr_sim_node" _stepping:=realtime _control_rate:=$RATE.0 _auto_reset:=true \
  _episode_length:=1001 _num_episodes:=0 _publish_clock:=false >"$LOG.sim" 2>&1 &
SIM=$!
PIDS+=($SIM)
ROS_NAMESPACE=msspr "$BIN/msspr_policy_node" _checkpoint:="$CKPT" _mode:=lockstep "${POLICY_ARGS[@]}" >"$LOG.policy" 2>&1 &
POLICY=$!
PIDS+=($POLICY)
echo "[soak] $SOAK_PATH path: sim (pid $SIM) + policy (pid $POLICY) at $RATE Hz for $SOAK_S s, commands on $TOPIC"
PERIOD=$(( SOAK_S >= 120 ? 10 : 2 ))
WARMUP=$(( SOAK_S / 10 > 15 ? SOAK_S / 10 : 15 ))  # torch and the buffers settle first
WARMUP=$(( WARMUP > SOAK_S / 2 ? SOAK_S / 2 : WARMUP ))
SAMPLES=$OUT/soak_samples_$SOAK_PATH.csv
if ! /usr/bin/python3 scripts/soak_sampler.py --sim-pid "$SIM" --policy-pid "$POLICY" --topic "$TOPIC" \
  --seconds "$SOAK_S" --period "$PERIOD" --out "$SAMPLES"; then
  tail -n 5 "$LOG.sim" "$LOG.policy" >&2
  exit 1
fi
python3 - "$SAMPLES" "$OUT/soak_$SOAK_PATH.json" "$SOAK_S" "$WARMUP" "$SOAK_PATH" "$RATE" <<'PY'
import csv, json, sys
rows = list(csv.DictReader(open(sys.argv[1])))
duration, warmup, path, rate = float(sys.argv[3]), float(sys.argv[4]), sys.argv[5], float(sys.argv[6])
steady = [r for r in rows if float(r['t_s']) >= warmup] or rows
out = {'path': path, 'duration_s': duration, 'rate_hz': rate, 'warmup_s': warmup, 'samples': len(rows)}
for node in ('sim', 'policy'):
    k = node + '_rss_kb'
    start, end = int(steady[0][k]), int(steady[-1][k])
    span_h = max(float(steady[-1]['t_s']) - float(steady[0]['t_s']), 1e-9) / 3600.0
    out[node] = {'rss_start_kb': start, 'rss_end_kb': end, 'rss_peak_kb': max(int(r[k]) for r in rows),
                 'growth_kb': end - start, 'growth_kb_per_hour': round((end - start) / span_h, 1)}
windows = sorted(float(r['served_hz']) for r in steady[1:]) or [0.0]
span = float(steady[-1]['t_s']) - float(steady[0]['t_s'])
out['served'] = {'commands': int(rows[-1]['commands']),
                 'mean_hz': round((int(steady[-1]['commands']) - int(steady[0]['commands'])) / span, 2) if span > 0 else 0.0,
                 'min_window_hz': windows[0], 'p5_window_hz': windows[int(0.05 * (len(windows) - 1))]}
json.dump(out, open(sys.argv[2], 'w'), indent=2)
print(json.dumps(out, indent=2))
if out['served']['mean_hz'] < 0.5 * rate:
    sys.exit(f"[soak] served {out['served']['mean_hz']} commands/s, under half of {rate} Hz")
PY
echo "[soak] wrote $OUT/soak_$SOAK_PATH.json"
