#!/usr/bin/env bash
# lcd_evaluate checks --camera-info against the images before evaluating anything (as the node
# checks camera_info against its images): another camera's calibration stops even a dry run with
# a line naming both sizes; the shipped Gardens Point calibration passes; where nothing uses it,
# it says so. Reads Gardens Point from
# ../shared/data (CI has it).
#   evaluate_camera_info.sh SOURCE_DIR LCD_EVALUATE
set -euo pipefail
source_dir="$1" evaluate="$2"
data="$source_dir/../shared/data/gardens_point"
if [ ! -d "$data/day_left" ]; then
  echo "skipped: $data is not here"
  exit 77  # ctest: Not Run (SKIP_RETURN_CODE)
fi
folder="$(mktemp -d)"
trap 'rm -rf "$folder"' EXIT
# The same file with a 4:3 image size: another camera.
sed 's/^image_height: 540$/image_height: 720/; s/270\.0/360.0/' \
  "$source_dir/bench/cameras/gardens_point.yaml" > "$folder/other_camera.yaml"
grep -q "image_height: 720" "$folder/other_camera.yaml"
for mode in "--appearance-check" "--detector --as-sequence"; do
  # shellcheck disable=SC2086
  if "$evaluate" --database "$data/day_left" --queries "$data/day_right" --gt-aligned 3 --limit 5 \
      $mode --camera-info "$folder/other_camera.yaml" --output "$folder/results" --dry-run \
      2> "$folder/error.txt" > /dev/null; then
    echo "another camera's calibration was accepted ($mode)"; exit 1
  fi
  grep -q "960x720 has another aspect ratio than the 960x540 images" "$folder/error.txt" ||
    { cat "$folder/error.txt"; exit 1; }
  # shellcheck disable=SC2086
  "$evaluate" --database "$data/day_left" --queries "$data/day_right" --gt-aligned 3 --limit 5 \
    $mode --camera-info "$source_dir/bench/cameras/gardens_point.yaml" \
    --output "$folder/results" --dry-run > /dev/null
done
# Single-image matching without the node's checks has no use for the calibration: it says so.
"$evaluate" --database "$data/day_left" --queries "$data/day_right" --gt-aligned 3 --limit 5 \
  --camera-info "$source_dir/bench/cameras/gardens_point.yaml" --output "$folder/results" \
  --dry-run 2> "$folder/error.txt" > /dev/null
grep -q "camera-info is used by --detector and --appearance-check only" "$folder/error.txt" ||
  { echo "an unused --camera-info went unmentioned"; cat "$folder/error.txt"; exit 1; }
# With the appearance check switched off, the checks line says so instead of naming its setting.
printf 'advanced:\n  verification:\n    appearance:\n      enabled: false\n' > "$folder/no_appearance.yaml"
"$evaluate" --database "$data/day_left" --queries "$data/day_right" --gt-aligned 3 --limit 5 \
  --descriptors hog --appearance-check --config "$folder/no_appearance.yaml" \
  --camera-info "$source_dir/bench/cameras/gardens_point.yaml" --output "$folder/results" \
  > "$folder/output.txt"
grep -q "ORB min_inliers [0-9]*, then appearance check off)" "$folder/output.txt" ||
  { echo "the checks line does not say the appearance check is off"; cat "$folder/output.txt"
    exit 1; }
echo "camera_info checked against the images in both modes"
