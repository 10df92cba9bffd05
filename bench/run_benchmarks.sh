#!/usr/bin/env bash
# Regenerates everything in bench/: every dataset of ../shared/data that has images, the
# generated corridor, the scaling benchmark, the results table (bench/results.md) and the plots.
# Takes about 35 minutes on 2 cores. Needs ../shared/data; plots need python3-matplotlib
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
DESCRIPTORS=backbone,pixels,hog,hog_whole,calc,landmarks,landmarks_conv,cnn_pca,cnn_pca_raw,broad

run() {  # name, then lcd_evaluate arguments. cnn_pca and broad train on the evaluated images
  # unless --train-images is given (results.json names the source of each).
  local name=$1; shift
  echo "== $name"
  "$EVALUATE" --descriptors "$DESCRIPTORS" --output "$OUT/$name" --train-on-eval "$@" 2> >(grep -v "^lcd_evaluate: \(describing\|matching\)" >&2)
}

GP=$DATA/gardens_point
run_all() {  # every dataset with images; $1 = folder suffix; Nordland limited by $NORDLAND_LIMIT
  local suffix=$1 limit=()
  [ -n "${NORDLAND_LIMIT:-}" ] && limit=(--limit "$NORDLAND_LIMIT")
  run "nordland$suffix" --name "Nordland winter vs summer${NORDLAND_LIMIT:+, first $NORDLAND_LIMIT} (+-2)" \
    "${limit[@]}" --database "$DATA/nordland/summer" --queries "$DATA/nordland/winter" --gt-aligned 2
  run "gardens_point_viewpoint$suffix" --name "Gardens Point day right vs day left (+-3)" \
    --database "$GP/day_left" --queries "$GP/day_right" --gt-aligned 3
  run "gardens_point_day_night$suffix" --name "Gardens Point night right vs day right (+-3)" \
    --database "$GP/day_right" --queries "$GP/night_right" --gt-aligned 3
  run "gardens_point_both$suffix" --name "Gardens Point night right vs day left (+-3)" \
    --database "$GP/day_left" --queries "$GP/night_right" --gt-aligned 3
  run "corridor$suffix" --name "Generated corridor, 2 laps (sequence)" --corridor 2 --exclude-recent 60
}
run_all ""

# The broad autoencoder at its default size (2 000 enhancement nodes) and the paper's (10 000),
# trained on Nordland summer (3 576 images, another dataset) instead of the 100 database images.
DESCRIPTORS=broad,broad_e10000 run gardens_point_viewpoint_broad_sizes \
  --name "Gardens Point day right vs day left (+-3), trained on Nordland summer" \
  --train-images "$DATA/nordland/summer" --database "$GP/day_left" --queries "$GP/day_right" \
  --gt-aligned 3

# One network pass per landmark (~50 passes, ~0.5 s per image): Nordland's first 300 frames only,
# all 3576 with FULL=1 (about 30 more minutes).
DESCRIPTORS=landmarks_per_landmark NORDLAND_LIMIT=300 run_all _per_landmark
if [ "${FULL:-0}" = 1 ]; then
  DESCRIPTORS=landmarks_per_landmark run nordland_per_landmark_full \
    --name "Nordland winter vs summer (+-2)" \
    --database "$DATA/nordland/summer" --queries "$DATA/nordland/winter" --gt-aligned 2
fi

# Landmark choices, each against the default (HOG of 32x32 patches cut from 320x240, float16,
# boxes up to half the image, penalising shape weight).
DESCRIPTORS=landmarks,landmarks_paper,landmarks_conv3_grid4,landmarks_w160,landmarks_patch16,landmarks_area100,landmarks_f32
run gardens_point_viewpoint_variants --name "Gardens Point day right vs day left (+-3)" \
  --database "$GP/day_left" --queries "$GP/day_right" --gt-aligned 3
run gardens_point_day_night_variants --name "Gardens Point night right vs day right (+-3)" \
  --database "$GP/day_right" --queries "$GP/night_right" --gt-aligned 3

