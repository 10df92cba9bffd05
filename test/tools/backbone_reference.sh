#!/bin/bash
# The converted backbone against the original: TensorFlow.js (CPU backend, installed from npm at a
# pinned version into the build folder) runs the Keras model from the nsfwjs package on fixed
# images; backbone_reference_check runs model/mobilenet_v2.onnx through OpenCV's dnn module on the
# same images; every output layer must agree within 1e-3 relative.
#   backbone_reference.sh SOURCE_DIR WORK_DIR CHECK_PROGRAM
set -euo pipefail
source_dir="$1" work="$2" check="$3"
model="$source_dir/model/mobilenet_v2.onnx"
package="$source_dir/_backbone/nsfwjs-4.4.0/package/dist/models/mobilenet_v2"
if [[ ! -f "$model" || ! -d "$package" ]]; then
  echo "backbone_reference: $model or $package is missing: run scripts/fetch_backbone.sh"
  exit 1
fi
TFJS=4.22.0
mkdir -p "$work"
if [[ "$(cat "$work/tfjs.version" 2>/dev/null)" != "$TFJS" ]]; then
  (cd "$work" && echo '{"private": true}' > package.json &&
   npm install --silent --no-audit --no-fund "@tensorflow/tfjs-core@$TFJS" \
     "@tensorflow/tfjs-layers@$TFJS" "@tensorflow/tfjs-backend-cpu@$TFJS" > npm_install.log 2>&1) ||
    { echo "backbone_reference: cannot install TensorFlow.js $TFJS from npm:"; tail -n 5 "$work/npm_install.log"; exit 1; }
  echo "$TFJS" > "$work/tfjs.version"
fi
rm -rf "$work/reference"
# tfjs prints an advertisement for its native backend on stdout; only errors matter here.
NODE_PATH="$work/node_modules" node "$source_dir/test/tools/backbone_reference.js" "$package" \
  "$work/reference" block_5_add,block_12_add > /dev/null
"$check" "$model" "$work/reference" 1e-3
echo "backbone_reference: the ONNX backbone matches TensorFlow.js on every image and layer"
