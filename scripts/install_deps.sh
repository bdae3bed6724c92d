#!/usr/bin/env bash
# Installs the Debian 12 packages this package builds, runs and tests with.
# Idempotent: only calls apt when something is missing. Run as root.
set -euo pipefail

PACKAGES=(
  build-essential cmake pkg-config libeigen3-dev libgtest-dev libboost-dev
  catkin ros-core-dev ros-message-generation ros-message-runtime
  libroscpp-dev librosconsole-dev libstd-srvs-dev libgeometry-msgs-dev
  libtf2-ros-dev libtf2-eigen-dev libtf2-msgs-dev libvisualization-msgs-dev
  libdynamic-reconfigure-config-init-mutex-dev python3-dynamic-reconfigure
  librostest-dev python3-rostest rosbash python3-rospy python3-roslaunch
  python3-geometry-msgs python3-visualization-msgs python3-tf2-msgs
  python3-std-srvs python3-catkin-pkg python3-tf2-ros python3-dynamic-reconfigure
  libdiagnostic-msgs-dev python3-diagnostic-msgs libyaml-cpp-dev libroslib-dev
  libros-rosgraph-msgs-dev python3-rosgraph-msgs
  libactionlib-dev libactionlib-msgs-dev python3-actionlib python3-actionlib-msgs
  libsensor-msgs-dev python3-sensor-msgs python3-matplotlib
  libinteractive-markers-dev python3-interactive-markers python3-yaml
  liburdfdom-dev libfcl-dev libassimp-dev
)
# Optional extras: rviz and Xvfb (WITH_RVIZ=1); the benchmark's peers and plots (WITH_BENCH=1);
# clang with libFuzzer for scripts/fuzz.sh (WITH_FUZZ=1).
if [[ "${WITH_RVIZ:-0}" == 1 ]]; then
  PACKAGES+=(rviz xvfb x11-apps imagemagick)
fi
if [[ "${WITH_FUZZ:-0}" == 1 ]]; then
  PACKAGES+=(clang libclang-rt-14-dev)
fi
if [[ "${WITH_BENCH:-0}" == 1 ]]; then
  PACKAGES+=(libode-dev libmujoco-dev)
fi

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if ((${#missing[@]})); then
  SUDO=""
  if [[ $(id -u) -ne 0 ]]; then SUDO="sudo"; fi
  echo "Installing missing packages: ${missing[*]}"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi
