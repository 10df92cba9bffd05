#!/bin/bash
# The pose-graph benchmark on KITTI 06's real route (../shared/data; skipped without it): with a
# fifth of the loops wrong, the shipped settings accept none of them, refuse no true one, and the
# corrected path is far closer to the truth than the drifting odometry.
set -euo pipefail
bench="$1"
poses="$(cd "$(dirname "$0")/../.." && pwd)/../shared/data/kitti_poses/06.txt"
if [ ! -f "$poses" ]; then
  echo "skipped: $poses is not there"
  exit 77  # ctest: Not Run (SKIP_RETURN_CODE)
fi
report="$("$bench" --kitti "$poses" --scale-error 0.01 --heading-error 0.0001 --wrong-loops 0.2)"
echo "$report"
read -r wrong accepted refused < <(sed -nE \
  's/.*\(([0-9]+) wrong, ([0-9]+) of them accepted; ([0-9]+) true refused\).*/\1 \2 \3/p' <<<"$report")
read -r odometry corrected < <(sed -nE \
  's/.*similarity-aligned ([0-9.]+) m, ([0-9.]+) m;.*/\1 \2/p' <<<"$report")
[ "${wrong:-0}" -ge 10 ] || { echo "too few wrong loops to tell: '${wrong:-}'"; exit 1; }
[ "$accepted" -eq 0 ] || { echo "$accepted wrong loops accepted"; exit 1; }
[ "$refused" -eq 0 ] || { echo "$refused true loops refused"; exit 1; }
awk -v o="$odometry" -v c="$corrected" 'BEGIN { exit !(c < o / 5) }' ||
  { echo "corrected $corrected m is not a fifth of the odometry's $odometry m"; exit 1; }
echo "pose graph on KITTI 06: $wrong wrong loops refused, corrected $corrected m (odometry $odometry m)"
