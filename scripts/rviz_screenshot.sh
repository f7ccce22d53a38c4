#!/usr/bin/env bash
# A screenshot of `roslaunch msspr demo.launch rviz:=true stepping:=realtime`, taken headless: rviz
# under Xvfb with software GL (Mesa llvmpipe). Needs rviz, xvfb and imagemagick
# (apt-get install rviz xvfb imagemagick); nothing else in the package does.
#   scripts/rviz_screenshot.sh OUT.png [SECONDS]   (default 40 s after launch)
set -euo pipefail
OUT=$(readlink -f "${1:?usage: scripts/rviz_screenshot.sh OUT.png [SECONDS]}")
WAIT=${2:-40}
cd "$(dirname "$0")/.."
for tool in Xvfb rviz; do
  command -v "$tool" >/dev/null || { echo "rviz_screenshot: $tool is not installed (apt-get install rviz xvfb imagemagick)" >&2; exit 2; }
done
IMPORT=/usr/bin/import
[ -x "$IMPORT" ] || { echo "rviz_screenshot: no $IMPORT (apt-get install imagemagick)" >&2; exit 2; }
source scripts/ros_env.sh
DISP=:$((90 + $$ % 9))
Xvfb "$DISP" -screen 0 1100x760x24 -nolisten tcp >/dev/null 2>&1 &
XVFB=$!
trap 'kill $LAUNCH $XVFB 2>/dev/null || true; wait 2>/dev/null || true' EXIT
export DISPLAY=$DISP LIBGL_ALWAYS_SOFTWARE=1
TMP=$(mktemp -d)
# Real time (10 Hz) so that the robot and its path are caught mid-episode.
roslaunch -p "$MSSPR_PORT" msspr demo.launch rviz:=true stepping:=realtime episodes:=2 out_dir:="$TMP" >"$TMP/roslaunch.log" 2>&1 &
LAUNCH=$!
sleep "$WAIT"
"$IMPORT" -display "$DISP" -window root "$OUT"
echo "rviz_screenshot: wrote $OUT (log: $TMP/roslaunch.log)"
