#!/usr/bin/env bash
# Installs the Debian 12 packages msspr needs (README "Install").
# Idempotent: a no-op when every package is present.
set -euo pipefail
PKGS=(
  ros-core-dev python3-rostest rosbash
  libtf2-ros-dev libtf2-eigen-dev libtf2-geometry-msgs-dev
  libimage-transport-dev libvisualization-msgs-dev libnav-msgs-dev libtrajectory-msgs-dev
  libtf2-dev libtf2-msgs-dev libroslz4-dev
  python3-sensor-msgs python3-geometry-msgs python3-tf2-msgs
  libmujoco-dev libqhull-dev
  libtorch-dev libopenblas0-openmp libgloo-dev
  libopencv-dev liburdfdom-dev libeigen3-dev
  libosmesa6-dev libegl-dev libegl-mesa0 libgl-dev
  googletest libgtest-dev
  libyaml-cpp-dev libzip-dev zlib1g-dev libbz2-dev libpng-dev python3-numpy python3-yaml python3-matplotlib
  cmake make g++ clang-format
)
missing=()
for p in "${PKGS[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)
  [[ "$status" == "install ok installed" ]] || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "deps: all ${#PKGS[@]} Debian packages present"
  exit 0
fi
echo "deps: missing ${#missing[@]} package(s): ${missing[*]}"
if [ "$(id -u)" -ne 0 ]; then
  echo "deps: not root; run 'sudo make deps' (or install the packages above with apt-get)" >&2
  exit 1
fi
export DEBIAN_FRONTEND=noninteractive
apt-get update -q
apt-get install -y -q --no-install-recommends "${missing[@]}"
echo "deps: installed ${#missing[@]} package(s)"
