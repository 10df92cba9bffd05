#!/usr/bin/env bash
# Builds the package as a user's catkin workspace does (catkin_make_isolated --install) with the
# system's ROS 1. The workspace is build/ with this package as its source space: _build is the
# package's build directory (the devel space in _build/devel) and build/.install the install space
# a deployment ships. (ROS's tools search a package's folder for its launch files and programs:
# rosrun skips build/, roslaunch skips hidden folders, so neither finds a second copy there.)
# The compiler's output goes to _build.log; the console gets the phase, progress every 10 % and
# any warning or error.
#   scripts/build.sh            the libraries, nodes and tools, installed into build/.install
#   scripts/build.sh tests      ...and every test
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd -P)
LOG=_build.log
workspace=$root/build
build_dir=$workspace/isolated/landmark_loop_closure
mkdir -p "$workspace/isolated"
# A build made before the workspace (a directory of its own) is not the workspace's: start over.
if [ -d _build ] && [ ! -L _build ]; then
  echo "build: _build/ is a build from before the catkin workspace; removing it"
  rm -rf _build
fi
ln -sfn build/isolated/landmark_loop_closure _build
make_targets=(all)
if [ "${1:-}" = tests ]; then make_targets+=(tests); fi
# ROS's Python tools (catkin_make_isolated) need the system interpreter.
export PATH="/usr/bin:$PATH"
echo "build: catkin_make_isolated --install in build/, ${make_targets[*]} on $(nproc) cores" \
  "(output in $LOG)"
if ! catkin_make_isolated -C "$workspace" --source "$root" --merge --no-color --install \
  --build-space "$workspace/isolated" --devel-space "$build_dir/devel" \
  --install-space "$workspace/.install" \
  --cmake-args -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCATKIN_ENABLE_TESTING=ON \
  --make-args "${make_targets[@]}" -j"$(nproc)" 2>&1 | tee "$LOG" |
  awk '/^\[ *[0-9]+%\]/ { match($0, /[0-9]+/); p = substr($0, RSTART, RLENGTH) - 0;
         if (p >= next_step) { printf "build: %d%%\n", p; fflush(); next_step = p - p % 10 + 10 } }
       /warning:|error:|^CMake Error|^CMake Warning/ { print; fflush() }'; then
  echo "build: failed; the whole output is in $LOG" >&2
  exit 1
fi
echo "build: done, installed into build/.install ($(grep -c 'warning:' "$LOG" || true) compiler" \
  "warnings)"
