#!/usr/bin/env bash
# Builds msspr_core standalone with CMake on a GPU machine against the LibTorch
# of the Python torch there, runs its gtests (CPU, then the torch tests with
# MSSPR_TEST_DEVICE=cuda), times the trainer at paper scale (fp32, bf16) and
# the eager PyTorch reference on the same GPU, and profiles one step
# (msspr_profile_step). Optionally (stage "eval") it builds the ROS-free
# evaluators and tools of msspr_sim/eval (msspr_eval_inprocess,
# msspr_collect_npz) and evaluates the shipped state checkpoint on the GPU.
#
#   scripts/gpu/build_and_bench.sh [OUT_DIR]        # from the repository root
#
# Needs: python3 with a CUDA torch, CMake >= 3.16, a C++17 compiler, nvcc (for
# LibTorch's CMake config). yaml-cpp, libzip and googletest come from
# Debian 12 .deb files in $MSSPR_GPU_DEBS (default .gpu_deps), unpacked into
# $MSSPR_GPU_PREFIX (default /tmp/deps), never into /:
#   mkdir -p .gpu_deps && cd .gpu_deps && apt-get download libyaml-cpp-dev \
#     libyaml-cpp0.7 libzip-dev libzip4 googletest zlib1g-dev zlib1g
# (zlib only used when the machine has no zlib.h). The reference is
# ../shared/tools/mspr_ref.py beside the repository ($MSSPR_REFERENCE
# overrides; stage "ref" is skipped without it). Stage "eval" also needs
# MuJoCo 2.2, Eigen, OpenCV, urdfdom and EGL where CMake finds them (e.g.
# Debian 12's libmujoco-dev, libeigen3-dev, libopencv-dev, liburdfdom-dev and
# their libraries, unpacked into $MSSPR_GPU_PREFIX the same way). Stages:
# STAGES="build bench ref profile test" (default, run in this order); "eval"
# and "extra" (TF32, bf16 and Adam experiments) on request. Writes
# OUT_DIR/results.jsonl (one JSON object per measurement), bench_cuda.json, test logs and a gzipped trace.
set -uo pipefail

OUT_DIR=${1:-${OUT:-/tmp/msspr_gpu}}
DEBS=${MSSPR_GPU_DEBS:-.gpu_deps}
PREFIX=${MSSPR_GPU_PREFIX:-/tmp/deps}
BUILD=${MSSPR_GPU_BUILD:-build-core}
JOBS=${JOBS:-$(nproc)}
STAGES=${STAGES:-build bench ref profile test}
CONFIG=config/pointmaze_paper.yaml
mkdir -p "$OUT_DIR"
RESULTS=$OUT_DIR/results.jsonl
: >"$RESULTS"
has_stage() { [[ " $STAGES " == *" $1 "* ]]; }
note() { echo "== $(date +%T) $*"; }
# Appends a JSON line from FILE (or stdin), tagged with a name.
record() {
  local name=$1 file=${2:-/dev/stdin}
  python3 -c 'import json,sys; d=json.loads(sys.stdin.read().strip().splitlines()[-1]); d["name"]=sys.argv[1]; print(json.dumps(d))' \
    "$name" <"$file" >>"$RESULTS" || echo "(no JSON for $name)"
}

note "machine"
nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.sm,clocks.max.sm --format=csv || true
python3 -c 'import torch; print("torch", torch.__version__, "cuda", torch.version.cuda, torch.cuda.get_device_name(0))'
cmake --version | head -1
nvcc --version | tail -2 || true
c++ --version | head -1
grep PRETTY_NAME /etc/os-release || true
nproc

