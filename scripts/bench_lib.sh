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
