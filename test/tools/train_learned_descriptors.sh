#!/bin/bash
# The learned descriptors end to end from a bag: lcd_train fits the CNN whitening and trains the
# broad autoencoder on a generated corridor bag; lcd_evaluate then uses both files on that bag and
# refuses a damaged model with a message naming it.
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
echo "learned descriptors: trained, evaluated, damaged model refused"
