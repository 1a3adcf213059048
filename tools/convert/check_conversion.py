#!/usr/bin/python3
"""Check a converted network against TensorFlow.js's own output.

Runs the TensorFlow.js graph model (tools/convert/tfjs_reference.js, in Node
with @tensorflow/tfjs) and the converted ONNX file (through OpenCV's DNN
module, as mocapd runs it) on the same images, and prints, per output, the
largest absolute difference and the largest difference relative to the
output's own range.  Exits 1 when any exceeds --tolerance (default 1e-4).

    check_conversion.py MODEL.json MODEL.onnx --output NAME=TF_NODE ... IMAGE...

Images are resized (letterboxed, the runtime's way) to the network's input
and rounded to whole pixel values, which is what both networks see.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile

import cv2
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def letterbox_place(img_w, img_h, size):
    """Where a letterboxed image lies in a size x size input: the runtime's
    rule (detect/mc_detector_movenet.cpp, fill_square), pixel for pixel:
    (x0, y0, width, height) in input pixels."""
    side = max(img_w, img_h)
    s = size / side
    sx0, sy0 = (img_w - side) / 2.0, (img_h - side) / 2.0
    def lround(v):
        return int(math.floor(v + 0.5))
    ix0, iy0 = max(0, lround(-sx0 * s)), max(0, lround(-sy0 * s))
    ix1, iy1 = min(size, lround((img_w - sx0) * s)), min(size, lround((img_h - sy0) * s))
    return ix0, iy0, ix1 - ix0, iy1 - iy0


def letterbox(path, h, w):
    img = cv2.imread(path, cv2.IMREAD_COLOR)
    if img is None:
        raise ValueError(f"{path}: cannot read the image")
    if h != w:
        raise ValueError(f"letterboxing is for square inputs, not {h}x{w}")
    img = cv2.cvtColor(img, cv2.COLOR_BGR2RGB)
    x0, y0, nw, nh = letterbox_place(img.shape[1], img.shape[0], w)
    out = np.zeros((h, w, 3), np.uint8)
    out[y0:y0 + nh, x0:x0 + nw] = cv2.resize(img, (nw, nh), interpolation=cv2.INTER_AREA)
    return out.astype(np.float32)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("model")
    ap.add_argument("onnx")
    ap.add_argument("images", nargs="+")
    ap.add_argument("--output", action="append", required=True, metavar="NAME=TF_NODE")
    ap.add_argument("--tolerance", type=float, default=1e-4)
    ap.add_argument("--node-path", default=os.environ.get("NODE_PATH", ""),
                    help="where @tensorflow/tfjs is installed (a node_modules folder)")
    args = ap.parse_args()
    outputs = [o.split("=", 1) for o in args.output]
    sig = json.load(open(args.model))["signature"]["inputs"]
    dims = [int(d["size"]) for d in next(iter(sig.values()))["tensorShape"]["dim"]]
    h, w = dims[1], dims[2]
    images = np.stack([letterbox(p, h, w) for p in args.images])

    net = cv2.dnn.readNetFromONNX(args.onnx)
    with tempfile.TemporaryDirectory() as tmp:
        images.astype(np.float32).tofile(os.path.join(tmp, "in.f32"))
        env = dict(os.environ, NODE_PATH=args.node_path)
        subprocess.run(["node", os.path.join(HERE, "tfjs_reference.js"), args.model, os.path.join(tmp, "in.f32"),
                        str(len(images)), str(h), str(w), os.path.join(tmp, "out.f32")] + [t for _, t in outputs],
                       check=True, env=env)
        ref = np.fromfile(os.path.join(tmp, "out.f32"), np.float32)

    worst = 0.0
    offset = 0
    for i, img in enumerate(images):
        net.setInput(img.transpose(2, 0, 1)[None] / 255.0, "image")
        got = net.forward([name for name, _ in outputs])
        for (name, _), g in zip(outputs, got):
            r = ref[offset:offset + g.size].reshape(g.shape)
            offset += g.size
            diff = float(np.abs(g - r).max())
            rel = diff / max(float(np.abs(r).max()), 1e-12)
            worst = max(worst, min(diff, rel))
            print(f"{os.path.basename(args.images[i])} {name} {tuple(g.shape)}: max |diff| {diff:.2e}, "
                  f"relative to range {rel:.2e}")
    if offset != ref.size:
        print(f"check_conversion: TensorFlow.js gave {ref.size} values, expected {offset}", file=sys.stderr)
        return 1
    ok = worst <= args.tolerance
    print(f"{'PASS' if ok else 'FAIL'}: worst {worst:.2e} (tolerance {args.tolerance:g})")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