# Backbone choices, each against the default (block_12_add, 3x4 grid of cell-normalised cells,
# 256x144 input, HOG weight 0.1 and alone below 160 px, 30 landmarks that do not re-rank).
DESCRIPTORS=backbone,backbone_whole,backbone_centred,backbone_g2x3,backbone_g4x6,backbone_i224x224,backbone_i320x180,backbone_h0,backbone_h35,backbone_b5,backbone_r30,backbone_r100,backbone_p5_r30,backbone_hoglm_r30
backbone_variants() {
  run gardens_point_viewpoint_backbone --name "Gardens Point day right vs day left (+-3)" \
    --database "$GP/day_left" --queries "$GP/day_right" --gt-aligned 3
  run gardens_point_day_night_backbone --name "Gardens Point night right vs day right (+-3)" \
    --database "$GP/day_right" --queries "$GP/night_right" --gt-aligned 3
  run gardens_point_both_backbone --name "Gardens Point night right vs day left (+-3)" \
    --database "$GP/day_left" --queries "$GP/night_right" --gt-aligned 3
  run corridor_backbone --name "Generated corridor, 2 laps (sequence)" --corridor 2 --exclude-recent 60
}
backbone_variants
# PCA whitening of the backbone's global vector (methods.md section 2's step), fitted on the traversal that
# is neither database nor queries (100 images, so at most 99 dimensions).
DESCRIPTORS=backbone,backbone_pca32,backbone_pca64,backbone_pca99
run gardens_point_viewpoint_backbone_pca --name "Gardens Point day right vs day left (+-3)" \
  --train-images "$GP/night_right" --database "$GP/day_left" --queries "$GP/day_right" --gt-aligned 3
run gardens_point_day_night_backbone_pca --name "Gardens Point night right vs day right (+-3)" \
  --train-images "$GP/day_left" --database "$GP/day_right" --queries "$GP/night_right" --gt-aligned 3
run gardens_point_both_backbone_pca --name "Gardens Point night right vs day left (+-3)" \
  --train-images "$GP/day_right" --database "$GP/day_left" --queries "$GP/night_right" --gt-aligned 3
# On Nordland's 64x32 images: the network alone (n0), fused at several weights, HOG alone (default).
DESCRIPTORS=backbone,backbone_n0_h0,backbone_n0,backbone_n0_h50,backbone_n0_h85 run nordland_backbone \
  --name "Nordland winter vs summer (+-2)" --database "$DATA/nordland/summer" \
  --queries "$DATA/nordland/winter" --gt-aligned 2

echo "== pipeline"
_build/devel/lib/landmark_loop_closure/lcd_bench_pipeline --database "$GP/day_left" \
  --queries "$GP/day_right" --keyframes 10000 > "$OUT/pipeline.md"
_build/devel/lib/landmark_loop_closure/lcd_bench_pipeline --database "$GP/day_left" \
  --queries "$GP/day_right" --keyframes 10000 --descriptor landmarks > "$OUT/pipeline_landmarks.md"
_build/devel/lib/landmark_loop_closure/lcd_bench_pipeline --database "$GP/day_left" \
  --queries "$GP/day_right" --keyframes 10000 --descriptor landmarks_conv > "$OUT/pipeline_conv.md"
cat "$OUT/pipeline.md"

echo "== scaling"
_build/devel/lib/landmark_loop_closure/lcd_bench_scaling 1000,10000,100000 200 > "$OUT/scaling.md"
cat "$OUT/scaling.md"

echo "== map at scale"
_build/devel/lib/landmark_loop_closure/lcd_bench_map --keyframes 100000 --checkpoints 10000,100000 \
  --dir "${TMPDIR:-/tmp}/lcd_bench_map" --image "$GP/day_left/Image000.jpg" > "$OUT/map.md"
cat "$OUT/map.md"

