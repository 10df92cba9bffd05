#!/usr/bin/env bash
# Soak test (not CI): replays a long generated corridor sequence (default >= 20 000 frames at
# 30 Hz, about 12 minutes) through the running node with the demo settings and reports the node's
# resident memory over time against what its database holds, frames played against frames
# admitted, keyframes dropped by the worker, and the loops found against ground truth
# (demo_report's summary). The node stores its keyframes in a map file (_soak/map.db, started
# empty), so resident memory shows what search keeps, not the keyframes.
#   scripts/soak.sh [--frames N]       results in _soak/ (bag, rss.csv, diagnostics, report)
set -euo pipefail
cd "$(dirname "$0")/.."
FRAMES=20000
while [ $# -gt 0 ]; do
  case "$1" in
    --frames) FRAMES="$2"; shift ;;
    *) echo "usage: scripts/soak.sh [--frames N]" >&2; exit 2 ;;
  esac
  shift
done

scripts/install_deps.sh
# rostopic needs the diagnostics messages' Python module to record the node's counters.
if ! dpkg -s python3-diagnostic-msgs > /dev/null 2>&1; then
  SUDO=""
  if [ "$(id -u)" -ne 0 ]; then SUDO="sudo"; fi
  $SUDO apt-get install -y -qq --no-install-recommends python3-diagnostic-msgs
fi
scripts/build.sh
source scripts/ros_env.sh
mkdir -p _soak
TOOLS=_build/devel/lib/landmark_loop_closure
RATE=30
# One lap of the corridor is FRAMES_PER_LAP frames at RATE Hz (make_demo_bag prints it).
FRAMES_PER_LAP=$("$TOOLS/make_demo_bag" _soak/probe.bag 1 "$RATE" \
  | sed -n 's/.*wrote \([0-9]*\) frames.*/\1/p')
rm -f _soak/probe.bag
LAPS=$(python3 -c "import math; print(math.ceil($FRAMES / $FRAMES_PER_LAP))")
BAG=_soak/corridor_${LAPS}laps_${RATE}hz.bag
[ -f "$BAG" ] || "$TOOLS/make_demo_bag" "$BAG" "$LAPS" "$RATE"
FRAMES_IN_BAG=$(rosbag info -y -k topics "$BAG" | python3 -c "
import sys, yaml
print(next(t['messages'] for t in yaml.safe_load(sys.stdin) if t['topic'] == '/camera/image_raw'))")

MAP="$(pwd)/_soak/map.db"
rm -f "$MAP" "$MAP"-*
{ cat config/demo.yaml; echo "database_path: \"$MAP\""; } > _soak/soak.yaml
launch_pid=""
report_pid=""
echo_pid=""
PLAYER_PID=""
finish() {
  trap - EXIT INT TERM
  for pid in "$PLAYER_PID" "$echo_pid" "$report_pid" "$launch_pid"; do
    [ -n "$pid" ] && kill -INT "$pid" 2> /dev/null && wait "$pid" 2> /dev/null || true
  done
}
trap finish EXIT INT TERM
roslaunch --screen landmark_loop_closure demo.launch config:="$(pwd)/_soak/soak.yaml" \
  > _soak/launch.log 2>&1 &
launch_pid=$!
until rosservice list 2> /dev/null | grep -q "^/loop_closure/reset"; do
  kill -0 "$launch_pid" 2> /dev/null || { echo "soak: the node did not start, see _soak/launch.log" >&2; exit 1; }
  sleep 0.5
done
NODE=$(pgrep -f "__name:=loop_closure" | head -1)
rosrun landmark_loop_closure demo_report > _soak/report.log 2>&1 &
report_pid=$!
PYTHONUNBUFFERED=1 rostopic echo -p /diagnostics > _soak/diagnostics.txt &
echo_pid=$!
# Every node is connected before the bag plays, as in the demo: the node admits every frame, the
# pose graph and the report see every keyframe and loop from the first.
wait_for_connections /loop_closure _soak/launch.log /keyframes:/pose_graph \
  /loop_closures:/pose_graph /keyframes:/demo_report /loop_closures:/demo_report
echo "seconds,rss_kb" > _soak/rss.csv
START=$(date +%s)
play_bag_when_connected "$BAG" 1.0 _soak/launch.log /camera/image_raw:/loop_closure \
  /camera/camera_info:/loop_closure /odom:/loop_closure /ground_truth:/demo_report
while kill -0 "$PLAYER_PID" 2> /dev/null; do
  echo "$(( $(date +%s) - START )),$(ps -o rss= -p "$NODE" | tr -d ' ')" >> _soak/rss.csv
  sleep 5
done
sleep 5  # The worker finishes the last keyframes; the last diagnostics arrive.
finish
MAP_BYTES=$(cat "$MAP" "$MAP"-* 2> /dev/null | wc -c)
echo "map on disk after shutdown: $MAP_BYTES bytes ($MAP and the files beside it)"

python3 - "$FRAMES_IN_BAG" "$LAPS" "$RATE" <<'PY'
import csv, sys
frames, laps, rate = int(sys.argv[1]), sys.argv[2], sys.argv[3]
rows = [(int(r["seconds"]), int(r["rss_kb"]) * 1024)
        for r in csv.DictReader(open("_soak/rss.csv")) if r["rss_kb"]]
print(f"frames in the bag: {frames} at {rate} Hz ({laps} laps), RSS samples: {len(rows)}")
# Each diagnostics row holds key,value pairs; keep the node's counters.
KEYS = ("frames admitted", "keyframes", "database bytes", "keyframes dropped (worker busy)",
        "keyframes past the memory budget", "loops published",
        "max keyframe processing (ms)")
status = []
for line in open("_soak/diagnostics.txt"):
    fields = line.rstrip("\n").split(",")
    values = {fields[i]: fields[i + 1] for i in range(len(fields) - 1) if fields[i] in KEYS}
    if "database bytes" in values:
        status.append(values)
if rows:
    mb = 1 / 2**20
    print(f"RSS: first sample {rows[0][1] * mb:.0f} MB, last {rows[-1][1] * mb:.0f} MB, "
          f"max {max(b for _, b in rows) * mb:.0f} MB")
    if status:
        grown = rows[-1][1] - rows[0][1]
        held = int(status[-1]["database bytes"]) - int(status[0]["database bytes"])
        print(f"RSS growth {grown * mb:.0f} MB, of which the database's own accounting "
              f"{held * mb:.0f} MB; not explained by stored keyframes: {(grown - held) * mb:.0f} MB")
if status:
    for key in KEYS:
        print(f"{key}: {status[-1].get(key, '?')}")
    admitted = int(status[-1].get("frames admitted", 0))
    print(f"frames not admitted: {frames - admitted} of {frames}")
else:
    print("no diagnostics recorded (see _soak/diagnostics.txt)")
PY
echo "demo_report summary:"
sed -n '/==== demo summary ====/,$p' _soak/report.log
