#!/bin/bash
# The verification benchmark reads a sequence in KITTI odometry's layout: the generated corridor
# exported that way gives loops, none false, with metric poses.
set -euo pipefail
bench="$1"
folder="$(mktemp -d)"
trap 'rm -rf "$folder"' EXIT
"$bench" --export-kitti "$folder" --laps 1.4
report="$("$bench" --kitti-images "$folder/image_0" --kitti-poses "$folder/poses.txt" \
  --kitti-times "$folder/times.txt" --kitti-calib "$folder/calib.txt" --true-distance 2.5 \
  --variants shipped)"
echo "$report"
# | check + gate (shipped) | keyframes | revisited | loops | true | false | precision | recall |
row="$(grep '^| check + gate' <<<"$report")"
loops="$(cut -d'|' -f5 <<<"$row" | tr -d ' ')"
false_loops="$(cut -d'|' -f7 <<<"$row" | tr -d ' ')"
metric="$(sed -n 's/^Metric relative poses: \([0-9]*\) of.*/\1/p' <<<"$report")"
[[ "$loops" -ge 5 ]] || { echo "expected >= 5 loops, got $loops"; exit 1; }
[[ "$false_loops" -eq 0 ]] || { echo "expected no false loop, got $false_loops"; exit 1; }
[[ "$metric" -ge 1 ]] || { echo "expected metric poses, got $metric"; exit 1; }
