#!/usr/bin/env bash
# Kill soak (about 10 minutes; CI runs 3 kills): nothing published is lost, nothing is published
# twice.
# Repeats N times (default 20), on the demo corridor bag played from a random point:
#   1. a node maps onto _kill_soak/A.db (the map the previous round left there) and is killed
#      with SIGKILL at a random moment;
#   2. a second node maps into its own map, then saves it onto A.db with overwrite (the killed
#      map is kept aside, its write-ahead log with it) and loads the kept copy, then stops.
# Every Keyframe message of every node is recorded; at the end scripts/kill_soak_check.py reads
# every map file left in _kill_soak/ and fails unless every published (map_id, id) is in some
# file, no (map_id, id) was published for two frames and no file holds one twice.
#   scripts/kill_soak.sh [--kills N] [--seed S] [--no-setup]   results in _kill_soak/ (maps, logs,
#                                                              report)
# --no-setup skips installing and building (CI's short run: tool_kill_soak, 3 kills, on a ROS
# master port of its own).
set -euo pipefail
cd "$(dirname "$0")/.."
KILLS=20
SEED=$RANDOM
SETUP=true
while [ $# -gt 0 ]; do
  case "$1" in
    --kills) KILLS="$2"; shift ;;
    --seed) SEED="$2"; shift ;;
    --no-setup) SETUP=false ;;
    *) echo "usage: scripts/kill_soak.sh [--kills N] [--seed S] [--no-setup]" >&2; exit 2 ;;
  esac
  shift
done
RANDOM=$SEED

if [ "$SETUP" = true ]; then
  scripts/install_deps.sh
  scripts/build.sh
fi
source scripts/ros_env.sh
TOOLS=_build/devel/lib/landmark_loop_closure
BAG=_demo/corridor_2laps.bag
mkdir -p _demo
[ -f "$BAG" ] || "$TOOLS/make_demo_bag" "$BAG" 2 10 0.02 0.004
OUT="$(pwd)/_kill_soak"
rm -rf "$OUT"
mkdir -p "$OUT"
echo "kill soak: $KILLS kills, seed $SEED, results in $OUT"

CORE_PID=""
RECORDER_PID=""
NODE_PID=""
PLAYER_PID=""
finish() {
  trap - EXIT INT TERM
  for pid in "$PLAYER_PID" "$NODE_PID" "$RECORDER_PID" "$CORE_PID"; do
    [ -n "$pid" ] && kill -INT "$pid" 2> /dev/null && wait "$pid" 2> /dev/null || true
  done
}
trap finish EXIT INT TERM
roscore -p "${ROS_MASTER_URI##*:}" > "$OUT/roscore.log" 2>&1 &
CORE_PID=$!
until rosparam list > /dev/null 2>&1; do sleep 0.5; done
rosparam set use_sim_time true
PYTHONUNBUFFERED=1 rostopic echo -p /keyframes > "$OUT/published.csv" 2> "$OUT/recorder.log" &
RECORDER_PID=$!

# start_node NAME MAP: the detector with the demo's settings on MAP, in its own process.
start_node() {
  local name=$1 map=$2
  rosparam delete "/$name" > /dev/null 2>&1 || true
  rosparam load config/default.yaml "/$name"
  rosparam load config/demo.yaml "/$name"
  rosparam set "/$name/database_path" "$map"
  "$TOOLS/loop_closure_node" __name:="$name" image:=/camera/image_raw odom:=/odom \
    >> "$OUT/$name.log" 2>&1 &
  NODE_PID=$!
  for _ in $(seq 1 120); do
    rosservice list 2> /dev/null | grep -q "^/$name/save_database" && return 0
    kill -0 "$NODE_PID" 2> /dev/null || { echo "kill soak: $name did not start, see $OUT/$name.log" >&2; exit 1; }
    sleep 0.5
  done
  echo "kill soak: $name did not advertise its services within 60 s" >&2
  exit 1
}

# play_from NAME: the bag from a random point into node NAME, once both are connected.
play_from() {
  local name=$1
  local start=$((RANDOM % 100))
  rosbag play --clock --quiet --pause --rate=2 --start="$start" "$BAG" __name:=bag_player \
    < /dev/null > /dev/null 2>&1 &
  PLAYER_PID=$!
  wait_for_connections /bag_player "$OUT/$name.log" "/camera/image_raw:/$name" "/odom:/$name" \
    "/camera/camera_info:/$name"
  rosservice call /bag_player/pause_playback "data: false" > /dev/null
}

stop_player() {
  kill -INT "$PLAYER_PID" 2> /dev/null && wait "$PLAYER_PID" 2> /dev/null || true
  PLAYER_PID=""
}

for round in $(seq 1 "$KILLS"); do
  # 1. Mapping onto A.db, killed at a random moment (0.5 to 12 s into the bag).
  start_node mapper "$OUT/A.db"
  play_from mapper
  delay=$(python3 -c "import random; random.seed($SEED * 100 + $round); print(round(random.uniform(0.5, 12), 2))")
  sleep "$delay"
  kill -KILL "$NODE_PID"
  wait "$NODE_PID" 2> /dev/null || true
  NODE_PID=""
  stop_player
  echo y | rosnode cleanup > /dev/null 2>&1 || true  # The killed node's registration.
  echo "round $round: mapper killed after ${delay} s"

  # 2. Another node's map saved onto A.db with overwrite, then the kept copy loaded.
  start_node saver "$OUT/B$round.db"
  play_from saver
  sleep 4
  stop_player
  sleep 1
  saved=$(rosservice call /saver/save_database "{path: '$OUT/A.db', overwrite: true}")
  # The map kept aside now: the newest name (a rename keeps the file's time; the service's
  # message wraps the name over lines).
  kept=$(ls -d "$OUT"/A.db.replaced-* 2> /dev/null \
    | grep -v -e '-wal$' -e '-shm$' -e '-vectors$' -e '-graph$' -e '-summaries$' | sort | tail -1 \
    || true)
  if ! grep -q "success: True" <<< "$saved" || [ -z "$kept" ]; then
    echo "kill soak: round $round: the save kept nothing aside: $saved" >&2
    exit 1
  fi
  loaded=$(rosservice call /saver/load_database "{path: '$kept', overwrite: false}")
  grep -q "success: True" <<< "$loaded" || { echo "kill soak: round $round: the kept copy $kept did not load: $loaded" >&2; exit 1; }
  echo "round $round: kept copy $(basename "$kept") loaded ($(sed -n 's/.*keyframes: \([0-9]*\).*/\1/p' <<< "$loaded") keyframes)"
  kill -INT "$NODE_PID"
  wait "$NODE_PID" 2> /dev/null || true
  NODE_PID=""
done

kill -INT "$RECORDER_PID" 2> /dev/null && wait "$RECORDER_PID" 2> /dev/null || true
RECORDER_PID=""
python3 scripts/kill_soak_check.py "$OUT" | tee "$OUT/report.txt"
