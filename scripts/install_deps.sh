#!/usr/bin/env bash
# Installs the Debian 12 packages the package needs to build, test and run the demo.
# and fetches the pretrained backbone (scripts/fetch_backbone.sh).
# Idempotent: does nothing when everything is present. Needs root (or sudo) only to install.
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(
  build-essential cmake catkin ros-core rosbash ros-message-generation ros-message-runtime
  libroscpp-dev libroslib-dev libnodeletlib-dev libnodeletlib-tools pluginlib-dev
  libcv-bridge-dev libimage-transport-dev libmessage-filters-dev
  libtf2-ros-dev libtf2-eigen-dev libtf2-msgs-dev libsensor-msgs-dev libnav-msgs-dev libvisualization-msgs-dev
  libdiagnostic-updater-dev libdiagnostic-msgs-dev ros-diagnostic-msgs
  ros-sensor-msgs ros-nav-msgs ros-visualization-msgs ros-geometry-msgs ros-std-msgs
  librosbag-dev python3-rosbag librostest-dev python3-rostest python3-roslaunch
  libgtest-dev libopencv-dev libeigen3-dev libyaml-cpp-dev zlib1g-dev libhnswlib-dev libsqlite3-dev liblmdb-dev libceres-dev libdnnl-dev
  libcli11-dev libmatio-dev  # the tools' command lines; ground-truth .mat files (v5 and v7.3)
  ocl-icd-opencl-dev  # libdnnl-dev only recommends it, yet its CMake config needs it
  python3-std-srvs ros-std-srvs  # rosservice resumes the demo's paused bag player
  python3-onnx python3-numpy python3-matplotlib
  python3-geometry-msgs  # rostopic reads the Keyframe message (scripts/kill_soak.sh)
  rviz xvfb libx11-dev
  clang  # the thread-safety analysis (scripts/thread_safety.sh)
)
# npm fetches the pretrained backbone; a Node.js that brings its own npm is enough.
if ! command -v npm > /dev/null; then PACKAGES+=(nodejs npm); fi

missing=()
for package in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$package")
  fi
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install_deps: all ${#PACKAGES[@]} packages present"
  scripts/fetch_backbone.sh
  exit 0
fi

LOG=_install.log
echo "install_deps: installing ${#missing[@]} packages (apt's output goes to $LOG): ${missing[*]}"
SUDO=""
if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
export DEBIAN_FRONTEND=noninteractive
if ! { $SUDO apt-get update -qq &&
  $SUDO apt-get install -y -qq --no-install-recommends -o DPkg::Lock::Timeout=900 "${missing[@]}"; } \
  > "$LOG" 2>&1; then
  tail -n 30 "$LOG" >&2
  echo "install_deps: apt-get failed; its whole output is in $LOG" >&2
  exit 1
fi
echo "install_deps: installed"
scripts/fetch_backbone.sh
