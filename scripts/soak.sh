#!/usr/bin/env bash
# Soak: msspr_sim_node stepping in real time at 100 Hz (random episodes, auto
# reset) driven by msspr_policy_node for SOAK_S seconds (default 600), sampling
# the resident memory of both every few seconds. Writes build/bench/soak.json:
# per node the RSS at the start (after a warm-up), at the end, the peak, and
# the growth. Usage: scripts/soak.sh [BUILD] [SECONDS]   (make bench runs it
# when MSSPR_SOAK_S is set, e.g. MSSPR_SOAK_S=600 make bench)
set -euo pipefail
BUILD=${1:-build}
SOAK_S=${2:-${MSSPR_SOAK_S:-600}}
cd "$(dirname "$0")/.."
source scripts/ros_env.sh
OUT=$PWD/$BUILD/bench
BIN=$DEVEL/lib/msspr
CKPT=$PWD/msspr_policy_node/checkpoints/pointmaze-medium-state.pt
mkdir -p "$OUT"
[ -x "$BIN/msspr_policy_node" ] && [ -f "$CKPT" ] || { echo "[soak] needs msspr_policy_node and $CKPT" >&2; exit 1; }
PIDS=()
trap 'for p in "${PIDS[@]}"; do kill "$p" 2>/dev/null || true; done' EXIT
if ! rostopic list >/dev/null 2>&1; then
  rosmaster --core -p "$MSSPR_PORT" >/dev/null 2>&1 &
  PIDS+=($!)
  sleep 1.5
fi
ROS_NAMESPACE=msspr "$BIN/msspr_sim_node" _stepping:=realtime _control_rate:=100.0 _auto_reset:=true \
  _episode_length:=1001 _num_episodes:=0 _publish_clock:=false >/dev/null 2>&1 &
SIM=$!
PIDS+=($SIM)
ROS_NAMESPACE=msspr "$BIN/msspr_policy_node" _checkpoint:="$CKPT" _mode:=lockstep >/dev/null 2>&1 &
POLICY=$!
PIDS+=($POLICY)
echo "[soak] sim (pid $SIM) + policy (pid $POLICY) at 100 Hz for $SOAK_S s"
rss() { awk '/^VmRSS:/ {print $2}' "/proc/$1/status" 2>/dev/null || echo 0; }
PERIOD=$(( SOAK_S >= 120 ? 10 : 2 ))
WARMUP=$(( SOAK_S / 10 > 15 ? SOAK_S / 10 : 15 ))  # torch and the buffers settle first
WARMUP=$(( WARMUP > SOAK_S / 2 ? SOAK_S / 2 : WARMUP ))
SAMPLES=$OUT/soak_samples.csv
echo "t_s,sim_rss_kb,policy_rss_kb" > "$SAMPLES"
t=0
while [ "$t" -le "$SOAK_S" ]; do
  kill -0 "$SIM" 2>/dev/null && kill -0 "$POLICY" 2>/dev/null || { echo "[soak] a node died at $t s" >&2; exit 1; }
  echo "$t,$(rss $SIM),$(rss $POLICY)" >> "$SAMPLES"
  sleep "$PERIOD"
  t=$(( t + PERIOD ))
done
python3 - "$SAMPLES" "$OUT/soak.json" "$SOAK_S" "$WARMUP" <<'PY'
import csv, json, sys
rows = list(csv.DictReader(open(sys.argv[1])))
duration, warmup = float(sys.argv[3]), float(sys.argv[4])
steady = [r for r in rows if float(r['t_s']) >= warmup] or rows
out = {'duration_s': duration, 'rate_hz': 100.0, 'warmup_s': warmup, 'samples': len(rows)}
for node in ('sim', 'policy'):
    k = node + '_rss_kb'
    start, end = int(steady[0][k]), int(steady[-1][k])
    span_h = max(float(steady[-1]['t_s']) - float(steady[0]['t_s']), 1e-9) / 3600.0
    out[node] = {'rss_start_kb': start, 'rss_end_kb': end, 'rss_peak_kb': max(int(r[k]) for r in rows),
                 'growth_kb': end - start, 'growth_kb_per_hour': round((end - start) / span_h, 1)}
json.dump(out, open(sys.argv[2], 'w'), indent=2)
print(json.dumps(out, indent=2))
PY
echo "[soak] wrote $OUT/soak.json"
