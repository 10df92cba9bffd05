#!/usr/bin/env bash
# One command from a fresh Debian 12 machine: installs what is missing, builds, generates the
# demo bag (a camera driven twice around a textured corridor, drifting odometry, ground truth)
# and plays it into the detector, printing one line per loop (TRUE or FALSE against ground truth)
# and a summary at the end. The detector's own log goes to _demo/roslaunch.log.
#   scripts/demo.sh [--rviz] [--laps N] [--rate R] [--wrong-loops F] [--scale-error E]
#                   [--heading-drift D] [--no-setup]
#   scripts/demo.sh --two-robots [--gardens-point] [--rate R] [--no-setup]
# --rviz keeps rviz open after the bag, to look at the map, until it is closed or Ctrl-C.
# --wrong-loops F replaces that share of loops by wrong ones before the pose graph (loop_injector),
# to see it refuse them: the summary counts them.
# --scale-error E and --heading-drift D (rad/m) set the demo odometry's errors (default 0.02 and
# 0.004), to see what each costs the corrected path.
# --two-robots: robot_a drives lap 1 of the corridor, robot_b one lap from another start in its
# own odometry frame (launch/two_robots.launch): robot_b's detector searches the keyframes robot_a
# shares and publishes loops into robot_a's map; one pose graph puts both in one frame.
# --gardens-point (with --two-robots): the same with real images and no odometry, Gardens Point's
# day left walk as robot_a and its night right walk as robot_b, a frame a second (from
# ../shared/data/gardens_point; image i of each shows place i, +-3 counts as the place).
# --no-setup skips installing and building (what the demo's test does).
set -euo pipefail
cd "$(dirname "$0")/.."
RVIZ=false
LAPS=2
RATE=2.0
SETUP=true
TWO_ROBOTS=false
GARDENS_POINT=false
WRONG_LOOPS=0.0
SCALE_ERROR=0.02
HEADING_DRIFT=0.004
USAGE="usage: scripts/demo.sh [--rviz] [--laps N] [--rate R] [--wrong-loops F] [--scale-error E] [--heading-drift D] [--no-setup]
       scripts/demo.sh --two-robots [--gardens-point] [--rate R] [--no-setup]"
while [ $# -gt 0 ]; do
  case "$1" in
    --rviz) RVIZ=true ;;
    --laps) LAPS="$2"; shift ;;
    --rate) RATE="$2"; shift ;;
    --wrong-loops) WRONG_LOOPS="$2"; shift ;;
    --scale-error) SCALE_ERROR="$2"; shift ;;
    --heading-drift) HEADING_DRIFT="$2"; shift ;;
    --no-setup) SETUP=false ;;
    --two-robots) TWO_ROBOTS=true ;;
    --gardens-point) GARDENS_POINT=true ;;
    *) echo "$USAGE" >&2; exit 2 ;;
  esac
  shift
done
if [ "$TWO_ROBOTS" = true ] && { [ "$RVIZ" = true ] || [ "$LAPS" != 2 ] ||
  [ "$WRONG_LOOPS" != 0.0 ] || [ "$SCALE_ERROR" != 0.02 ] || [ "$HEADING_DRIFT" != 0.004 ]; }; then
  echo "demo: --two-robots takes only --gardens-point, --rate and --no-setup" >&2
  echo "$USAGE" >&2
  exit 2
fi
GARDENS_POINT_DATA=../shared/data/gardens_point
if [ "$GARDENS_POINT" = true ]; then
  if [ "$TWO_ROBOTS" != true ]; then
    echo "demo: --gardens-point goes with --two-robots" >&2
    exit 2
  fi
  if [ ! -d "$GARDENS_POINT_DATA/day_left" ] || [ ! -d "$GARDENS_POINT_DATA/night_right" ]; then
    echo "demo: --gardens-point reads $GARDENS_POINT_DATA/day_left and night_right, not here" >&2
    exit 1
  fi
fi

phase() { echo; echo "==== $* ===="; }

if [ "$SETUP" = true ]; then
  phase "1/4 Installing what is missing"
  scripts/install_deps.sh
  phase "2/4 Building (about 8 minutes on 2 cores the first time)"
  scripts/build.sh
fi

source scripts/ros_env.sh
mkdir -p _demo
LOG=_demo/roslaunch.log
launch_pid=""
report_pid=""
PLAYER_PID=""
finish() {
  trap - EXIT INT TERM
  [ -n "$PLAYER_PID" ] && kill -INT "$PLAYER_PID" 2> /dev/null || true
  [ -n "$report_pid" ] && kill -INT "$report_pid" 2> /dev/null && wait "$report_pid" || true
  [ -n "$launch_pid" ] && kill -INT "$launch_pid" 2> /dev/null && wait "$launch_pid" || true
}
trap finish EXIT INT TERM

