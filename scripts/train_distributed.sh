#!/usr/bin/env bash
# Data-parallel msspr_train on this machine: starts N ranks (torch.distributed
# c10d, Gloo on loopback; see docs/training.md "Data-parallel training") with the same
# arguments, rank 0 in the foreground of the log, and stops the others if
# one fails.
#
# usage: scripts/train_distributed.sh N [msspr_train arguments...]
#   e.g. scripts/train_distributed.sh 2 --data medium-navigate.bag --config config/pointmaze_cpu.yaml \
#          --threads 1 --out runs/dp2
#   resume: scripts/train_distributed.sh 2 --resume --out runs/dp2
# Environment: TRAIN (default devel/lib/msspr/msspr_train), MASTER_PORT (default: a free port),
#   LOG_DIR (default: the --out directory; ranks > 0 log to rank<R>.log there).
# Across machines: run msspr_train yourself on each, with --world-size N --rank R
# --master HOST:PORT (HOST = rank 0's address) and the same data and --out path.
set -euo pipefail
if [ $# -lt 1 ] || ! [[ "$1" =~ ^[0-9]+$ ]] || [ "$1" -lt 1 ]; then
  sed -n 2,15p "$0" >&2
  exit 2
fi
N=$1
shift
TRAIN=${TRAIN:-devel/lib/msspr/msspr_train}
[ -x "$TRAIN" ] || { echo "train_distributed: no $TRAIN: run 'make build' first" >&2; exit 2; }
out=""
args=("$@")
for ((i = 0; i < ${#args[@]}; i++)); do
  [ "${args[$i]}" = "--out" ] && [ $((i + 1)) -lt ${#args[@]} ] && out=${args[$((i + 1))]}
done
[ -n "$out" ] || { echo "train_distributed: --out DIR is required" >&2; exit 2; }
PORT=${MASTER_PORT:-$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')}
LOG_DIR=${LOG_DIR:-$out}
mkdir -p "$LOG_DIR"
pids=()
cleanup() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
}
trap cleanup INT TERM
for ((r = 1; r < N; r++)); do
  "$TRAIN" "$@" --world-size "$N" --rank "$r" --master "127.0.0.1:$PORT" > "$LOG_DIR/rank$r.log" 2>&1 &
  pids+=($!)
done
"$TRAIN" "$@" --world-size "$N" --rank 0 --master "127.0.0.1:$PORT" &
pids=($! "${pids[@]}")
status=0
# The first rank to fail stops the others (they would wait for it until --dist-timeout).
while [ ${#pids[@]} -gt 0 ]; do
  if wait -n; then :; else
    status=$?
    echo "train_distributed: a rank failed (exit $status); stopping the others (see $LOG_DIR/rank*.log)" >&2
    cleanup
    wait || true
    exit "$status"
  fi
  alive=()
  for p in "${pids[@]}"; do kill -0 "$p" 2>/dev/null && alive+=("$p"); done
  pids=("${alive[@]}")
done
echo "train_distributed: $N ranks done; outputs in $out" >&2
