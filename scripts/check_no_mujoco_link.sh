#!/usr/bin/env bash
# Fails if an executable loads MuJoCo (directly or through a library it links):
# the policy node serves a checkpoint on a robot and needs no simulator.
#   scripts/check_no_mujoco_link.sh EXE...
set -u
[ $# -gt 0 ] || { echo "usage: check_no_mujoco_link.sh EXE..." >&2; exit 2; }
status=0
for exe in "$@"; do
  if [ ! -x "$exe" ]; then
    echo "check_no_mujoco_link: $exe is not an executable (build it first)" >&2
    status=1
    continue
  fi
  if ! libs=$(ldd "$exe" 2>&1); then
    echo "check_no_mujoco_link: ldd $exe failed: $libs" >&2
    status=1
    continue
  fi
  bad=$(grep -iE 'libmujoco|libmsspr_env\.|libmsspr_sim_nodes\.' <<<"$libs")
  if [ -n "$bad" ]; then
    echo "check_no_mujoco_link: $exe loads the simulator:" >&2
    echo "$bad" >&2
    status=1
  else
    echo "check_no_mujoco_link: $(basename "$exe") loads no MuJoCo ($(wc -l <<<"$libs") libraries)"
  fi
done
exit $status
