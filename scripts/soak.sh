#!/usr/bin/env bash
# Soak test (not CI): replays a long generated corridor sequence (default 20 000 frames at 30 Hz,
# about 11 minutes) through the running node with the demo settings and reports the node's
# resident memory over time (growth after the first minute, maximum), keyframes dropped by the
# worker, and the loops found against ground truth (demo_report's summary).
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
scripts/build.sh
source scripts/ros_env.sh
mkdir -p _soak
TOOLS=_build/devel/lib/landmark_loop_closure
# One lap of the corridor is FRAMES_PER_LAP frames at 30 Hz (make_demo_bag prints it).
FRAMES_PER_LAP=$("$TOOLS/make_demo_bag" _soak/probe.bag 1 | sed -n 's/.*wrote \([0-9]*\) frames.*/\1/p')
rm -f _soak/probe.bag
LAPS=$(python3 -c "import math; print(math.ceil($FRAMES / $FRAMES_PER_LAP))")
BAG=_soak/corridor_${LAPS}laps.bag
[ -f "$BAG" ] || "$TOOLS/make_demo_bag" "$BAG" "$LAPS"

roslaunch --screen landmark_loop_closure demo.launch bag:="$(pwd)/$BAG" rate:=1.0 \
  > _soak/launch.log 2>&1 &
LAUNCH=$!
trap 'kill -INT $LAUNCH 2>/dev/null || true' EXIT
echo "seconds,rss_kb" > _soak/rss.csv
START=$(date +%s)
until pgrep -f "__name:=loop_closure" > /dev/null; do sleep 1; done
rostopic echo -p /diagnostics > _soak/diagnostics.txt 2>/dev/null &
ECHO=$!
while kill -0 $LAUNCH 2>/dev/null && pgrep -f "rosbag/play\|record/play\|play --clock" > /dev/null; do
  PID=$(pgrep -f "__name:=loop_closure" | head -1)
  [ -n "$PID" ] && echo "$(( $(date +%s) - START )),$(ps -o rss= -p "$PID" | tr -d ' ')" >> _soak/rss.csv
  sleep 5
done
sleep 5
kill $ECHO 2>/dev/null || true
kill -INT $LAUNCH 2>/dev/null || true
wait $LAUNCH 2>/dev/null || true
trap - EXIT

python3 - "$FRAMES_PER_LAP" "$LAPS" <<'PY'
import csv, re, sys
frames = int(sys.argv[1]) * int(sys.argv[2])
rows = [(int(r["seconds"]), int(r["rss_kb"])) for r in csv.DictReader(open("_soak/rss.csv")) if r["rss_kb"]]
after_warmup = [kb for s, kb in rows if s >= 60] or [kb for _, kb in rows]
print(f"frames played: {frames} ({sys.argv[2]} laps), samples: {len(rows)}")
if rows:
    print(f"RSS: {after_warmup[0] / 1024:.0f} MB after the first minute, max {max(kb for _, kb in rows) / 1024:.0f} MB,"
          f" growth after the first minute {(max(after_warmup) - after_warmup[0]) / 1024:.0f} MB")
text = open("_soak/diagnostics.txt").read()
for key in ("keyframes dropped (worker busy)", "keyframes", "loops published", "database bytes"):
    values = re.findall(re.escape(key) + r"[^\n]*?,\s*([0-9]+)", text)
    if values:
        print(f"{key}: {values[-1]}")
PY
echo "demo_report summary:"
grep -A8 -i "summary" _soak/launch.log | tail -12 || true
