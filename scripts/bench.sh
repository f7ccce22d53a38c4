#!/usr/bin/env bash
# make bench: writes JSON figures under build/bench/ and a merged build/bench/bench.json.
set -euo pipefail
BUILD=${1:-build}
cd "$(dirname "$0")/.."
source scripts/ros_env.sh
OUT=$PWD/$BUILD/bench
BIN=$DEVEL/lib/msspr
mkdir -p "$OUT"
echo "[bench] environment (steps/s, frames/s)"
"$BIN/msspr_bench_env" --out "$OUT/env.json"
echo "[bench] collection into a bag (100 episodes x 1001 steps, states)"
t0=$(date +%s.%N)
"$BIN/msspr_collect" --maze medium --episodes 100 --val-episodes 0 --quiet --out "$OUT/collect.bag"
t1=$(date +%s.%N)
python3 -c "import json;t=$t1-$t0;json.dump({'collect_bag_transitions_per_s': round(100*1001/t,1),'collect_bag_seconds_100_episodes': round(t,3)},open('$OUT/collect.json','w'))"
rm -f "$OUT/collect.bag"
echo "[bench] lockstep round trip over ROS"
rosmaster --core -p "$MSSPR_PORT" >/dev/null 2>&1 &
MASTER=$!
trap 'kill ${SIM:-} $MASTER 2>/dev/null || true' EXIT
sleep 1.5
ROS_NAMESPACE=msspr "$BIN/msspr_sim_node" _republish_timeout:=100.0 >/dev/null 2>&1 &
SIM=$!
ROS_NAMESPACE=msspr "$BIN/msspr_bench_lockstep" --steps 5000 --label state --out "$OUT/lockstep_state.json"
kill $SIM; wait $SIM 2>/dev/null || true
ROS_NAMESPACE=msspr "$BIN/msspr_sim_node" _observation_mode:=both _republish_timeout:=100.0 >/dev/null 2>&1 &
SIM=$!
ROS_NAMESPACE=msspr "$BIN/msspr_bench_lockstep" --steps 2000 --label both --out "$OUT/lockstep_pixels.json"
kill $SIM; wait $SIM 2>/dev/null || true
for mode in state pixels; do
  CKPT=msspr_policy_node/checkpoints/pointmaze-medium-$mode.pt
  [ -f "$CKPT" ] && [ -x "$BIN/msspr_policy_node" ] || continue
  echo "[bench] msspr_policy_node observation -> action over ROS ($mode)"
  ROS_NAMESPACE=msspr "$BIN/msspr_policy_node" _checkpoint:="$PWD/$CKPT" _observation_mode:=$mode >/dev/null 2>&1 &
  SIM=$!
  # --pixels explicitly: the node may not have set its ~observation_mode yet.
  ROS_NAMESPACE=msspr "$BIN/msspr_bench_policy" --node policy --label $mode $([ "$mode" = pixels ] && echo --pixels) \
    --out "$OUT/policy_$mode.json"
  kill $SIM; wait $SIM 2>/dev/null || true
done
SIM=
if [ -x "$BIN/msspr_bench_core" ]; then
  echo "[bench] msspr_core (training steps/s, act latency, memory)"
  "$BIN/msspr_bench_core" --out "$OUT/core.json"
  echo "[bench] trainer against the eager PyTorch reference"
  scripts/bench_train_vs_reference.sh "$OUT" "$BIN/msspr_bench_core"
  if [ -x "$BIN/msspr_train" ]; then
    echo "[bench] msspr_train as a user runs it (metrics.csv), against the reference's best"
    scripts/bench_train_cli_vs_reference.sh "$OUT" "$BIN" "$OUT/train_vs_reference.json" ||
      echo "[bench] msspr_train benchmark failed" >&2
  fi
  # The arm's preset: the critic's gradient reaches the encoders, so 2 threads
  # pipeline only the actor update and the TD target (trainer.pipeline).
  for n in 1 2; do
    echo "[bench] cube-single state step (manipulation_cgrad_cpu.yaml, bf16), $n thread(s)"
    "$BIN/msspr_bench_core" --config config/manipulation_cgrad_cpu.yaml --obs-dim 28 --action-dim 5 \
      --episodes 50 --threads $n --out "$OUT/train_cube_cgrad_t$n.json"
  done
fi
if [ -x "$BIN/msspr_train" ]; then
  echo "[bench] data-parallel msspr_train: 1 and 2 ranks (Gloo, loopback)"
  scripts/bench_distributed.sh "$OUT" "$BIN" || echo "[bench] data-parallel benchmark failed" >&2
fi
if [ "${MSSPR_SOAK_S:-0}" -gt 0 ]; then
  for path in native robot; do
    echo "[bench] soak, $path topics: sim + msspr_policy_node at 100 Hz for $MSSPR_SOAK_S s (memory, served rate)"
    scripts/soak.sh "$BUILD" "$MSSPR_SOAK_S" "$path" || echo "[bench] soak ($path) failed" >&2
  done
fi
python3 - "$OUT" <<'PY'
import json, sys, glob, os
out = sys.argv[1]
merged = {}
for f in sorted(glob.glob(os.path.join(out, '*.json'))):
    if os.path.basename(f) == 'bench.json':
        continue
    merged[os.path.basename(f)[:-5]] = json.load(open(f))
json.dump(merged, open(os.path.join(out, 'bench.json'), 'w'), indent=2)
print(json.dumps(merged, indent=2))
PY
echo "[bench] wrote $OUT/bench.json"
