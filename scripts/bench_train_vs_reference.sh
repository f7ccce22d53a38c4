#!/usr/bin/env bash
# Trainer ms/step against the eager PyTorch reference (../shared/tools/mspr_ref.py),
# same configuration (config/pointmaze_cpu.yaml: widths 256, batch 256, one
# representation update per step), same machine, same run, 1 and 2 threads.
# Writes $1/train_vs_reference.json. Usage: bench_train_vs_reference.sh OUT_DIR BENCH_CORE_BIN
#
# OpenBLAS's kernels, measured fairly: where OpenBLAS falls back to its generic
# kernels on this CPU, msspr's tools run the CPU's own (msspr_core/process_env.h),
# so the reference is timed under both, and its faster one counts.
# OpenMP wait policy, measured fairly: at each thread count both sides are
# timed under every policy in MSSPR_BENCH_OMP_POLICIES (default "default PASSIVE";
# add ACTIVE for a third) and the faster is reported, with every timing and the
# winner per side in the JSON.
#   default  OpenMP's own (libgomp: spin 300k iterations, then sleep). For the
#            reference: OMP_WAIT_POLICY unset. msspr's tools re-execute
#            themselves with PASSIVE when the variable is unset
#            (msspr_core/process_env.h), so for them it is OMP_WAIT_POLICY=""
#            (set, so no re-exec; libgomp reads an empty value as unset, after
#            a one-line "Invalid value" warning).
#   PASSIVE  OMP_WAIT_POLICY=PASSIVE: what msspr's tools run with as shipped.
#   ACTIVE   OMP_WAIT_POLICY=ACTIVE (spin on).
# The JSON also records GOMP_SPINCOUNT as libgomp reports it (OMP_DISPLAY_ENV)
# in the process that runs, per side and policy: evidence that the setting
# reached it (0 passive, 300000 default, 30000000000 active).
# Other knobs: MSSPR_BENCH_STEPS (timed steps, default 200), MSSPR_REFERENCE.
set -uo pipefail
OUT=${1:?out dir}
BENCH=${2:?msspr_bench_core binary}
cd "$(dirname "$0")/.."
REF=${MSSPR_REFERENCE:-$PWD/../shared/tools/mspr_ref.py}
JSON=$OUT/train_vs_reference.json
STEPS=${MSSPR_BENCH_STEPS:-200}
POLICIES=${MSSPR_BENCH_OMP_POLICIES:-default PASSIVE}
for p in $POLICIES; do
  case $p in default|PASSIVE|ACTIVE) ;; *) echo "MSSPR_BENCH_OMP_POLICIES: unknown policy '$p' (default|PASSIVE|ACTIVE)" >&2; exit 2 ;; esac
done
mkdir -p "$OUT"

# with_policy SIDE POLICY CMD...: runs CMD under POLICY (see above, or "unset").
. scripts/bench_lib.sh
# spin_count SIDE POLICY CMD...: GOMP_SPINCOUNT of the last libgomp start-up in CMD
# (after msspr's re-exec, if any), as OMP_DISPLAY_ENV=verbose prints it.
spin_count() {
  local side=$1 pol=$2
  shift 2
  local n
  n=$(OMP_DISPLAY_ENV=verbose with_policy "$side" "$pol" "$@" 2>&1 >/dev/null |
        sed -n "s/.*GOMP_SPINCOUNT = '\([0-9]*\)'.*/\1/p" | tail -1)
  echo "${n:-null}"
}

# The CPU-scale pixel step: the shipped preset against the earlier one (Impala CNN on
# 64x64, batch 32, fp32), synthetic 64x64 images, 1 thread. Under the caller's
# OMP_WAIT_POLICY (unset: PASSIVE, as msspr's tools pick it).
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

# What each policy label turns into in each side's process.
spins=()
for pol in $POLICIES; do
  spins+=("{\"side\": \"reference\", \"policy\": \"$pol\", \"gomp_spincount\": $(spin_count ref "$pol" /usr/bin/python3 -c 'import torch')}")
  spins+=("{\"side\": \"msspr\", \"policy\": \"$pol\", \"gomp_spincount\": $(spin_count msspr "$pol" "$BENCH" --help)}")
done
spins+=("{\"side\": \"msspr\", \"policy\": \"unset (as shipped)\", \"gomp_spincount\": $(spin_count msspr unset "$BENCH" --help)}")

