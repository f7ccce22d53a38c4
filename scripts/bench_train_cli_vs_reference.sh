#!/usr/bin/env bash
# msspr_train itself, run the way a user runs it, against the eager PyTorch
# reference (../shared/tools/mspr_ref.py) at its faster OpenMP wait policy:
#   msspr_train --data rosbags/pointmaze-medium-navigate-sample.bag \
#     --config config/pointmaze_cpu.yaml [--precision fp32|bf16] \
#     --steps 300 --threads T --out DIR
# plus --eval-every 0 (no validation or simulator evaluation; in a 300-step run
# the shipped eval_every of 5000 would only add the final one, after the loop)
# and --log-every 100 (the shipped value, stated so that shorter runs keep three
# rows). ms/step comes from the run's metrics.csv (its wall_s column) over steps
# 100-300: the first 100 steps (start-up, first-step allocations) are left out.
# msspr_train runs with OMP_WAIT_POLICY unset, as a user's shell has it (its
# main re-executes itself with PASSIVE then, msspr_core/process_env.h).
#
# Usage: bench_train_cli_vs_reference.sh OUT_DIR BIN_DIR [REFERENCE_JSON]
#   REFERENCE_JSON: a train_vs_reference.json of the same run (make bench
#   passes it); its reference timings (best policy per thread count) are used
#   instead of timing the reference again. Without it the reference is timed
#   here under the policies in MSSPR_BENCH_OMP_POLICIES (default "default PASSIVE").
# Writes OUT_DIR/train_cli_vs_reference.json.
# Knobs: MSSPR_BENCH_CLI_STEPS (default 300; the window is its last two thirds),
# MSSPR_BENCH_CLI_POLICIES (msspr_train's policies, default "unset"; add
# "default PASSIVE ACTIVE" to time those too, the faster is then reported
# beside the as-shipped one), MSSPR_BENCH_STEPS (reference's timed steps when
# timed here, default 200), MSSPR_REFERENCE, MSSPR_BENCH_BAG.
set -uo pipefail
OUT=${1:?out dir}
BIN=${2:?directory with msspr_train}
REF_JSON=${3:-}
cd "$(dirname "$0")/.."
REF=${MSSPR_REFERENCE:-$PWD/../shared/tools/mspr_ref.py}
BAG=${MSSPR_BENCH_BAG:-rosbags/pointmaze-medium-navigate-sample.bag}
JSON=$OUT/train_cli_vs_reference.json
CLI_STEPS=${MSSPR_BENCH_CLI_STEPS:-300}
REF_STEPS=${MSSPR_BENCH_STEPS:-200}
REF_POLICIES=${MSSPR_BENCH_OMP_POLICIES:-default PASSIVE}
CLI_POLICIES=${MSSPR_BENCH_CLI_POLICIES:-unset}
LOG_EVERY=$((CLI_STEPS / 3))
if [ "$LOG_EVERY" -lt 1 ]; then echo "MSSPR_BENCH_CLI_STEPS must be at least 3" >&2; exit 2; fi
for p in $REF_POLICIES $CLI_POLICIES; do
  case $p in unset|default|PASSIVE|ACTIVE) ;; *) echo "unknown OpenMP wait policy '$p' (unset|default|PASSIVE|ACTIVE)" >&2; exit 2 ;; esac
done
mkdir -p "$OUT"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

# with_policy SIDE POLICY CMD...: as in bench_train_vs_reference.sh, "default" is
# OpenMP's own policy; msspr's tools need OMP_WAIT_POLICY="" for it (unset makes
# them re-execute with PASSIVE).
. scripts/bench_lib.sh
# ms/step over the metrics.csv rows from step LOG_EVERY to the last one, or null.
window_ms() {
  /usr/bin/python3 - "$1" "$LOG_EVERY" <<'PY' 2>/dev/null || echo null
import csv, sys
rows = [r for r in csv.DictReader(open(sys.argv[1])) if float(r['step']) >= float(sys.argv[2])]
a, b = rows[0], rows[-1]
steps = float(b['step']) - float(a['step'])
print(round(1000.0 * (float(b['wall_s']) - float(a['wall_s'])) / steps, 3) if steps > 0 else 'null')
PY
}

if [ ! -x "$BIN/msspr_train" ] || [ ! -f "$BAG" ]; then
  echo "[bench] train_cli_vs_reference: no $BIN/msspr_train or no $BAG"
  printf '{"msspr_train": null, "note": "msspr_train or the bag is missing"}\n' > "$JSON"
  exit 0
fi

# The reference: from the same run's train_vs_reference.json, or timed here.
ref_rows=()
if [ -n "$REF_JSON" ] && [ -f "$REF_JSON" ]; then
  ref_src="$REF_JSON"
else
  ref_src="timed here"
  if [ -f "$REF" ] && /usr/bin/python3 -c 'import torch' 2>/dev/null; then
    ref_cores=$(ref_blas_cores "$BIN/msspr_train" | tr '\n' ' ')
    for threads in 1 2; do
      time_reference "$REF" "$threads" "$REF_STEPS" "$REF_POLICIES" "$ref_cores"
      ref_rows+=("{\"threads\": $threads, \"reference_ms_by_policy\": $REF_TIMES}")
    done
  else
    echo "[bench] train_cli_vs_reference: no reference ($REF) or no python3-torch; msspr_train alone"
  fi
