#!/usr/bin/env bash
# make bench: data-parallel msspr_train at 1 and 2 ranks (Gloo on loopback) on this
# machine, one torch thread per rank, the same global batch (CPU scale, 256),
# on a small pointmaze-medium bag; writes OUT/distributed.json with steps/s and
# the all-reduce time and volume per step.
# usage: scripts/bench_distributed.sh OUT BIN [STEPS]
set -euo pipefail
OUT=$1
BIN=$2
STEPS=${3:-300}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$BIN/msspr_collect" --maze medium --episodes 40 --val-episodes 0 --quiet --out "$work/data.bag"
common=(--data "$work/data.bag" --config config/pointmaze_cpu.yaml --steps "$STEPS" --log-every 50
        --eval-every 0 --checkpoint-every 0 --threads 1 --quiet)
"$BIN/msspr_train" "${common[@]}" --out "$work/r1" > "$work/r1.log" 2>&1
TRAIN="$BIN/msspr_train" LOG_DIR="$work" scripts/train_distributed.sh 2 "${common[@]}" --out "$work/r2" \
  > "$work/r2.log" 2>&1
python3 - "$work" "$OUT/distributed.json" "$STEPS" <<'PY'
import csv, json, re, sys
work, out, steps = sys.argv[1], sys.argv[2], int(sys.argv[3])
def rate(d):
    rows = list(csv.DictReader(open(f"{work}/{d}/metrics.csv")))
    # steps/s over the run after its first logged row (start-up excluded)
    a, b = rows[0], rows[-1]
    return (float(b["step"]) - float(a["step"])) / (float(b["wall_s"]) - float(a["wall_s"]))
log = open(f"{work}/r2.log").read()
m = re.search(r"rank 0: all-reduce ([0-9.]+) ms and ([0-9.]+) MB per step", log)
r1, r2 = rate("r1"), rate("r2")
res = {"steps": steps, "global_batch": 256, "threads_per_rank": 1,
       "steps_per_s_1_rank": round(r1, 2), "steps_per_s_2_ranks": round(r2, 2),
       "speedup_2_ranks": round(r2 / r1, 3),
       "allreduce_ms_per_step_2_ranks": float(m.group(1)) if m else None,
       "allreduce_mb_per_step": float(m.group(2)) if m else None}
json.dump(res, open(out, "w"), indent=1)
print(json.dumps(res))
PY
