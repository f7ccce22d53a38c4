#!/usr/bin/env bash
# The paper's Table 5 on our task: full, DIR, DI and D at CPU scale on
# pointmaze-medium-navigate (states), SEEDS seeds each, equal step budgets,
# and (VARIANTS gcbc,gcivl,gciql,qrl,crl,hiql) OGBench's baseline agents
# with config/agents/pointmaze_cpu.yaml (fp32, no EXTRA_CONFIG),
# two runs at a time at one torch thread each (the 2 cores). Each run ends
# with OGBench's protocol (5 tasks x 50 episodes) and writes
# OUT/<variant>-s<seed>/eval.csv; scripts/results_table.py summarises them.
#
# usage: scripts/run_ablations.sh DATA.bag OUT [STEPS] [SEEDS] [VARIANTS]
#   STEPS     steps per run (default 20000)
#   SEEDS     comma-separated seeds (default 0,1)
#   VARIANTS  comma-separated presets (default mspr,DIR,DI,D) or agents
# Environment: EXTRA_CONFIG (default config/precision_bf16.yaml; "" for fp32),
#   EVAL_EVERY (default STEPS/4), PARALLEL (default 2).
set -euo pipefail
if [ $# -lt 2 ]; then
  sed -n 2,14p "$0" >&2
  exit 2
fi
DATA=$1
OUT=$2
STEPS=${3:-20000}
SEEDS=${4:-0,1}
VARIANTS=${5:-mspr,DIR,DI,D}
EXTRA_CONFIG=${EXTRA_CONFIG-config/precision_bf16.yaml}
EVAL_EVERY=${EVAL_EVERY:-$((STEPS / 4))}
PARALLEL=${PARALLEL:-2}
TRAIN=${TRAIN:-devel/lib/msspr/msspr_train}
[ -f "$DATA" ] || { echo "run_ablations: no dataset $DATA" >&2; exit 2; }
[ -x "$TRAIN" ] || { echo "run_ablations: no $TRAIN: run 'make build' first" >&2; exit 2; }
mkdir -p "$OUT"
jobs_list=()
for v in ${VARIANTS//,/ }; do
  for s in ${SEEDS//,/ }; do jobs_list+=("$v:$s"); done
done
run_one() {
  local v=${1%%:*} s=${1##*:}
  local dir="$OUT/$v-s$s"
  local extra=() flags=(--config config/pointmaze_cpu.yaml)
  [ -n "$EXTRA_CONFIG" ] && extra=(--config "$EXTRA_CONFIG")
  case "$v" in
    gcbc | gcivl | gciql | qrl | crl | hiql)
      flags=(--agent "$v" --config config/agents/pointmaze_cpu.yaml)
      extra=() ;;
    *) flags+=(--preset "$v") ;;
  esac
  if [ -f "$dir/run.yaml" ]; then
    echo "run_ablations: $dir exists: resuming" >&2
    "$TRAIN" --resume --out "$dir" --quiet > "$dir.log" 2>&1 || echo "run_ablations: $dir failed: see $dir.log" >&2
  else
    local t0=$SECONDS
    "$TRAIN" --data "$DATA" "${flags[@]}" "${extra[@]}" \
      --steps "$STEPS" --eval-every "$EVAL_EVERY" --checkpoint-every "$EVAL_EVERY" --eval-episodes 50 \
      --threads 1 --seed "$s" --quiet --out "$dir" > "$dir.log" 2>&1 ||
      echo "run_ablations: $dir failed: see $dir.log" >&2
    echo "$((SECONDS - t0))" > "$dir.wall_s"
  fi
  echo "run_ablations: $v seed $s done ($(tail -1 "$dir/eval.csv" 2>/dev/null))" >&2
}
running=0
for j in "${jobs_list[@]}"; do
  run_one "$j" &
  running=$((running + 1))
  if [ "$running" -ge "$PARALLEL" ]; then
    wait -n
    running=$((running - 1))
  fi
done
wait
echo "run_ablations: all done in $OUT" >&2