# The reference's OpenBLAS kernels: its own pick, and the CPU's own where they differ.
REF_CORES=$(ref_blas_cores "$BENCH" | tr '\n' ' ')
echo "[bench] reference timed under OpenBLAS kernels: $REF_CORES(own = OpenBLAS's pick)"
rows=()
for threads in 1 2; do
  time_reference "$REF" "$threads" "$STEPS" "$POLICIES" "$REF_CORES"
  ref_times=$REF_TIMES
  for precision in fp32 bf16; do
    ours_times="{"
    for pol in $POLICIES; do
      echo "[bench] msspr_core trainer ($precision), $threads thread(s), OpenMP wait policy $pol"
      ms=$(with_policy msspr "$pol" "$BENCH" --config config/pointmaze_cpu.yaml --threads "$threads" \
             --precision "$precision" --steps "$STEPS" --warmup 20 \
             --out "$OUT/train_${precision}_t$threads.json" 2>/dev/null | ms_of)
      ours_times+="\"$pol\": $ms, "
      # One core's fp32 FMA and bf16 dot-product peaks, as msspr_bench_core measured them.
      [ -n "${ISA_PEAKS:-}" ] || ISA_PEAKS=$(/usr/bin/python3 -c \
        'import json, sys; print(json.dumps(json.load(open(sys.argv[1])).get("isa_peaks", {})))' \
        "$OUT/train_${precision}_t$threads.json" 2>/dev/null)
      rm -f "$OUT/train_${precision}_t$threads.json"
    done
    ours_times="${ours_times%, }}"
    rows+=("{\"threads\": $threads, \"precision\": \"$precision\", \"msspr_ms_by_policy\": $ours_times, \"reference_ms_by_policy\": $ref_times}")
  done
done
MSSPR_CPU_JSON=$(/usr/bin/python3 scripts/cpu_json.py) MSSPR_REF_CORES=$REF_CORES \
MSSPR_ISA_PEAKS=${ISA_PEAKS:-} /usr/bin/python3 - "$JSON" "$STEPS" "${#spins[@]}" "${spins[@]}" "${rows[@]}" <<'PY'
import json, os, sys
path, steps, nspin = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
spins = [json.loads(s) for s in sys.argv[4:4 + nspin]]
rows = [json.loads(r) for r in sys.argv[4 + nspin:]]

def best(times):
    ok = {k: v for k, v in times.items() if isinstance(v, (int, float)) and v > 0}
    if not ok:
        return None, None
    k = min(ok, key=ok.get)
    return k, ok[k]

for r in rows:
    r['msspr_policy'], r['msspr_ms_per_step'] = best(r['msspr_ms_by_policy'])
    r['reference_policy'], r['reference_ms_per_step'] = best(r['reference_ms_by_policy'])
    m, ref = r['msspr_ms_per_step'], r['reference_ms_per_step']
    r['ratio'] = round(ref / m, 3) if m and ref else None
    # msspr as a user runs it: OMP_WAIT_POLICY unset, so its tools pick PASSIVE.
    shipped = r['msspr_ms_by_policy'].get('PASSIVE')
    r['msspr_as_shipped_ms_per_step'] = shipped
    r['ratio_as_shipped'] = round(ref / shipped, 3) if shipped and ref else None
out = {'cpu': json.loads(os.environ.get('MSSPR_CPU_JSON') or '{}'),
       # One core's fp32 FMA and AVX512-BF16 dot-product GFLOP/s (-1: the CPU lacks it):
       # without AMX, bf16 matrix products cannot beat fp32 ones where the second is not above.
       'isa_peaks': json.loads(os.environ.get('MSSPR_ISA_PEAKS') or '{}'),
       'config': 'config/pointmaze_cpu.yaml (widths 256, batch 256, repr update every step)',
       'reference': 'shared/tools/mspr_ref.py --time_only (python3-torch, same LibTorch)',
       'timed_steps': steps,
       'omp_wait_policy': ('each side timed under every policy listed; ms_per_step and ratio use '
                           'each side\'s faster one (*_policy says which). "default": OpenMP\'s own '
                           '(reference: OMP_WAIT_POLICY unset; msspr: OMP_WAIT_POLICY="", since its '
                           'tools re-execute with PASSIVE when it is unset). ratio_as_shipped: msspr '
                           'with the variable unset (= PASSIVE) against the reference\'s best.'),
       'reference_openblas_cores': ('the reference timed under each: "own" is OpenBLAS\'s pick '
                                    '(OPENBLAS_CORETYPE unset); another is the CPU\'s own kernels, '
                                    'which msspr\'s tools run where OpenBLAS falls back to generic ones: '
                                    + ' '.join(os.environ.get('MSSPR_REF_CORES', '').split())),
       'policies': list(rows[0]['reference_ms_by_policy']) if rows else [],
       'gomp_spincount_seen': spins,
       'rows': rows}
json.dump(out, open(path, 'w'), indent=2)
c = out['cpu']
print(f"  CPU: {c.get('model_name', '?')} ({c.get('vendor', '?')} family {c.get('family', '?')} "
      f"model {c.get('model', '?')}; {' '.join(c.get('flags', []))})")
p = out['isa_peaks']
if p:
    print(f"  one core's peaks: fp32 FMA ({p.get('fp32_isa')}) {p.get('fp32_gflops')} GFLOP/s, "
          f"bf16 dot {p.get('bf16_dot_gflops')} GFLOP/s")
for s in spins:
    print(f"  {s['side']} under {s['policy']}: GOMP_SPINCOUNT {s['gomp_spincount']}")
for r in rows:
    print(f"  {r['threads']} thread(s), {r['precision']}: msspr {r['msspr_ms_per_step']} ms/step "
          f"({r['msspr_policy']}), reference {r['reference_ms_per_step']} ms/step ({r['reference_policy']}), "
          f"ratio {r['ratio']} (as shipped {r['ratio_as_shipped']}); "
          f"msspr {r['msspr_ms_by_policy']}, reference {r['reference_ms_by_policy']}")
PY
