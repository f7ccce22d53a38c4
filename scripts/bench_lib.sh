# Sourced by the bench scripts (from the repository root): shared shell helpers.

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

# ref_blas_cores TOOL: the OpenBLAS kernels to time the reference under, one per
# line: "own" (OpenBLAS's own pick, OPENBLAS_CORETYPE unset) and, when msspr's
# TOOL runs other kernels on this CPU (it re-executes with the CPU's own kernels
# where OpenBLAS falls back to its generic ones, msspr_core/process_env.h),
# those too: a setting that helps the reference as much as msspr.
ref_blas_cores() {
  local ours theirs
  ours=$(OMP_WAIT_POLICY=PASSIVE OPENBLAS_VERBOSE=2 "$1" --help 2>&1 | sed -n 's/^Core: //p' | tail -1)
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
