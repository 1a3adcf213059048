"""The data generator's output (tools/synth/render.py): which frames a folder
already holds, so that a rerun resumes, and the sensor effects with which a
rendered PNG becomes the JPEG that training reads.  No Blender here.
"""
import json
import os

import numpy as np


def done_indices(out):
    done = set()
    for fn in os.listdir(out):
        if fn.startswith("labels") and fn.endswith(".jsonl"):
            for line in open(os.path.join(out, fn)):
                try:
                    done.add(json.loads(line)["id"])
                except (ValueError, KeyError):
                    pass
    return done


def open_labels(path):
    """The label file, opened for appending; a partial last line (a renderer
    killed while writing it) is ended first, so that the next record starts
    on a line of its own (the partial one is skipped by every reader)."""
    if os.path.exists(path) and os.path.getsize(path) > 0:
        with open(path, "rb") as f:
            f.seek(-1, os.SEEK_END)
            partial = f.read(1) != b"\n"
        if partial:
            with open(path, "a") as f:
                f.write("\n")
    return open(path, "a")


def postprocess(png, jpg, rng):
    from PIL import Image, ImageFilter
    im = Image.open(png).convert("RGB")
    if rng.random() < 0.6:
        im = im.filter(ImageFilter.GaussianBlur(rng.uniform(0.2, 0.9)))
    a = np.asarray(im).astype(np.float32) / 255.0
    a = a * rng.uniform(0.75, 1.25) * (1 + rng.uniform(-0.06, 0.06, 3))
    a = np.clip(a, 0, 1) ** rng.uniform(0.85, 1.15)
    a = a + rng.normal(0, rng.uniform(0.0, 0.035), a.shape)
    img = Image.fromarray((np.clip(a, 0, 1) * 255 + 0.5).astype(np.uint8))
    img.save(jpg, quality=int(rng.integers(55, 96)))
