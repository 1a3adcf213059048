#!/usr/bin/python3
"""TensorFlow.js's own MoveNet keypoints for images, in their native pixels.

The whole graph (its own decoding included) runs on each image letterboxed
the way the runtime's first pass does it (detect/mc_detector_movenet.cpp),
and its [y, x, score] output is mapped back to native pixels.  The result
is the fixture detect/tests/test_detector_movenet.c compares the C runtime
with (mc_detector_set_refine off):

    movenet_reference.py MODEL.json IMAGE... > reference.json

Needs Node and @tensorflow/tfjs (NODE_PATH), at conversion time only.
"""
import json
import os
import subprocess
import sys
import tempfile

import cv2
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from check_conversion import letterbox, letterbox_place  # noqa: E402


def main():
    if len(sys.argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    model, images = sys.argv[1], sys.argv[2:]
    sig = json.load(open(model))["signature"]["inputs"]
    size = int(next(iter(sig.values()))["tensorShape"]["dim"][1]["size"])
    batch = np.stack([letterbox(p, size, size) for p in images])
    with tempfile.TemporaryDirectory() as tmp:
        batch.tofile(os.path.join(tmp, "in.f32"))
        subprocess.run(["node", os.path.join(HERE, "tfjs_reference.js"), model, os.path.join(tmp, "in.f32"),
                        str(len(images)), str(size), str(size), os.path.join(tmp, "out.f32"), "Identity!raw"],
                       check=True)
        out = np.fromfile(os.path.join(tmp, "out.f32"), np.float32).reshape(len(images), 17, 3)
    result = []
    for path, kp in zip(images, out):
        h, w = cv2.imread(path).shape[:2]
        x0, y0, nw, nh = letterbox_place(w, h, size)
        sx, sy = nw / w, nh / h
        joints = [[float((x * size - x0) / sx - 0.5), float((y * size - y0) / sy - 0.5), float(s)]
                  for y, x, s in kp]
        result.append({"image": os.path.basename(os.path.dirname(path)) + "/" + os.path.basename(path),
                       "joints": joints})
    json.dump({"model": os.path.basename(model), "keypoints": result}, sys.stdout, indent=1)
    print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
