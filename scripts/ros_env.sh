# Sourced by the scripts: the built package's environment and a private master
# port, so that demos, benches and tests never collide with a running roscore.
export PATH=/usr/bin:/bin:$PATH
BUILD=${BUILD:-build}
DEVEL=${DEVEL:-$PWD/devel}
if [ ! -f "$DEVEL/setup.bash" ]; then
  echo "no $DEVEL/setup.bash: run 'make build' first" >&2
  exit 1
fi
# catkin's setup scripts read unset variables: relax -u while sourcing them.
_msspr_u=$([[ $- == *u* ]] && echo 1 || true)
set +u
# shellcheck disable=SC1091
source "$DEVEL/setup.bash"
[ -n "$_msspr_u" ] && set -u
export ROS_HOME=${ROS_HOME:-$PWD/$BUILD/ros_home}
export ROS_LOG_DIR=${ROS_LOG_DIR:-$ROS_HOME/log}
mkdir -p "$ROS_LOG_DIR"
MSSPR_PORT=${MSSPR_PORT:-$(python3 "$(dirname "${BASH_SOURCE[0]}")/free_port.py" $$)}
export ROS_MASTER_URI=http://127.0.0.1:$MSSPR_PORT
export ROS_IP=127.0.0.1
