#!/usr/bin/env bash
# The package as a user's catkin workspace ships it. scripts/build.sh built it with
# catkin_make_isolated --install in the workspace build/ (the suite's own build); here the source
# tree and the build are out of reach (a private mount namespace lays an empty folder over the
# repository and puts back only the install space), and from the install space alone:
#  - a package using the installed headers and libraries builds through the installed catkin
#    exports (test/downstream_package: no find_package of OpenCV, Eigen or yaml-cpp of its own);
#  - the node runs the demo (demo.launch, which is loop_closure.launch with the demo's settings
#    and the reference pose graph) on the demo bag at 2x, with the installed default backbone: at
#    least 220 loops, all true (the demo publishes 228);
#  - the tools read the installed defaults (lcd_train --help, lcd_config, lcd_evaluate).
#   workspace_install.sh SOURCE_DIR
set -euo pipefail
root=$(cd "$1" && pwd -P)
install=$root/build/.install
export PATH="/usr/bin:$PATH"  # catkin's CMake and roslaunch run the system's Python

if [ "${LCD_SOURCE_HIDDEN:-}" != yes ]; then
  [ -f "$install/setup.bash" ] ||
    { echo "workspace_install: no install space in $install: run scripts/build.sh" >&2; exit 1; }
  stage=$(mktemp -d /tmp/lcd_workspace_XXXXXX)
  trap 'rm -rf "$stage"' EXIT
  # What the test needs from the repository, copied before it is hidden: this script, the helpers
  # that wait for connections, the downstream package and the demo bag (made once, in _demo/).
  cp "$0" "$root/scripts/ros_env.sh" "$stage/"
  cp -r "$root/test/downstream_package" "$stage/downstream_package"
  rm -f "$stage/downstream_package/CATKIN_IGNORE"
  bag=$root/_demo/corridor_2laps.bag
  if [ ! -f "$bag" ]; then
    mkdir -p "$root/_demo"
    "$install/lib/landmark_loop_closure/make_demo_bag" "$bag" 2 > /dev/null
  fi
  touch "$stage/demo.bag" && mkdir "$stage/install"
  status=0
  LCD_SOURCE_HIDDEN=yes LCD_STAGE=$stage LCD_BAG=$bag unshare --mount --propagation private \
    bash "$stage/workspace_install.sh" "$root" || status=$?
  exit "$status"
fi

# In the private mount namespace: only the install space (at its own path) and the bag remain.
stage=$LCD_STAGE
mount --bind "$LCD_BAG" "$stage/demo.bag"
mount --bind "$install" "$stage/install"
mount -t tmpfs -o size=1m,mode=0755 source_out_of_reach "$root"
mkdir -p "$install"
mount --bind "$stage/install" "$install"
cd "$stage"
[ ! -e "$root/package.xml" ] && [ ! -e "$root/_build" ] ||
  { echo "workspace_install: the source tree is still in reach" >&2; exit 1; }
log=$stage/launch.log
launch=""
report=""
cleanup() {
  [ -n "$PLAYER_PID" ] && kill -INT "$PLAYER_PID" 2> /dev/null || true
  [ -n "$report" ] && kill -INT "$report" 2> /dev/null && wait "$report" 2> /dev/null || true
  [ -n "$launch" ] && kill -INT "$launch" 2> /dev/null && wait "$launch" 2> /dev/null || true
}
trap cleanup EXIT
fail() {
  echo "workspace_install: $*" >&2
  [ -f "$log" ] && tail -30 "$log" >&2
  exit 1
}
PLAYER_PID=""
port=$((20000 + RANDOM % 20000))
export ROS_MASTER_URI=http://localhost:$port ROS_HOSTNAME=localhost
export ROSCONSOLE_STDOUT_LINE_BUFFERED=1 PYTHONUNBUFFERED=1  # the log is read while it runs
LCD_ROS_SETUP=$install/setup.bash
# shellcheck source=../../scripts/ros_env.sh
source "$stage/ros_env.sh"

share=$install/share/landmark_loop_closure
[ "$(rospack find landmark_loop_closure)" = "$share" ] ||
  fail "rospack finds $(rospack find landmark_loop_closure), not $share"
