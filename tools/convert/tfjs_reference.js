// TensorFlow.js's own output of a graph model on given images, for checking
// a conversion (tools/convert/check_conversion.py runs this).
//
//   node tfjs_reference.js MODEL.json IMAGES.f32 N H W OUT.f32 TF_NODE...
//
// IMAGES.f32: N images, float32 NHWC, pixel values 0..255 (the graph's
// int32 input, rounded).  OUT.f32: for each image, each TF_NODE's tensor in
// NCHW order (as it is when the name ends in "!raw"), float32, concatenated.  Needs @tensorflow/tfjs (npm), at
// conversion time only: NODE_PATH must reach it.
'use strict';
const fs = require('fs');
const path = require('path');
const tf = require('@tensorflow/tfjs');

function loadHandler(modelPath) {
	const json = JSON.parse(fs.readFileSync(modelPath, 'utf8'));
	const dir = path.dirname(modelPath);
	const specs = [];
	const buffers = [];
	for (const group of json.weightsManifest) {
		specs.push(...group.weights);
		for (const p of group.paths) buffers.push(fs.readFileSync(path.join(dir, p)));
	}
	const all = Buffer.concat(buffers);
	const weightData = all.buffer.slice(all.byteOffset, all.byteOffset + all.byteLength);
	return tf.io.fromMemory({modelTopology: json.modelTopology, weightSpecs: specs, weightData});
}

async function main() {
	const [modelPath, imagesPath, n, h, w, outPath, ...nodes] = process.argv.slice(2);
	if (!nodes.length) {
		console.error('usage: tfjs_reference.js MODEL.json IMAGES.f32 N H W OUT.f32 TF_NODE...');
		process.exit(2);
	}
	await tf.setBackend('cpu');
	const model = await tf.loadGraphModel(loadHandler(modelPath));
	const raw = fs.readFileSync(imagesPath);
	const pixels = new Float32Array(raw.buffer, raw.byteOffset, raw.byteLength / 4);
	const size = Number(h) * Number(w) * 3;
	const out = fs.openSync(outPath, 'w');
	for (let i = 0; i < Number(n); i++) {
		const img = tf.tensor4d(pixels.slice(i * size, (i + 1) * size), [1, Number(h), Number(w), 3], 'float32');
		const input = tf.cast(img, 'int32');
		const names = nodes.map((n) => n.replace(/!raw$/, ''));
		const results = model.execute(input, names);
		const list = Array.isArray(results) ? results : [results];
		for (let k = 0; k < list.length; k++) {
			const t = list[k];
			const nchw = nodes[k].endsWith('!raw') ? t.clone() : t.transpose([0, 3, 1, 2]);
			fs.writeSync(out, Buffer.from((await nchw.data()).buffer));
			nchw.dispose();
			t.dispose();
		}
		img.dispose();
		input.dispose();
	}
	fs.closeSync(out);
}

main().catch((e) => {
	console.error(`tfjs_reference: ${e.message}`);
	process.exit(1);
});
