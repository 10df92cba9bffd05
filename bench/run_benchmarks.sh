#!/usr/bin/env bash
# Regenerates everything in bench/: every dataset of ../shared/data that has images, the
# generated corridor, the scaling benchmark, the results table (bench/results.md) and the plots.
# Takes about 30 minutes on 2 cores. Needs ../shared/data; plots need python3-matplotlib
# (installed here when missing).
set -euo pipefail
cd "$(dirname "$0")/.."
DATA=${DATA:-../shared/data}
OUT=bench/results
scripts/install_deps.sh
scripts/build.sh
if ! /usr/bin/python3 -c "import matplotlib" 2> /dev/null; then
  sudo_cmd=""; [ "$(id -u)" -ne 0 ] && sudo_cmd=sudo
  $sudo_cmd apt-get install -y -qq --no-install-recommends python3-matplotlib
fi
EVALUATE=_build/devel/lib/landmark_loop_closure/lcd_evaluate
DESCRIPTORS=pixels,hog,hog_whole,calc,landmarks

run() {  # name, then lcd_evaluate arguments
  local name=$1; shift
  echo "== $name"
  "$EVALUATE" --descriptors "$DESCRIPTORS" --output "$OUT/$name" "$@" 2> >(grep -v "^lcd_evaluate: \(describing\|matching\)" >&2)
}

run nordland --name "Nordland winter vs summer (+-2)" \
  --database "$DATA/nordland/summer" --queries "$DATA/nordland/winter" --gt-aligned 2
run gardens_point_viewpoint --name "Gardens Point day right vs day left (+-3)" \
  --database "$DATA/gardens_point/day_left" --queries "$DATA/gardens_point/day_right" --gt-aligned 3
run gardens_point_day_night --name "Gardens Point night right vs day right (+-3)" \
  --database "$DATA/gardens_point/day_right" --queries "$DATA/gardens_point/night_right" --gt-aligned 3
run gardens_point_both --name "Gardens Point night right vs day left (+-3)" \
  --database "$DATA/gardens_point/day_left" --queries "$DATA/gardens_point/night_right" --gt-aligned 3
run corridor --name "Generated corridor, 2 laps (sequence)" --corridor 2 --exclude-recent 60

# Landmark choices, each against the default (conv2 crops, grid 2, penalising shape weight,
# shared pass): the paper's shape weighting, conv3 crops, one network pass per landmark (~50
# passes per image, so Gardens Point and 300 Nordland frames only).
DESCRIPTORS=landmarks,landmarks_paper,landmarks_conv3_grid4,landmarks_per_landmark
run gardens_point_viewpoint_variants --name "Gardens Point day right vs day left (+-3)" \
  --database "$DATA/gardens_point/day_left" --queries "$DATA/gardens_point/day_right" --gt-aligned 3
run nordland_300_variants --name "Nordland winter vs summer, first 300 (+-2)" --limit 300 \
  --database "$DATA/nordland/summer" --queries "$DATA/nordland/winter" --gt-aligned 2

echo "== scaling"
_build/devel/lib/landmark_loop_closure/lcd_bench_scaling 1000,10000,100000 200 > "$OUT/scaling.md"
cat "$OUT/scaling.md"

/usr/bin/python3 scripts/plot_results.py "$OUT"/*/
/usr/bin/python3 bench/make_table.py "$OUT"/nordland "$OUT"/gardens_point_viewpoint \
  "$OUT"/gardens_point_day_night "$OUT"/gardens_point_both "$OUT"/corridor > "$OUT/table.md"
/usr/bin/python3 bench/make_table.py "$OUT"/gardens_point_viewpoint_variants \
  "$OUT"/nordland_300_variants > "$OUT/table_variants.md"
cat "$OUT/table.md"
echo "bench/results updated; copy the tables into bench/README.md when they change"