fi

rows=()
for threads in 1 2; do
  # "default": no --precision, the preset's own (trainer.precision: auto); the
  # precision it resolved to is read from the run's options.yaml.
  for precision in fp32 bf16 default; do
    cfg=(--config config/pointmaze_cpu.yaml)
    [ "$precision" != default ] && cfg+=(--precision "$precision")
    used=null
    times="{"
    for pol in $CLI_POLICIES; do
      echo "[bench] msspr_train ($precision), $threads thread(s), $CLI_STEPS steps, OpenMP wait policy $pol"
      run="$work/${precision}_t${threads}_$pol"
      with_policy msspr "$pol" "$BIN/msspr_train" --data "$BAG" "${cfg[@]}" --steps "$CLI_STEPS" \
        --threads "$threads" --eval-every 0 --log-every "$LOG_EVERY" --out "$run" > "$run.log" 2>&1 ||
        { echo "[bench] msspr_train failed:"; tail -5 "$run.log"; }
      times+="\"$pol\": $(window_ms "$run/metrics.csv"), "
      p=$(sed -n 's/^ *precision: *"\{0,1\}\([a-z0-9]*\)"\{0,1\}$/\1/p' "$run/options.yaml" 2>/dev/null | head -1)
      [ -n "$p" ] && used="\"$p\""
      rm -rf "$run" "$run.log"
    done
    rows+=("{\"threads\": $threads, \"precision\": \"$precision\", \"precision_used\": $used, \"msspr_train_ms_by_policy\": ${times%, }}}")
  done
done

MSSPR_CPU_JSON=$(/usr/bin/python3 scripts/cpu_json.py) \
/usr/bin/python3 - "$JSON" "$ref_src" "$CLI_STEPS" "$LOG_EVERY" "$BAG" "${#ref_rows[@]}" "${ref_rows[@]}" "${rows[@]}" <<'PY'
import json, os, sys
path, ref_src, steps, log_every, bag, nref = sys.argv[1:7]
steps, log_every, nref = int(steps), int(log_every), int(nref)
ref_rows = [json.loads(r) for r in sys.argv[7:7 + nref]]
rows = [json.loads(r) for r in sys.argv[7 + nref:]]
if ref_src not in ('timed here',):
    try:
        src = json.load(open(ref_src))
        seen = {}
        for r in src.get('rows', []):
            seen.setdefault(r['threads'], r.get('reference_ms_by_policy')
                            or {src.get('omp_wait_policy', '?'): r.get('reference_ms_per_step')})
        ref_rows = [{'threads': t, 'reference_ms_by_policy': v} for t, v in sorted(seen.items())]
    except (OSError, ValueError, KeyError):
        ref_rows = []

def best(times):
    ok = {k: v for k, v in (times or {}).items() if isinstance(v, (int, float)) and v > 0}
    if not ok:
        return None, None
    k = min(ok, key=ok.get)
    return k, ok[k]

ref_by_threads = {r['threads']: r['reference_ms_by_policy'] for r in ref_rows}
for r in rows:
    r['msspr_train_policy'], r['msspr_train_ms_per_step'] = best(r['msspr_train_ms_by_policy'])
    r['msspr_train_as_shipped_ms_per_step'] = r['msspr_train_ms_by_policy'].get('unset')
    r['reference_ms_by_policy'] = ref_by_threads.get(r['threads'])
    r['reference_policy'], r['reference_ms_per_step'] = best(r['reference_ms_by_policy'])
    ref, m, shipped = r['reference_ms_per_step'], r['msspr_train_ms_per_step'], r['msspr_train_as_shipped_ms_per_step']
    r['ratio'] = round(ref / m, 3) if ref and m else None
    r['ratio_as_shipped'] = round(ref / shipped, 3) if ref and shipped else None
out = {'cpu': json.loads(os.environ.get('MSSPR_CPU_JSON') or '{}'),
       'command': (f'msspr_train --data {bag} --config config/pointmaze_cpu.yaml '
                   '[--precision fp32|bf16] '
                   f'--steps {steps} --threads T --eval-every 0 --log-every {log_every} --out DIR'),
       'window': f'metrics.csv wall_s, steps {log_every}-{steps}',
       'reference': 'shared/tools/mspr_ref.py --time_only (python3-torch, same LibTorch), '
                    'its faster OpenMP wait policy per thread count',
       'reference_source': ref_src,
       'msspr_train_policy_note': ('"unset": OMP_WAIT_POLICY unset, as a user runs it (msspr_train '
                                   're-executes itself with PASSIVE). ratio uses msspr_train\'s fastest '
                                   'policy timed, ratio_as_shipped the unset one.'),
       'rows': rows}
json.dump(out, open(path, 'w'), indent=2)
c = out['cpu']
print(f"  CPU: {c.get('model_name', '?')} ({c.get('vendor', '?')} family {c.get('family', '?')} "
      f"model {c.get('model', '?')}; {' '.join(c.get('flags', []))})")
for r in rows:
    print(f"  msspr_train {r['precision']} ({r['precision_used']}), {r['threads']} thread(s): {r['msspr_train_ms_per_step']} ms/step "
          f"({r['msspr_train_policy']}); reference {r['reference_ms_per_step']} ms/step "
          f"({r['reference_policy']}); ratio {r['ratio']} (as shipped {r['ratio_as_shipped']})")
PY
