#!/usr/bin/env bash
# Pixel training on a GPU machine without ROS: builds msspr_core against the
# pip torch there, collects pointmaze-medium-navigate's 1000 + 100 image
# episodes with the ROS-free collector (scripts/gpu/collect_npz.cc: MuJoCo
# and EGL, the NVIDIA driver's EGL device when Mesa's surfaceless platform
# is missing), trains several pixel configurations side by side on the one
# GPU (RUNS below), and evaluates every export by OGBench's protocol
# (scripts/gpu/eval_policies.cc). Meant for a lease split into calls of a
# few minutes each: the runs and the evaluator live on in the background.
#
#   scripts/gpu/train_pixels.sh setup TRAIN_SECONDS   # build, collect, start the runs
#   scripts/gpu/train_pixels.sh wait SECONDS          # watch; copy results to $OUT
#   scripts/gpu/train_pixels.sh final                 # 50-episode evaluation of the
#                                                     # last exports; results to $OUT
#
# Needs in the working tree: .gpu_deps/*.deb (yaml-cpp, libzip, googletest;
# see build_and_bench.sh) and .gpu_deps/simdeps.tar.gz (MuJoCo 2.2.2 and its
# libraries, glvnd's EGL/OpenGL, the Eigen, EGL, KHR and MuJoCo headers,
# taken from Debian 12; carried, never installed into /). Made on a machine
# where `make deps` has run:
#   mkdir -p /tmp/s/include /tmp/s/lib && cd /usr/include &&
#   cp -r mujoco EGL KHR eigen3/Eigen /tmp/s/include && cd /usr/lib/x86_64-linux-gnu &&
#   cp -L libmujoco.so.2.2.2 libccd.so.2 liblodepng.so.0 libqhull_r.so.8.0 libtinyxml2.so.9 \
#     libEGL.so.1 libOpenGL.so.0 libGLdispatch.so.0 libGL.so.1 libGLX.so.0 /tmp/s/lib &&
#   cd /tmp/s/lib && ln -s libmujoco.so.2.2.2 libmujoco.so && ln -s libEGL.so.1 libEGL.so &&
#   ln -s libOpenGL.so.0 libOpenGL.so && tar czf $REPO/.gpu_deps/simdeps.tar.gz -C /tmp/s .
# (2.3 MB). The device call carries .gpu_deps (carry: [".gpu_deps"]).
set -uo pipefail
cd "$(dirname "$0")/../.."
ROOT=$PWD
WORK=${MSSPR_GPU_WORK:-/root/pix}
PREFIX=/tmp/deps
SIM=/tmp/simdeps
OUT=${OUT:-$WORK/out}
mkdir -p "$WORK" "$OUT"
export LD_LIBRARY_PATH=$SIM/lib:$PREFIX/usr/lib/x86_64-linux-gnu${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
if [ -f /usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json ] && [ -z "${__EGL_VENDOR_LIBRARY_FILENAMES:-}" ]; then
  export __EGL_VENDOR_LIBRARY_FILENAMES=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
fi
note() { echo "== $(date +%T) $*"; }

# name|config files (comma-separated)|extra flags. Runs side by side share the
# GPU and slow each other down (msspr_core/README.md, "Pixels on the GPU"):
# for a curve worth reporting, keep one run per lease.
RUNS=(
  "paper|config/mspr_pixels_paper.yaml|"
  "light1024|config/pointmaze_pixels_cpu.yaml,scripts/gpu/fp32.yaml|--batch 1024"
)
# MSSPR_GPU_RUNS="paper" keeps only the named runs (space-separated names).
if [ -n "${MSSPR_GPU_RUNS:-}" ]; then
  kept=()
  for r in "${RUNS[@]}"; do [[ " $MSSPR_GPU_RUNS " == *" ${r%%|*} "* ]] && kept+=("$r"); done
  RUNS=("${kept[@]}")
fi

build() {
  note "deps"
  mkdir -p $PREFIX $SIM
  for f in .gpu_deps/*.deb; do
    case $(basename "$f") in zlib1g*) [ -f /usr/include/zlib.h ] && continue ;; esac
    dpkg -x "$f" $PREFIX || return 1
  done
  tar xzf .gpu_deps/simdeps.tar.gz -C $SIM || return 1
  TORCH_PREFIX=$(python3 -c 'import torch; print(torch.utils.cmake_prefix_path)')
  TORCH_ROOT=$(python3 -c 'import torch, os; print(os.path.dirname(torch.__file__))')
  note "configure + build msspr_core (msspr_train)"
  cmake -S msspr_core -B build-core -G Ninja -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_PREFIX_PATH="$TORCH_PREFIX;$PREFIX/usr" -DMSSPR_GTEST_SOURCE_DIR=$PREFIX/usr/src/googletest \
    -DTORCH_CUDA_ARCH_LIST=9.0 -DCMAKE_CUDA_COMPILER="$(command -v nvcc)" >"$WORK/cmake.log" 2>&1 ||
    { tail -30 "$WORK/cmake.log"; return 1; }
  local t0=$(date +%s)
  cmake --build build-core -j16 --target msspr_train >"$WORK/build.log" 2>&1 || { tail -40 "$WORK/build.log"; return 1; }
  echo "msspr_train built in $(($(date +%s) - t0)) s"
  local ENV_SRC="msspr_sim/env/src/maze_map.cc msspr_sim/env/src/point_maze.cc msspr_sim/env/src/expert.cc
    msspr_sim/env/src/mujoco_util.cc msspr_sim/env/src/offscreen_renderer.cc
    msspr_sim/env/src/dataset_gen.cc msspr_sim/env/src/gl_context_egl.cc"
  local INC="-Imsspr_core/include -Imsspr_sim/env/include -Imsspr_sim/env/src -I$SIM/include -I$PREFIX/usr/include"
  local LIBS="-L$SIM/lib -L$PREFIX/usr/lib/x86_64-linux-gnu -lmujoco -lEGL -lOpenGL -lzip -lz -lpthread"
  note "collect_npz, eval_policies"
  g++ -std=c++17 -O2 -o "$WORK/collect_npz" scripts/gpu/collect_npz.cc $ENV_SRC msspr_core/src/npz.cc \
    msspr_core/src/dataset.cc $INC $LIBS || return 1
  g++ -std=c++17 -O2 -D_GLIBCXX_USE_CXX11_ABI=1 -o "$WORK/eval_policies" scripts/gpu/eval_policies.cc $ENV_SRC \
    $INC -I$TORCH_ROOT/include -I$TORCH_ROOT/include/torch/csrc/api/include build-core/libmsspr_core.a \
    -Wl,--no-as-needed -L$TORCH_ROOT/lib -ltorch -ltorch_cpu -ltorch_cuda -lc10 -lc10_cuda -Wl,--as-needed \
    -Wl,-rpath,$TORCH_ROOT/lib -lyaml-cpp $LIBS || return 1
}

# 16 single-threaded shards of 62-63 episodes (seeds 7..22) and 100 validation
# episodes (seed 99), concatenated with numpy: on NVIDIA's EGL one process
# renders ~2,500 steps/s, but 16 threads of one process only ~230 in all.
collect() {
  local pids=()
  for i in $(seq 0 15); do
    local n=$(( (1000 + 15 - i) / 16 ))
    "$WORK/collect_npz" --maze medium --episodes $n --val-episodes 0 --seed $((7 + i)) --threads 1 \
      --out "$WORK/shard$i.npz" >"$WORK/collect$i.log" 2>&1 &
    pids+=($!)
  done
  "$WORK/collect_npz" --maze medium --episodes 100 --val-episodes 0 --seed 99 --threads 1 \
    --out "$WORK/pix-val.npz" >"$WORK/collect_val.log" 2>&1 &
  pids+=($!)
  for p in "${pids[@]}"; do wait $p || { cat "$WORK"/collect*.log | tail; return 1; }; done
  tail -qn1 "$WORK"/collect*.log | head -3
  python3 - "$WORK" <<'PY' || return 1
import numpy as np, sys, time
w = sys.argv[1]; t = time.time()
parts = [np.load(f"{w}/shard{i}.npz") for i in range(16)]
out = {k: np.concatenate([p[k] for p in parts]) for k in parts[0].files}
np.savez(f"{w}/pix.npz", **out)
print("merged", {k: v.shape for k, v in out.items()}, f"{time.time() - t:.0f} s")
PY
  rm -f "$WORK"/shard*.npz
}

start_runs() {
  local seconds=$1
  for r in "${RUNS[@]}"; do
    IFS='|' read -r name configs flags <<<"$r"
    mkdir -p "$WORK/runs"
    local config_flags=()
    for c in ${configs//,/ }; do config_flags+=(--config "$c"); done
    # setsid: the runs outlive this call (the lease is held across calls).
    setsid nohup build-core/msspr_train --data "$WORK/pix.npz" --val "$WORK/pix-val.npz" "${config_flags[@]}" \
      $flags --device cuda --seed 0 --threads 2 --time-limit "$seconds" --eval-every 5000 \
      --export-every 2500 --checkpoint-every 5000 --log-every 500 --quiet --out "$WORK/runs/$name" \
      >"$WORK/runs/$name.log" 2>&1 </dev/null &
    echo "started $name (pid $!): --config $configs $flags"
  done
  setsid nohup "$0" evaluator >"$WORK/evaluator.log" 2>&1 </dev/null &
}

# Evaluates every new export (20 episodes per task) until the runs are done.
evaluator() {
  touch "$WORK/evals.jsonl"
  while true; do
    local any=0
    for f in $(ls -tr "$WORK"/runs/*/policy_step*.pt 2>/dev/null); do
      grep -q "\"$f\"" "$WORK/evals.jsonl" && continue
      any=1
      "$WORK/eval_policies" --episodes 20 "$f" >>"$WORK/evals.jsonl" 2>>"$WORK/evaluator.err"
    done
    if [ $any = 0 ]; then
      pgrep -f "build-core/msspr_train" >/dev/null || break
      sleep 10
    fi
  done
}