if [ "$TWO_ROBOTS" = true ]; then
  TRUE_LOOP_DISTANCE=2.5
  if [ "$GARDENS_POINT" = true ]; then
    BAG=_demo/gardens_point_two_robots.bag
    TRUE_LOOP_DISTANCE=3.5  # Places are 1 m apart in the bag: +-3 images.
    if [ ! -f "$BAG" ]; then
      phase "3/4 Writing Gardens Point's day left and night right walks into a bag"
      _build/devel/lib/landmark_loop_closure/make_demo_bag --traversals \
        "$GARDENS_POINT_DATA/day_left" "$GARDENS_POINT_DATA/night_right" "$BAG"
    fi
    phase "4/4 Playing robot_a's walk (day, left), then robot_b's (night, right), into their detectors"
  else
    BAG=_demo/corridor_two_robots.bag
    if [ ! -f "$BAG" ]; then
      phase "3/4 Generating the two robots' bag"
      _build/devel/lib/landmark_loop_closure/make_demo_bag --two-robots "$BAG" 10
    fi
    phase "4/4 Playing robot_a's lap, then robot_b's, into their detectors"
  fi
  roslaunch landmark_loop_closure two_robots.launch > "$LOG" 2>&1 &
  launch_pid=$!
  wait_for_service /robot_a/loop_closure/reset "$launch_pid" "$LOG"
  wait_for_service /robot_b/loop_closure/reset "$launch_pid" "$LOG"
  rosrun landmark_loop_closure demo_report _robots:="/robot_a /robot_b" \
    _true_loop_distance:="$TRUE_LOOP_DISTANCE" &
  report_pid=$!
  for robot in robot_a robot_b; do
    wait_for_connections /$robot/loop_closure "$LOG" /$robot/keyframes:/pose_graph \
      /$robot/loop_closures:/pose_graph /$robot/keyframes:/demo_report \
      /$robot/loop_closures:/demo_report
  done
  wait_for_connections /robot_a/loop_closure "$LOG" \
    /robot_a/loop_closure/shared_keyframes:/robot_b/loop_closure
  wait_for_connections /pose_graph "$LOG" /pose_graph/loop_verdicts:/demo_report
  play_bag_when_connected "$BAG" "$RATE" "$LOG" /robot_a/camera/image_raw:/robot_a/loop_closure \
    /robot_a/camera/camera_info:/robot_a/loop_closure /robot_a/odom:/robot_a/loop_closure \
    /robot_b/camera/image_raw:/robot_b/loop_closure /robot_b/camera/camera_info:/robot_b/loop_closure \
    /robot_b/odom:/robot_b/loop_closure /ground_truth:/demo_report
  wait "$PLAYER_PID"
  PLAYER_PID=""
  sleep 3  # The detectors' workers finish the last keyframes.
  kill -INT "$report_pid" && wait "$report_pid" || true
  report_pid=""
  exit 0
fi

BAG=_demo/corridor_${LAPS}laps.bag
if [ "$SCALE_ERROR" != 0.02 ] || [ "$HEADING_DRIFT" != 0.004 ]; then
  BAG=_demo/corridor_${LAPS}laps_scale${SCALE_ERROR}_drift${HEADING_DRIFT}.bag
fi
if [ ! -f "$BAG" ]; then
  phase "3/4 Generating the demo bag ($LAPS laps)"
  _build/devel/lib/landmark_loop_closure/make_demo_bag "$BAG" "$LAPS" 10 "$SCALE_ERROR" \
    "$HEADING_DRIFT"
fi

phase "4/4 Playing the bag into the detector"
# The detector (and rviz) under roslaunch, its output in the log; the report and the bag from here,
# so the console shows the loops and the summary only.
roslaunch landmark_loop_closure demo.launch rviz:="$RVIZ" wrong_loops:="$WRONG_LOOPS" > "$LOG" 2>&1 &
launch_pid=$!
wait_for_service /loop_closure/reset "$launch_pid" "$LOG"
rosrun landmark_loop_closure demo_report &
report_pid=$!
# Every node is connected before the bag plays: a keyframe sent before the pose graph listens is
# missing from its graph, and the first pose every error is aligned on moves with it.
detector_links=(/keyframes:/pose_graph /keyframes:/demo_report /loop_closures:/demo_report)
if awk -v share="$WRONG_LOOPS" 'BEGIN { exit !(share > 0) }'; then
  detector_links+=(/keyframes:/loop_injector /loop_closures:/loop_injector)
  wait_for_connections /loop_injector "$LOG" /loop_closures_injected:/pose_graph
else
  detector_links+=(/loop_closures:/pose_graph)
fi
wait_for_connections /loop_closure "$LOG" "${detector_links[@]}"
wait_for_connections /pose_graph "$LOG" /pose_graph/loop_verdicts:/demo_report
play_bag_when_connected "$BAG" "$RATE" "$LOG" /camera/image_raw:/loop_closure \
  /camera/camera_info:/loop_closure /odom:/loop_closure /ground_truth:/demo_report
wait "$PLAYER_PID"
sleep 3  # The detector's worker finishes the last keyframes.
if [ "$RVIZ" = true ]; then
  echo "The bag has ended. rviz stays open with the final map: close it or press Ctrl-C to end."
fi
kill -INT "$report_pid" && wait "$report_pid" || true
report_pid=""
if [ "$RVIZ" = true ]; then
  wait "$launch_pid" || true  # Closing rviz ends the launch (rviz is required there).
  launch_pid=""
fi
