#!/usr/bin/env bash
# Trainer ms/step against the eager PyTorch reference (../shared/tools/mspr_ref.py),
# same configuration (config/pointmaze_cpu.yaml: widths 256, batch 256, one
# representation update per step), same machine, same run, 1 and 2 threads.
# Writes $1/train_vs_reference.json. Usage: bench_train_vs_reference.sh OUT_DIR BENCH_CORE_BIN
set -uo pipefail
OUT=${1:?out dir}
BENCH=${2:?msspr_bench_core binary}
cd "$(dirname "$0")/.."
REF=${MSSPR_REFERENCE:-$PWD/../shared/tools/mspr_ref.py}
JSON=$OUT/train_vs_reference.json
STEPS=${MSSPR_BENCH_STEPS:-200}
# Both sides with OpenMP's passive wait (msspr's tools set it themselves).
export OMP_WAIT_POLICY=PASSIVE
mkdir -p "$OUT"
# The CPU-scale pixel step: the shipped preset against the earlier one (Impala CNN on
# 64x64, batch 32, fp32), synthetic 64x64 images, 1 thread.
cat > "$OUT/pixels_impala_b32.yaml" <<'YAML'
network: {obs_mode: pixels, cnn: impala, image_downsample: 1}
representation: {weight_rew: 0.5, augment_prob: 0.0}
agent: {bc_weight: 0.01}
trainer: {batch_size: 32, precision: fp32}
YAML
echo "[bench] CPU-scale pixel steps (1 thread; the shipped preset also at 2)"
pix_rows=()
for run in "config/pointmaze_pixels_cpu.yaml 1" "config/pointmaze_pixels_cpu.yaml 2" \
           "config/pointmaze_pixels_cpu.yaml,$OUT/pixels_impala_b32.yaml 1"; do
  set -- $run
  line=$("$BENCH" --config "$1" --threads "$2" --steps 20 --warmup 5 --episodes 20 --length 201 \
           --out "$OUT/pix_tmp.json" 2>/dev/null | tail -1)
  [ -n "$line" ] && pix_rows+=("$line")
done
rm -f "$OUT/pix_tmp.json" "$OUT/pixels_impala_b32.yaml"
/usr/bin/python3 - "$OUT/train_pixels.json" "${pix_rows[@]}" <<'PY'
import json, sys
rows = [json.loads(r) for r in sys.argv[2:]]
names = ['config/pointmaze_pixels_cpu.yaml (light CNN, 32x32, bf16, batch 128)',
         'config/pointmaze_pixels_cpu.yaml (light CNN, 32x32, bf16, batch 128)',
         'earlier preset (Impala CNN, 64x64, fp32, batch 32)']
for n, r in zip(names, rows):
    r['config'] = n
    r['samples_per_s'] = round(1000.0 * r['batch'] / r['ms_per_step'], 1)
    print(f"  {n}, {r['threads']} thread(s): {r['ms_per_step']:.1f} ms/step, {r['samples_per_s']} samples/s")
json.dump({'rows': rows}, open(sys.argv[1], 'w'), indent=2)
PY
if [ ! -f "$REF" ]; then
  echo "[bench] train_vs_reference: the reference $REF is not there; nothing to compare with"
  printf '{"reference": null, "note": "reference script not found at %s"}\n' "$REF" > "$JSON"
  exit 0
fi
if ! /usr/bin/python3 -c 'import torch' 2>/dev/null; then
  if [ "$(id -u)" -eq 0 ]; then
    echo "[bench] installing python3-torch (Debian's build of the same LibTorch) for the reference"
    DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends python3-torch >/dev/null
  fi
fi
if ! /usr/bin/python3 -c 'import torch' 2>/dev/null; then
  echo "[bench] train_vs_reference: python3-torch is missing (install it as root: apt-get install python3-torch)"
  printf '{"reference": null, "note": "python3-torch not installed"}\n' > "$JSON"
  exit 0
fi
rows=()
for threads in 1 2; do
  echo "[bench] reference (eager PyTorch), $threads thread(s)"
  ref_line=$(/usr/bin/python3 "$REF" --time_only --steps $((STEPS + 20)) --episodes 100 --threads "$threads" 2>/dev/null | grep ms_per_step | tail -1)
  ref_ms=$(printf '%s' "$ref_line" | /usr/bin/python3 -c 'import json,sys; print(json.loads(sys.stdin.read())["ms_per_step"])' 2>/dev/null || echo null)
  for precision in fp32 bf16; do
    echo "[bench] msspr_core trainer ($precision), $threads thread(s)"
    ours=$("$BENCH" --config config/pointmaze_cpu.yaml --threads "$threads" --precision "$precision" \
             --steps "$STEPS" --warmup 20 --out "$OUT/train_${precision}_t$threads.json" 2>/dev/null | tail -1)
    ours_ms=$(printf '%s' "$ours" | /usr/bin/python3 -c 'import json,sys; print(json.loads(sys.stdin.read())["ms_per_step"])' 2>/dev/null || echo null)
    rows+=("{\"threads\": $threads, \"precision\": \"$precision\", \"msspr_ms_per_step\": $ours_ms, \"reference_ms_per_step\": $ref_ms}")
    rm -f "$OUT/train_${precision}_t$threads.json"
  done
done
/usr/bin/python3 - "$JSON" "${rows[@]}" <<'PY'
import json, sys
rows = [json.loads(r) for r in sys.argv[2:]]
for r in rows:
    m, ref = r['msspr_ms_per_step'], r['reference_ms_per_step']
    r['ratio'] = round(ref / m, 3) if m and ref else None
out = {'config': 'config/pointmaze_cpu.yaml (widths 256, batch 256, repr update every step)',
       'reference': 'shared/tools/mspr_ref.py --time_only (python3-torch, same LibTorch)',
       'omp_wait_policy': 'PASSIVE', 'rows': rows}
json.dump(out, open(sys.argv[1], 'w'), indent=2)
for r in rows:
    print(f"  {r['threads']} thread(s), {r['precision']}: msspr {r['msspr_ms_per_step']} ms/step, "
          f"reference {r['reference_ms_per_step']} ms/step, ratio {r['ratio']}")
PY
