#!/usr/bin/env bash
# Fails if any file under a ROS-free library (default msspr_core/; also used
# for msspr_sim/env/ and msspr_sim/eval/) includes a ROS header: those
# libraries build with plain CMake, without catkin, so that they train and
# simulate on machines without ROS (a GPU machine, say).
set -u
dir=${1:-$(dirname "$0")/../msspr_core}
name=$(basename "$(cd "$dir" && pwd)")
case $name in eval | env) name=msspr_sim/$name ;; esac
pattern='#[[:space:]]*include[[:space:]]*[<"](ros/|rosbag/|roscpp/|roslz4/|std_msgs/|sensor_msgs/|geometry_msgs/|nav_msgs/|trajectory_msgs/|diagnostic_msgs/|visualization_msgs/|tf2_ros/|tf2/|tf2_msgs/|tf2_eigen/|image_transport/|cv_bridge/|msspr/|actionlib/|nodelet/|rosgraph_msgs/)'
hits=$(grep -rnE "$pattern" "$dir" --include='*.h' --include='*.hpp' --include='*.cc' --include='*.cpp' 2>/dev/null)
if [ -n "$hits" ]; then
  echo "$name must stay ROS-free; these lines include ROS headers:" >&2
  echo "$hits" >&2
  exit 1
fi
if grep -rnE 'catkin|roscpp' "$dir/CMakeLists.txt" >/dev/null 2>&1; then
  echo "$name/CMakeLists.txt must not use catkin or roscpp" >&2
  exit 1
fi
echo "$name is ROS-free ($(find "$dir" -name '*.h' -o -name '*.cc' | wc -l) files checked)"
