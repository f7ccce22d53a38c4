#!/usr/bin/env bash
# Profiler events (ATen ops) in one training step of a config, fp32 and bf16:
# msspr_bench_core --profile records 5 steps (after 3 untimed ones) with
# LibTorch's autograd profiler on synthetic point-maze data (100 x 1001 steps,
# obs 2, action 2), and scripts/profile_summary.py --count divides by 5.
# One torch thread: the step then runs on one thread, none pipelined, and the
# profiler (thread-local) sees every op of it.
#
# Usage: scripts/count_ops.sh [CONFIG[,CONFIG...]] [BENCH_CORE_BIN]
#   CONFIG defaults to config/pointmaze_cpu.yaml (the shipped CPU default);
#   prints one JSON line for the config as shipped and one for the other
#   precision (--precision), e.g.
#   {"config": ..., "precision": "fp32", "as_shipped": true, "events_per_step": ...,
#    "aten_ops_per_step": ..., "aten_ops_top_level_per_step": ...,
#    "copy_and_to_copy_per_step": ..., "autograd_functions_per_step": ..., ...}
# The counts do not depend on the machine's load (timings in the trace do).
set -euo pipefail
cd "$(dirname "$0")/.."
CONFIG=${1:-config/pointmaze_cpu.yaml}
BENCH=${2:-${DEVEL:-$PWD/devel}/lib/msspr/msspr_bench_core}
if [ ! -x "$BENCH" ]; then
  echo "count_ops: no $BENCH (make build first)" >&2
  exit 1
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
profile() {  # PRECISION_FLAG... -> JSON line; $work/trace.json
  "$BENCH" --config "$CONFIG" --threads 1 --steps 1 --warmup 0 "$@" \
    --out "$work/bench.json" --profile "$work/trace.json" >/dev/null 2>"$work/err" ||
    { cat "$work/err" >&2; exit 1; }
}
count() {  # AS_SHIPPED -> one JSON line
  /usr/bin/python3 - "$work/bench.json" "$CONFIG" "$1" \
    "$(/usr/bin/python3 scripts/profile_summary.py --count "$work/trace.json" 5)" <<'PY'
import json, sys
bench = json.load(open(sys.argv[1]))
counts = json.loads(sys.argv[4])
counts.pop('trace', None)
out = {'config': sys.argv[2], 'precision': bench['precision'], 'as_shipped': sys.argv[3] == '1',
       'threads': bench['threads'], 'pipelined': bench['pipelined'], 'batch': bench['batch'],
       'updates_per_step': bench['updates_per_step']}
out.update(counts)
print(json.dumps(out))
PY
}
profile
count 1
shipped=$(/usr/bin/python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["precision"])' "$work/bench.json")
other=$([ "$shipped" = bf16 ] && echo fp32 || echo bf16)
profile --precision "$other"
count 0
