// Reference evaluation of the backbone for test/tools/backbone_reference.sh: runs the original
// Keras model from the nsfwjs package in TensorFlow.js (CPU backend) on fixed generated images
// and writes each image and each named layer's output as raw little-endian float32, NHWC.
//   node backbone_reference.js PACKAGE_MODEL_DIR OUT_DIR layer[,layer...]
const fs = require('fs');
const path = require('path');
const tf = require('@tensorflow/tfjs-core');
require('@tensorflow/tfjs-backend-cpu');
const tfl = require('@tensorflow/tfjs-layers');

// Images the test feeds both networks: [height, width, generator(y, x, channel) in [0, 1]].
const IMAGES = [
  [144, 256, (y, x, c) => 0.5 + 0.5 * Math.sin(0.11 * x + 0.07 * y + 2.1 * c)],
  [224, 224, (y, x, c) => ((Math.floor(x / 16) + Math.floor(y / 16) + c) % 2) * 0.8 + 0.1],
  [120, 160, (y, x, c) => {
    const u = Math.sin(x * 12.9898 + y * 78.233 + c * 37.719) * 43758.5453;
    return u - Math.floor(u);  // fixed pseudo-random noise
  }],
];

async function main() {
  const [modelDir, outDir, layerList] = process.argv.slice(2);
  await tf.setBackend('cpu');
  const topology = require(path.resolve(modelDir, 'model.min.js'));
  const shard = Buffer.from(require(path.resolve(modelDir, 'group1-shard1of1.min.js')), 'base64');
  const config = topology.modelTopology.model_config.config;
  // Any input size; the classifier head (fixed-size Flatten) is cut off.
  config.layers[0].config.batch_input_shape = [null, null, null, 3];
  config.layers = config.layers.slice(0, config.layers.findIndex(l => l.name === 'out_relu') + 1);
  config.output_layers = [['out_relu', 0, 0]];
  const weightData = shard.buffer.slice(shard.byteOffset, shard.byteOffset + shard.byteLength);
  const model = await tfl.loadLayersModel(
      tf.io.fromMemory({modelTopology: topology.modelTopology,
                        weightSpecs: topology.weightsManifest[0].weights, weightData}),
      {strict: false});
  const layers = layerList.split(',');
  const cut = tfl.model({inputs: model.inputs, outputs: layers.map(n => model.getLayer(n).output)});
  fs.mkdirSync(outDir, {recursive: true});
  const manifest = [];
  IMAGES.forEach(([height, width, pixel], index) => {
    const values = new Float32Array(height * width * 3);
    for (let y = 0; y < height; ++y)
      for (let x = 0; x < width; ++x)
        for (let c = 0; c < 3; ++c) values[(y * width + x) * 3 + c] = pixel(y, x, c);
    const input = tf.tensor4d(values, [1, height, width, 3]);
    fs.writeFileSync(path.join(outDir, `image${index}.f32`), Buffer.from(values.buffer));
    const outputs = [].concat(cut.predict(input));
    const entry = {image: `image${index}.f32`, height, width, outputs: []};
    outputs.forEach((output, k) => {
      const file = `image${index}_${layers[k]}.f32`;
      fs.writeFileSync(path.join(outDir, file), Buffer.from(output.dataSync().buffer));
      entry.outputs.push({layer: layers[k], file, shape: output.shape});
    });
    manifest.push(entry);
  });
  fs.writeFileSync(path.join(outDir, 'manifest.txt'),
                   manifest.map(e => e.outputs.map(o =>
                       [e.image, e.height, e.width, o.layer, o.file, ...o.shape.slice(1)].join(' '))
                     .join('\n')).join('\n') + '\n');
}

main().catch(error => { console.error(`backbone_reference: ${error.message}`); process.exit(1); });
