# Sourced by the bench scripts and run_tests.sh: shared shell helpers.

# with_policy SIDE POLICY CMD...: runs CMD under the OpenMP wait policy POLICY;
# SIDE is ref or msspr. "default" is OpenMP's own policy: OMP_WAIT_POLICY unset
# for the reference, OMP_WAIT_POLICY="" for msspr's tools (unset makes them
# re-execute with PASSIVE); "unset" leaves the variable unset on either side;
# PASSIVE and ACTIVE set it.
with_policy() {
  local side=$1 pol=$2
  shift 2
  case $pol in
    default) if [ "$side" = msspr ]; then env OMP_WAIT_POLICY= "$@"; else env -u OMP_WAIT_POLICY "$@"; fi ;;
    unset) env -u OMP_WAIT_POLICY "$@" ;;
    *) env OMP_WAIT_POLICY="$pol" "$@" ;;
  esac
}

# tool_blas_core TOOL: the OpenBLAS kernels msspr's TOOL runs on this CPU, as OpenBLAS names
# them ("SkylakeX"; after the tool's re-execution, msspr_core/process_env.h), or nothing.
tool_blas_core() {
  OMP_WAIT_POLICY=PASSIVE OPENBLAS_VERBOSE=2 "$1" --help 2>&1 | sed -n 's/^Core: //p' | tail -1
}

# ref_blas_cores TOOL: the OpenBLAS kernels to time the reference under, one per
# line: "own" (OpenBLAS's own pick, OPENBLAS_CORETYPE unset) and, when msspr's
# TOOL runs other kernels on this CPU (it re-executes with the CPU's own kernels
# where OpenBLAS falls back to its generic ones, msspr_core/process_env.h),
# those too: a setting that helps the reference as much as msspr.
ref_blas_cores() {
  local ours theirs
  ours=$(tool_blas_core "$1")
  theirs=$(env -u OPENBLAS_CORETYPE OPENBLAS_VERBOSE=2 /usr/bin/python3 -c 'import torch' 2>&1 |
             sed -n 's/^Core: //p' | tail -1)
  echo own
  if [ -n "$ours" ] && [ "$ours" != "$theirs" ]; then echo "$ours"; fi
}

# blas_env CORE: env(1) arguments for CORE ("own": OPENBLAS_CORETYPE unset).
blas_env() {
  if [ "$1" = own ]; then echo "-u OPENBLAS_CORETYPE"; else echo "OPENBLAS_CORETYPE=$1"; fi
}

# ref_label POLICY CORE: the key of one reference timing in the JSON.
ref_label() {
  if [ "$2" = own ]; then echo "$1"; else echo "$1, OPENBLAS_CORETYPE=$2"; fi
}

ms_of() {  # the ms_per_step of the last JSON line on stdin, or null
  /usr/bin/python3 -c 'import json,sys
lines=[l for l in sys.stdin.read().splitlines() if "ms_per_step" in l]
print(json.loads(lines[-1])["ms_per_step"] if lines else "null")' 2>/dev/null || echo null
}

# time_reference REF THREADS STEPS "POLICIES" "CORES": the eager reference REF
# (--time_only, STEPS timed steps after 20, 100 episodes) at THREADS threads under
# each OpenMP wait policy and OpenBLAS kernels (ref_blas_cores); sets REF_TIMES to
# a JSON object {label (ref_label): ms per step or null}.
time_reference() {
  local ref=$1 threads=$2 steps=$3 policies=$4 cores=$5 pol core label ms
  REF_TIMES="{"
  for pol in $policies; do
    for core in $cores; do
      label=$(ref_label "$pol" "$core")
      echo "[bench] reference (eager PyTorch), $threads thread(s), OpenMP wait policy $label"
      # shellcheck disable=SC2046  # blas_env prints env(1)'s arguments
      ms=$(with_policy ref "$pol" env $(blas_env "$core") /usr/bin/python3 "$ref" --time_only \
             --steps $((steps + 20)) --episodes 100 --threads "$threads" 2>/dev/null | ms_of)
      REF_TIMES+="\"$label\": $ms, "
    done
  done
  REF_TIMES="${REF_TIMES%, }}"
}
