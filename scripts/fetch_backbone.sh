#!/usr/bin/env bash
# Fetches the pretrained backbone and converts it to ONNX for OpenCV's dnn module:
# the ImageNet-derived MobileNetV2 inside the npm package nsfwjs (MIT licence, Infinite Red),
# at a pinned version whose tarball checksum is checked. Nothing fetched is committed.
#   scripts/fetch_backbone.sh            -> model/mobilenet_v2.onnx (kept in _backbone/ too)
# Idempotent. Without the npm registry it says so in one line and exits 0: the node then falls
# back to the package's own encoder (advanced/descriptor/type landmarks) with a warning.
set -euo pipefail
cd "$(dirname "$0")/.."

VERSION=4.4.0
SHA256=585cd178f3b994337c4d10a87b080d342fc52f8b9bf0085c4d1f345a3a1c5382
WORK=_backbone
PACKAGE_DIR=$WORK/nsfwjs-$VERSION
MODEL_DIR=$PACKAGE_DIR/package/dist/models/mobilenet_v2
OUTPUT=model/mobilenet_v2.onnx
# Layers the graph outputs (Keras names); the network is cut after the last of them.
LAYERS=block_5_add,block_12_add
STAMP="nsfwjs $VERSION sha256 $SHA256 layers $LAYERS converter $(sha256sum scripts/convert_backbone.py | cut -c1-16)"

if [ -f "$OUTPUT" ] && [ "$(cat "$OUTPUT.source" 2>/dev/null)" = "$STAMP" ]; then
  echo "fetch_backbone: $OUTPUT present (nsfwjs $VERSION)"
  exit 0
fi

mkdir -p "$WORK"
tarball=$WORK/nsfwjs-$VERSION.tgz
if [ ! -f "$tarball" ] || ! echo "$SHA256  $tarball" | sha256sum --check --status; then
  rm -f "$tarball"
  if ! (cd "$WORK" && npm pack --loglevel=error "nsfwjs@$VERSION" > /dev/null 2> npm_pack.log); then
    reason=$(grep -m 1 -o 'FetchError: .*\|npm error code .*' "$WORK/npm_pack.log" || tail -n 1 "$WORK/npm_pack.log")
    echo "fetch_backbone: cannot fetch nsfwjs@$VERSION from the npm registry ($reason); the node will warn and use the package's own encoder (advanced/descriptor/type landmarks)"
    exit 0
  fi
fi
if ! echo "$SHA256  $tarball" | sha256sum --check --status; then
  echo "fetch_backbone: $tarball does not have the pinned checksum $SHA256; refusing it" >&2
  rm -f "$tarball"
  exit 1
fi

rm -rf "$PACKAGE_DIR"
mkdir -p "$PACKAGE_DIR"
tar -xzf "$tarball" -C "$PACKAGE_DIR" package/LICENSE package/package.json \
  package/dist/models/package.json package/dist/models/mobilenet_v2
# The model files are browserify wrappers: the first exports the model JSON, the second the
# weights as base64. Node unwraps them exactly as the package's own loader does.
node -e '
  const fs = require("fs");
  const [dir, json, bin] = process.argv.slice(1);
  fs.writeFileSync(json, JSON.stringify(require(dir + "/model.min.js")));
  fs.writeFileSync(bin, Buffer.from(require(dir + "/group1-shard1of1.min.js"), "base64"));
' "$PWD/$MODEL_DIR" "$WORK/mobilenet_v2.json" "$WORK/mobilenet_v2.weights"
/usr/bin/python3 scripts/convert_backbone.py "$WORK/mobilenet_v2.json" "$WORK/mobilenet_v2.weights" \
  "$OUTPUT.tmp" --outputs "$LAYERS"
mv "$OUTPUT.tmp" "$OUTPUT"
echo "$STAMP" > "$OUTPUT.source"
echo "fetch_backbone: wrote $OUTPUT from nsfwjs $VERSION (MIT licence, $PACKAGE_DIR/package/LICENSE)"