if has_stage build; then
  note "deps: unpacking $DEBS/*.deb into $PREFIX"
  mkdir -p "$PREFIX"
  for f in "$DEBS"/*.deb; do
    case $(basename "$f") in
      zlib1g*) [ -f /usr/include/zlib.h ] && continue ;;
    esac
    dpkg -x "$f" "$PREFIX" || exit 1
  done
  TORCH_PREFIX=$(python3 -c 'import torch; print(torch.utils.cmake_prefix_path)')
  GEN=()
  command -v ninja >/dev/null && GEN=(-G Ninja)
  CUDA_ARGS=()
  command -v nvcc >/dev/null && CUDA_ARGS=(-DCMAKE_CUDA_COMPILER="$(command -v nvcc)")
  note "configure ($BUILD)"
  cmake -S msspr_core -B "$BUILD" "${GEN[@]}" -DCMAKE_BUILD_TYPE=Release \
    -DCMAKE_PREFIX_PATH="$TORCH_PREFIX;$PREFIX/usr" \
    -DMSSPR_GTEST_SOURCE_DIR="$PREFIX/usr/src/googletest" \
    -DTORCH_CUDA_ARCH_LIST="${TORCH_CUDA_ARCH_LIST:-9.0}" "${CUDA_ARGS[@]}" || exit 1
  note "build (-j$JOBS, keep going)"
  start=$(date +%s)
  if [ ${#GEN[@]} -gt 0 ]; then
    cmake --build "$BUILD" -j"$JOBS" -- -k 0
  else
    cmake --build "$BUILD" -j"$JOBS" -- -k
  fi
  echo "build rc $? in $(($(date +%s) - start)) s"
  ldd "$BUILD/msspr_bench_core" | grep -E 'yaml|zip|libz|torch_cuda|not found' || true
fi

if has_stage bench; then
  B=$BUILD/msspr_bench_core
  note "full bench on cuda"
  "$B" --device cuda --out "$OUT_DIR/bench_cuda.json" 2>&1 | tail -30
  for p in fp32 bf16; do
    note "paper config, $p, 300 steps after 30"
    "$B" --config $CONFIG --device cuda --steps 300 --warmup 30 --precision $p \
      --out /tmp/paper_$p.json && record "paper_$p" /tmp/paper_$p.json
  done
  # Repeat of fp32 (spread), batch sweep (host- or device-bound?), and the
  # representation updated once every 250 steps.
  "$B" --config $CONFIG --device cuda --steps 300 --warmup 30 --precision fp32 \
    --out /tmp/r.json && record paper_fp32_repeat /tmp/r.json
  for v in batch_256 batch_4096 repr_every_250; do
    for p in fp32 bf16; do
      "$B" --config $CONFIG,scripts/gpu/$v.yaml --device cuda --steps 200 --warmup 20 \
        --precision $p --out /tmp/r.json && record "paper_${v}_$p" /tmp/r.json
    done
  done
fi

REFERENCE=${MSSPR_REFERENCE:-$PWD/../shared/tools/mspr_ref.py}
if has_stage ref && [ ! -f "$REFERENCE" ]; then
  note "no reference at $REFERENCE (MSSPR_REFERENCE=PATH/mspr_ref.py): stage ref skipped"
elif has_stage ref; then
  export MSSPR_REFERENCE=$REFERENCE
  for i in 1 2; do
    note "eager PyTorch reference on cuda (run $i)"
    PYTHONUNBUFFERED=1 python3 scripts/gpu/run_ref_cuda.py --time_only --scale paper --steps 220 \
      --episodes 100 2>&1 | tee /tmp/ref.log
    record "reference_paper_fp32_run$i" /tmp/ref.log
  done
fi

if has_stage profile; then
  P=$BUILD/msspr_profile_step
  if [ -x "$P" ]; then
    mkdir -p /tmp/prof
    for p in fp32 bf16; do
      note "profile one step, $p"
      "$P" --config $CONFIG --device cuda --precision $p --steps 20 --out-dir /tmp/prof --graph \
        >/tmp/prof_$p.json 2>/tmp/prof_$p.err
      echo "profile rc $?"; tail -3 /tmp/prof_$p.err
      head -1 /tmp/prof_$p.json | record "profile_$p"
      sed -n 2p /tmp/prof_$p.json | record "graph_$p"
      [ $p = fp32 ] && [ -f /tmp/prof/trace.json ] && gzip -c /tmp/prof/trace.json >"$OUT_DIR/trace_fp32.json.gz"
    done
  else
    echo "no $P"
  fi
fi

# Not in the default stages: TF32 matrix products (through LibTorch's
# TORCH_ALLOW_TF32_CUBLAS_OVERRIDE), bf16 with stderr discarded (LibTorch 2.4+
# warns on every deprecated autocast call), and Adam variants.
if has_stage extra; then
  B=$BUILD/msspr_bench_core
  P=$BUILD/msspr_profile_step
  note "fp32 baseline, then with TF32 matrix products"
  "$B" --config $CONFIG --device cuda --steps 300 --warmup 30 --precision fp32 \
    --out /tmp/r.json && record paper_fp32_baseline /tmp/r.json
  TORCH_ALLOW_TF32_CUBLAS_OVERRIDE=1 "$B" --config $CONFIG --device cuda --steps 300 --warmup 30 \
    --precision fp32 --out /tmp/r.json && record paper_fp32_tf32 /tmp/r.json
  TORCH_ALLOW_TF32_CUBLAS_OVERRIDE=1 "$P" --config $CONFIG --precision fp32 --steps 20 2>/dev/null |
    head -1 | record profile_fp32_tf32
  note "bf16 with stderr to /dev/null"
  "$B" --config $CONFIG --device cuda --steps 300 --warmup 30 --precision bf16 \
    --out /tmp/r.json 2>/dev/null && record paper_bf16_stderr_null /tmp/r.json
  note "Adam: loop, _foreach, fused"
  "$P" --config $CONFIG --precision fp32 --steps 2 --adam 2>/dev/null | sed -n 3p | record adam
fi

# The ROS-free evaluators (msspr_sim/eval: msspr_core + msspr_env, no ROS),
# built standalone with CMake, and the shipped state checkpoint evaluated by
# OGBench's protocol on the GPU and on the CPU.
if has_stage eval; then
  EVAL_BUILD=${MSSPR_GPU_EVAL_BUILD:-build-eval}
  TORCH_PREFIX=$(python3 -c 'import torch; print(torch.utils.cmake_prefix_path)')
  note "configure + build msspr_sim/eval ($EVAL_BUILD)"
  if cmake -S msspr_sim/eval -B "$EVAL_BUILD" -DCMAKE_BUILD_TYPE=Release \
       -DMSSPR_GTEST_SOURCE_DIR="$PREFIX/usr/src/googletest" \
       -DCMAKE_PREFIX_PATH="$TORCH_PREFIX;$PREFIX/usr" -DTORCH_CUDA_ARCH_LIST="${TORCH_CUDA_ARCH_LIST:-9.0}" \
       >"$OUT_DIR/cmake_eval.log" 2>&1 &&
     cmake --build "$EVAL_BUILD" -j"$JOBS" --target msspr_eval_inprocess msspr_collect_npz \
       >"$OUT_DIR/build_eval.log" 2>&1; then
    for d in cuda cpu; do
      note "msspr_eval_inprocess, shipped state checkpoint, 50 episodes per task, $d"
      "$EVAL_BUILD/msspr_eval_inprocess" --policy msspr_policy_node/checkpoints/pointmaze-medium-state.pt \
        --episodes 50 --device $d --out "$OUT_DIR/eval_$d.json" 2>&1 | tail -3
    done
  else
    echo "msspr_sim/eval did not build; see $OUT_DIR/cmake_eval.log and build_eval.log"
    tail -5 "$OUT_DIR/cmake_eval.log" "$OUT_DIR/build_eval.log" 2>/dev/null
  fi
fi

if has_stage test; then
  note "tests on cpu (ctest)"
  (cd "$BUILD" && ctest -j"$JOBS" --timeout 300 --output-on-failure) >"$OUT_DIR/ctest_cpu.log" 2>&1
  echo "ctest rc $?"
  grep -E "tests passed|tests failed|^\s+[0-9]+ - " "$OUT_DIR/ctest_cpu.log" | head -40
  note "torch tests with MSSPR_TEST_DEVICE=cuda"
  for t in msspr_core_model_test; do
    MSSPR_TEST_DEVICE=cuda "$BUILD/$t" >"$OUT_DIR/${t}_cuda.log" 2>&1
    echo "$t (cuda) rc $?"
    grep -E "^\[  (PASSED|FAILED) |^\[==========\]" "$OUT_DIR/${t}_cuda.log" | tail -20
  done
fi

note "results ($RESULTS)"
python3 - "$RESULTS" <<'EOF'
import json, sys
for line in open(sys.argv[1]):
    d = json.loads(line)
    keys = [k for k in ('ms_per_step', 'precision', 'batch', 'ms_step_no_info', 'ms_step_info',
                        'gpu_busy_ms_per_step', 'gpu_activities_per_step', 'profiled_wall_ms_per_step',
                        'ms_sample_transitions_and_chunks', 'critic_fwd_bwd_eager_ms',
                        'critic_fwd_bwd_graph_replay_ms', 'critic_graph_error', 'adam_tensors',
                        'adam_numel', 'adam_loop_ms', 'adam_foreach_ms', 'adam_fused_ms',
                        'adam_fused_error') if k in d]
    print(d['name'], {k: d[k] for k in keys})
EOF