/usr/bin/python3 scripts/plot_results.py "$OUT"/*/
/usr/bin/python3 bench/make_table.py "$OUT"/nordland "$OUT"/gardens_point_viewpoint \
  "$OUT"/gardens_point_day_night "$OUT"/gardens_point_both "$OUT"/corridor > "$OUT/table.md"
/usr/bin/python3 bench/make_table.py "$OUT"/nordland_per_landmark "$OUT"/gardens_point_viewpoint_per_landmark \
  "$OUT"/gardens_point_day_night_per_landmark "$OUT"/gardens_point_both_per_landmark \
  "$OUT"/corridor_per_landmark > "$OUT/table_per_landmark.md"
FULL_NORDLAND=()
[ -d "$OUT/nordland_per_landmark_full" ] && FULL_NORDLAND=("$OUT/nordland_per_landmark_full")
/usr/bin/python3 bench/make_table.py --matrix "$OUT"/nordland "${FULL_NORDLAND[@]}" "$OUT"/nordland_per_landmark \
  "$OUT"/gardens_point_viewpoint "$OUT"/gardens_point_viewpoint_per_landmark \
  "$OUT"/gardens_point_day_night "$OUT"/gardens_point_day_night_per_landmark \
  "$OUT"/gardens_point_both "$OUT"/gardens_point_both_per_landmark \
  "$OUT"/corridor "$OUT"/corridor_per_landmark > "$OUT/table_recall.md"
/usr/bin/python3 bench/make_table.py "$OUT"/gardens_point_viewpoint_variants \
  "$OUT"/gardens_point_day_night_variants > "$OUT/table_variants.md"
/usr/bin/python3 bench/make_table.py --matrix "$OUT"/gardens_point_viewpoint_backbone \
  "$OUT"/gardens_point_day_night_backbone "$OUT"/gardens_point_both_backbone \
  "$OUT"/corridor_backbone "$OUT"/nordland_backbone > "$OUT/table_backbone.md"
echo "== the whole detector (bench/history.md \"Precision first\"): both halves, two rules"
detector() {  # name, frames per half (0: one run), then lcd_evaluate arguments
  local halves=("--limit $2" "--skip $2")
  [ "$2" = 0 ] && halves=("")
  for rule in defaults single_image; do
    local config=()
    [ "$rule" = single_image ] && config=(--config config/single_image.yaml)
    for half in 0 1; do
      [ -z "${halves[$half]+set}" ] && continue
      # shellcheck disable=SC2086  # The half's two words.
      "$EVALUATE" --detector "${config[@]}" ${halves[$half]} --sweep-steps 24 \
        --output "$OUT/detector_$1_${rule}_$half" "${@:3}" \
        2> /dev/null | grep -v "^  sweep" | tee "$OUT/detector_$1_${rule}_$half.txt"
    done
  done
}
CAMERA=(--camera-info bench/cameras/gardens_point.yaml --still-threshold 0)
detector gardens_point_day_night 50 --database "$GP/day_right" --queries "$GP/night_right" \
  --as-sequence --gt-aligned 3 "${CAMERA[@]}"
detector gardens_point_both 50 --database "$GP/day_left" --queries "$GP/night_right" \
  --as-sequence --gt-aligned 3 "${CAMERA[@]}"
detector gardens_point_viewpoint 50 --database "$GP/day_left" --queries "$GP/day_right" \
  --as-sequence --gt-aligned 3 "${CAMERA[@]}"
detector nordland 1788 --database "$DATA/nordland/summer" --queries "$DATA/nordland/winter" \
  --as-sequence --gt-aligned 2 --gt-stops 5 --still-threshold 0
detector corridor 0 --corridor 2
echo "== geometric check and odometry gate (generated corridor)"
VERIFY=_build/devel/lib/landmark_loop_closure/lcd_bench_verification
{ "$VERIFY" --config config/demo.yaml; echo; "$VERIFY" --config config/demo.yaml --min-score 0.15; } \
  > "$OUT/verification.md"
cat "$OUT/table.md"
echo "bench/results updated; copy the tables into bench/README.md when they change"