for file in lib/landmark_loop_closure/loop_closure_node lib/landmark_loop_closure/lcd_evaluate \
  lib/liblandmark_loop_closure_nodelet.so share/landmark_loop_closure/launch/loop_closure.launch \
  share/landmark_loop_closure/config/default.yaml share/landmark_loop_closure/nodelet_plugins.xml \
  share/landmark_loop_closure/model/calc_encoder.onnx share/landmark_loop_closure/model/mobilenet_v2.onnx \
  share/landmark_loop_closure/msg/LoopClosure.msg share/landmark_loop_closure/scripts/fetch_backbone.sh \
  share/landmark_loop_closure/scripts/convert_backbone.py; do
  [ -e "$install/$file" ] || fail "not installed: $file"
done

# The downstream package, built against the installed exports alone.
(cmake -S "$stage/downstream_package" -B "$stage/downstream" -DCMAKE_BUILD_TYPE=Release &&
  cmake --build "$stage/downstream" -- -j"$(nproc)" &&
  "$stage/downstream/devel/lib/landmark_loop_closure_downstream/uses_landmark_loop_closure") \
  > "$stage/downstream.log" 2>&1 ||
  { tail -30 "$stage/downstream.log" >&2; fail "the downstream package did not build or run against the installed exports"; }
grep -q "^downstream: found the stored keyframe" "$stage/downstream.log" ||
  fail "the downstream package did not run"

# The tools from the install space alone: their defaults are the installed ones.
("$install/lib/landmark_loop_closure/lcd_train" --help > /dev/null &&
  "$install/lib/landmark_loop_closure/lcd_config" defaults > "$stage/defaults.yaml" &&
  cmp -s "$stage/defaults.yaml" "$share/config/default.yaml" &&
  "$install/lib/landmark_loop_closure/lcd_evaluate" --detector --corridor 1 --sweep-steps 0 \
    --output "$stage/lcd_results" > "$stage/evaluate.log" 2>&1 &&
  grep -q "headline: recall" "$stage/evaluate.log") ||
  fail "an installed tool did not run from the install space, or its defaults differ"

# The demo through the installed node.
roslaunch -p "$port" landmark_loop_closure demo.launch > "$log" 2>&1 &
launch=$!
wait_for_service /loop_closure/reset "$launch" "$log"
pgrep -f "^$install/lib/landmark_loop_closure/loop_closure_node" > /dev/null ||
  fail "the running node is not the installed one"
first_line=$(grep -m1 "Descriptor backbone:" "$log" || true)
[[ "$first_line" == *"the pretrained network $share/model/mobilenet_v2.onnx"* &&
  "$first_line" == *"package models from $share/model"* ]] ||
  fail "the node's first line does not name the installed backbone: $first_line"
rosrun landmark_loop_closure demo_report > "$stage/report.log" 2>&1 &
report=$!
wait_for_connections /loop_closure "$log" /keyframes:/pose_graph /keyframes:/demo_report \
  /loop_closures:/demo_report /loop_closures:/pose_graph
wait_for_connections /pose_graph "$log" /pose_graph/loop_verdicts:/demo_report
play_bag_when_connected "$stage/demo.bag" 2 "$log" /camera/image_raw:/loop_closure \
  /camera/camera_info:/loop_closure /odom:/loop_closure /ground_truth:/demo_report
wait "$PLAYER_PID"
PLAYER_PID=""
sleep 3  # The detector's worker finishes the last keyframes.
kill -INT "$report" && wait "$report" || true
report=""
summary=$(sed -n 's/^loops published: *\([0-9]*\) (true \([0-9]*\), false \([0-9]*\)).*/\1 \2 \3/p' \
  "$stage/report.log")
[ -n "$summary" ] || { cat "$stage/report.log" >&2; fail "the demo report printed no summary"; }
read -r loops true_loops false_loops <<< "$summary"
[ "$false_loops" = 0 ] || { cat "$stage/report.log" >&2; fail "$false_loops false loops"; }
[ "$loops" -ge 220 ] || { cat "$stage/report.log" >&2; fail "only $loops loops (220 needed)"; }
echo "workspace_install: from $install alone, the source tree out of reach: $loops loops" \
  "($true_loops true) on the demo bag at 2x; $(sed "s/\x1b\[[0-9;]*m//g" <<< "$first_line")"
