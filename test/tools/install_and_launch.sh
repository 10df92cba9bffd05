#!/usr/bin/env bash
# Installs the package into a temporary prefix, builds a package that uses it against the
# installed exports alone, and launches the installed node from it, on a master of its own: the
# node must run from the install space and find its models there. (A
# package built on its own installs no setup.bash; the environment it would set is set here.)
#   install_and_launch.sh BUILD_DIR
set -euo pipefail
build=$1
prefix=$(mktemp -d /tmp/lcd_install_XXXXXX)
log=$prefix.launch.log
launch=""
cleanup() {
  [ -n "$launch" ] && kill -INT "$launch" 2> /dev/null && wait "$launch" 2> /dev/null || true
  rm -rf "$prefix" "$prefix.install.log" "$log" "$prefix.downstream" "$prefix.downstream.log"
}
trap cleanup EXIT
fail() {
  echo "install_and_launch: $*" >&2
  [ -f "$log" ] && tail -30 "$log" >&2
  exit 1
}

# The environment an install space's setup.bash gives, with this build's devel space left out.
use_install_space() {
  export ROS_PACKAGE_PATH=$prefix/share CMAKE_PREFIX_PATH=$prefix LD_LIBRARY_PATH=$prefix/lib
  export PYTHONPATH=$prefix/lib/python3/dist-packages
  export PATH="/usr/bin:$PATH"  # catkin's CMake and roslaunch run the system's Python
}

cmake --install "$build" --prefix "$prefix" > "$prefix.install.log" 2>&1 ||
  { cat "$prefix.install.log" >&2; fail "cmake --install failed"; }
share=$prefix/share/landmark_loop_closure
for file in lib/landmark_loop_closure/loop_closure_node lib/landmark_loop_closure/lcd_evaluate \
  lib/liblandmark_loop_closure_nodelet.so share/landmark_loop_closure/launch/loop_closure.launch \
  share/landmark_loop_closure/config/default.yaml share/landmark_loop_closure/nodelet_plugins.xml \
  share/landmark_loop_closure/model/calc_encoder.onnx share/landmark_loop_closure/msg/LoopClosure.msg \
  share/landmark_loop_closure/scripts/fetch_backbone.sh share/landmark_loop_closure/scripts/convert_backbone.py; do
  [ -e "$prefix/$file" ] || fail "not installed: $file"
done

# A package using the installed headers and libraries through the installed catkin exports alone
# (test/downstream_package: no find_package of OpenCV, Eigen or yaml-cpp of its own).
downstream=$prefix.downstream
(
  use_install_space
  cmake -S "$(dirname "$0")/../downstream_package" -B "$downstream" -DCMAKE_BUILD_TYPE=Release &&
    cmake --build "$downstream" -- -j"$(nproc)" &&
    "$downstream/devel/lib/landmark_loop_closure_downstream/uses_landmark_loop_closure"
) > "$prefix.downstream.log" 2>&1 ||
  { tail -30 "$prefix.downstream.log" >&2; fail "the downstream package did not build or run against the installed exports"; }
grep -q "^downstream: found the stored keyframe" "$prefix.downstream.log" ||
  fail "the downstream package did not run"

port=$((20000 + RANDOM % 20000))
(
  use_install_space
  export ROSCONSOLE_STDOUT_LINE_BUFFERED=1 PYTHONUNBUFFERED=1  # the log is read while it runs
  export ROS_MASTER_URI=http://localhost:$port ROS_HOSTNAME=localhost
  found=$(rospack find landmark_loop_closure)
  [ "$found" = "$share" ] || { echo "rospack finds $found, not $share" >&2; exit 1; }
  exec roslaunch -p "$port" landmark_loop_closure loop_closure.launch
) > "$log" 2>&1 &
launch=$!

for _ in $(seq 1 120); do
  grep -q "Loop closure (" "$log" && break
  kill -0 "$launch" 2> /dev/null || fail "roslaunch ended before the node was ready"
  sleep 0.5
done
grep -q "Loop closure (" "$log" || fail "the installed node did not report ready within 60 s"
pgrep -f "^$prefix/lib/landmark_loop_closure/loop_closure_node" > /dev/null ||
  fail "the running node is not the installed one"
grep -q "package models from $share/model" "$log" || fail "the node does not read the installed models"
if [ -f "$(dirname "$0")/../../model/mobilenet_v2.onnx" ]; then
  grep -q "was never fetched" "$log" && fail "the installed node did not find the backbone"
  grep -q "Descriptor backbone: the pretrained network $share/model/mobilenet_v2.onnx" "$log" ||
    fail "the node's first line does not name the installed backbone"
fi
# The tools from the install space alone: their defaults are the installed ones.
(
  use_install_space
  cd "$prefix"
  "$prefix/lib/landmark_loop_closure/lcd_train" --help > /dev/null
  "$prefix/lib/landmark_loop_closure/lcd_config" defaults > "$prefix/defaults.yaml"
  cmp -s "$prefix/defaults.yaml" "$share/config/default.yaml"
  "$prefix/lib/landmark_loop_closure/lcd_evaluate" --detector --corridor 1 --sweep-steps 0 \
    > "$prefix/evaluate.log" 2>&1
  grep -q "headline: recall" "$prefix/evaluate.log"
) || fail "an installed tool did not run from the install space, or its defaults differ"
echo "install_and_launch: installed into $prefix and launched: $(grep -o 'Loop closure (.*' "$log" | head -1)"
