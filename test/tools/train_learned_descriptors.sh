#!/bin/bash
# The learned descriptors end to end from a bag: lcd_train fits the CNN whitening, trains the
# broad autoencoder and (with the backbone fetched) learns a VLAD vocabulary on a generated corridor
# bag; lcd_evaluate then uses the files on that bag and refuses a damaged model with a message
# naming it; lcd_train never replaces an existing vocabulary file.
set -euo pipefail
make_bag="$1" train="$2" evaluate="$3"
folder="$(mktemp -d)"
trap 'rm -rf "$folder"' EXIT
"$make_bag" "$folder/corridor.bag" 1.3 > /dev/null
"$train" whitening --bag "$folder/corridor.bag" --components 32 --output "$folder/cnn.whitening"
"$train" broad --bag "$folder/corridor.bag" --enhancement 400 --output "$folder/corridor.broad"
report="$("$evaluate" --bag "$folder/corridor.bag" --descriptors cnn_pca,broad \
  --cnn-whitening "$folder/cnn.whitening" --broad-model "$folder/corridor.broad" \
  --truth-topic /ground_truth --gt-distance 2.5 --gt-gap 20 --output "$folder/results")"
echo "$report"
for name in cnn_pca broad; do
  auc="$(sed -n "s/^$name *R@100P [0-9.]*  AUC \([0-9.]*\).*/\1/p" <<<"$report")"
  [[ -n "$auc" ]] || { echo "no result line for $name"; exit 1; }
  # Far better than chance (a random ranking's AUC is about the share of revisits).
  awk -v auc="$auc" 'BEGIN { exit !(auc > 0.6) }' || { echo "$name AUC $auc <= 0.6"; exit 1; }
done
head -c 1000 "$folder/corridor.broad" > "$folder/damaged.broad"
if "$evaluate" --bag "$folder/corridor.bag" --descriptors broad --broad-model "$folder/damaged.broad" \
    --output "$folder/results" 2> "$folder/error.txt"; then
  echo "a damaged model was accepted"; exit 1
fi
grep -q "damaged.broad" "$folder/error.txt" || { cat "$folder/error.txt"; exit 1; }

package="$(cd "$(dirname "$0")/../.." && pwd)"
if [ ! -f "$package/model/mobilenet_v2.onnx" ]; then
  echo "learned descriptors: trained, evaluated, damaged model refused; VLAD not run: the backbone was not fetched (scripts/fetch_backbone.sh)"
  exit 77  # ctest: Not Run (SKIP_RETURN_CODE), not a pass
fi
"$train" vocabulary --bag "$folder/corridor.bag" --clusters 8 --output "$folder/corridor.vocabulary"
cp "$folder/corridor.vocabulary" "$folder/before.vocabulary"
if "$train" vocabulary --bag "$folder/corridor.bag" --clusters 4 \
    --output "$folder/corridor.vocabulary" 2> "$folder/error.txt"; then
  echo "an existing vocabulary was replaced"; exit 1
fi
cmp "$folder/corridor.vocabulary" "$folder/before.vocabulary"
grep -q "not replaced" "$folder/error.txt" || { cat "$folder/error.txt"; exit 1; }
report="$("$evaluate" --bag "$folder/corridor.bag" --descriptors backbone \
  --vocabulary "$folder/corridor.vocabulary" \
  --truth-topic /ground_truth --gt-distance 2.5 --gt-gap 20 --output "$folder/results")"
echo "$report"
grep -q "VLAD over 8 centres" <<<"$report" || { echo "the vocabulary was not used"; exit 1; }
auc="$(sed -n "s/^backbone *R@100P [0-9.]*  AUC \([0-9.]*\).*/\1/p" <<<"$report")"
awk -v auc="$auc" 'BEGIN { exit !(auc > 0.6) }' || { echo "VLAD AUC '$auc' <= 0.6"; exit 1; }
head -c 100 "$folder/corridor.vocabulary" > "$folder/damaged.vocabulary"
if "$evaluate" --bag "$folder/corridor.bag" --descriptors backbone \
    --vocabulary "$folder/damaged.vocabulary" --output "$folder/results" 2> "$folder/error.txt"; then
  echo "a damaged vocabulary was accepted"; exit 1
fi
grep -q "damaged.vocabulary" "$folder/error.txt" || { cat "$folder/error.txt"; exit 1; }
echo "learned descriptors: trained, evaluated, damaged model and vocabulary refused"

