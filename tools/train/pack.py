#!/usr/bin/python3
"""Pack a rendered data folder (tools/synth) for moving it to a training
machine: every view re-encoded as WebP, the label lines copied with their
image paths changed, split into parts of at most --part-mb MB each.

    /usr/bin/python3 tools/train/pack.py --data build/detector/v2/data --out build/detector/pack

Each part is a folder (part00, part01, ...) holding images/ and one
labels_partNN.jsonl; copying the parts' contents into one folder gives a
data folder that train.py --data reads as it is (the label lines lose
only the 3D joints, which it does not read).  WebP at quality 70 is
about 40 % of the size of the renderer's JPEGs (1.9 against 4.4 kB per
128x128 view); its own smoothing is small beside the trainer's noise and
blur augmentation.  A pair goes into a part whole, with its label line
after its images; pairs with a partial label line (a renderer still
running) are skipped.
"""
import argparse
import glob
import io
import json
import os

from PIL import Image


def pairs(data):
    """Every complete label record of the folder, in file order."""
    for fn in sorted(glob.glob(os.path.join(data, "labels*.jsonl"))):
        with open(fn) as f:
            for line in f:
                try:
                    yield json.loads(line)
                except ValueError:
                    continue


def encode(path, quality):
    buf = io.BytesIO()
    Image.open(path).convert("RGB").save(buf, "WEBP", quality=quality, method=6)
    return buf.getvalue()


class Part:
    def __init__(self, out, k):
        self.name = "part%02d" % k
        self.dir = os.path.join(out, self.name)
        os.makedirs(os.path.join(self.dir, "images"), exist_ok=True)
        self.labels = open(os.path.join(self.dir, "labels_%s.jsonl" % self.name), "w")
        self.bytes = self.n = 0

    def add(self, rec, images):
        for rel, blob in images.items():
            os.makedirs(os.path.dirname(os.path.join(self.dir, rel)), exist_ok=True)
            with open(os.path.join(self.dir, rel), "wb") as f:
                f.write(blob)
            self.bytes += len(blob)
        line = json.dumps(rec, separators=(",", ":")) + "\n"
        self.labels.write(line)
        self.bytes += len(line)
        self.n += 1

    def close(self):
        self.labels.close()


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--data", required=True, help="a data folder of tools/synth (labels*.jsonl, images/)")
    ap.add_argument("--out", required=True, help="folder for part00, part01, ...")
    ap.add_argument("--part-mb", type=float, default=36.0, help="largest part, in MB")
    ap.add_argument("--quality", type=int, default=70, help="WebP quality")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    limit = a.part_mb * 1e6
    parts = [Part(a.out, 0)]
    for rec in pairs(a.data):
        rec.pop("joints_left_cam", None)  # 3D truth: a third of the line, not read by train.py
        images = {}
        for cam, rel in rec["images"].items():
            new = os.path.splitext(rel)[0] + ".webp"
            images[new] = encode(os.path.join(a.data, rel), a.quality)
            rec["images"][cam] = new
        if parts[-1].n and parts[-1].bytes + sum(map(len, images.values())) > limit:
            parts[-1].close()
            parts.append(Part(a.out, len(parts)))
        parts[-1].add(rec, images)
    parts[-1].close()
    for p in parts:
        print("%s: %d pairs, %.1f MB" % (p.dir, p.n, p.bytes / 1e6))


if __name__ == "__main__":
    main()