report() {
  nvidia-smi --query-gpu=utilization.gpu,memory.used --format=csv,noheader || true
  for r in "${RUNS[@]}"; do
    local name=${r%%|*}
    echo "-- $name: $(tail -c 300 "$WORK/runs/$name.log" | tr '\r' '\n' | tail -2 | head -1)"
    [ -f "$WORK/runs/$name/metrics.csv" ] && tail -1 "$WORK/runs/$name/metrics.csv" | cut -c1-200
  done
  echo "-- evals"
  sed 's#"policy": "[^"]*/runs/#"policy": "#' "$WORK/evals.jsonl" 2>/dev/null | cut -c1-160
  tar czf "$OUT/pix_results.tar.gz" -C "$WORK" evals.jsonl evaluator.log $(cd "$WORK" && ls runs/*.log \
    runs/*/metrics.csv runs/*/eval.csv runs/*/options.yaml collect.log 2>/dev/null) 2>/dev/null
}

case ${1:-} in
  setup)
    nvidia-smi --query-gpu=name,driver_version --format=csv,noheader
    build || exit 1
    note "collect 1000 + 100 image episodes: 16 processes (NVIDIA's EGL serialises threads)"
    collect || exit 1
    # One short episode to compare this GPU's renders with Mesa's (same seed, same states).
    "$WORK/collect_npz" --maze medium --episodes 1 --val-episodes 0 --length 201 --seed 7 --threads 1 \
      --out "$OUT/sample.npz" >/dev/null 2>&1
    start_runs "${2:-900}"
    [ $SECONDS -lt 480 ] && sleep 60
    report
    ;;
  wait)
    end=$(($(date +%s) + ${2:-500}))
    while [ "$(date +%s)" -lt "$end" ]; do sleep 30; done
    report
    ;;
  final)
    # Let the runs end (their time limits), then the 50-episode evaluation of each run's last export.
    while pgrep -f "build-core/msspr_train" >/dev/null; do sleep 5; done
    pkill -f "train_pixels.sh evaluator" || true
    for r in "${RUNS[@]}"; do
      name=${r%%|*}
      [ -f "$WORK/runs/$name/policy.pt" ] || continue
      "$WORK/eval_policies" --episodes 50 "$WORK/runs/$name/policy.pt" | tee -a "$WORK/evals.jsonl"
      # Files come back at most 16 MB each: larger exports in parts (cat them back together).
      split -b 15M -d "$WORK/runs/$name/policy.pt" "$OUT/$name.pt.part"
    done
    # The best intermediate export by the 20-episode evaluations, too.
    best=$(python3 -c 'import json,sys; r=[json.loads(l) for l in open(sys.argv[1]) if l.strip()]; r=[x for x in r if x["episodes"]==20]; print(max(r,key=lambda x:x["mean_success"])["policy"] if r else "")' "$WORK/evals.jsonl")
    [ -n "$best" ] && echo "best 20-episode export: $best" && cp "$best" "$OUT/best_$(basename "$(dirname "$best")")_$(basename "$best")"
    report
    ;;
  evaluator) evaluator ;;
  *) echo "usage: $0 setup TRAIN_SECONDS | wait SECONDS | final" >&2; exit 2 ;;
esac
