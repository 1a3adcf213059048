#!/usr/bin/python3
"""A contact sheet of a detector's keypoints against the truth on the
held-out validation, for checking by eye (docs/DETECTOR.md):

    overlay_pred.py --weights MODEL --data DIR sheet.png [--count 16] [--seed 1] [--worst]

MODEL is a checkpoint (ckpt.pt, best.pt) or an exported ONNX with its
sidecar.  Each tile is one validation view, 3x: the truth's skeleton in
green, the detections (confidence at least the threshold) in red, a
yellow line from each detection to its truth where they are more than
10 px apart at 128x128, and a caption with the view's gross-error count.
--worst picks the views with the most gross errors instead of at random."""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common as C  # noqa: E402
from overlay import BONES  # noqa: E402  (tools/synth, on the path through common)
from train import Data, batch, gross_mask, load_model, predict  # noqa: E402

SCALE = 3


def tile(img, pred, uv, st, bad):
    from PIL import Image, ImageDraw
    im = Image.fromarray(img).resize((img.shape[1] * SCALE, img.shape[0] * SCALE), Image.NEAREST)
    d = ImageDraw.Draw(im)

    def p(xy):
        return ((xy[0] + 0.5) * SCALE - 0.5, (xy[1] + 0.5) * SCALE - 0.5)

    for a, b in BONES:
        if st[a] < 2 and st[b] < 2:
            d.line([p(uv[a]), p(uv[b])], fill=(0, 220, 0), width=2)
    for j in range(len(C.JOINTS)):
        if pred[j, 2] < C.THRESHOLD:
            continue
        if bad[j] and st[j] < 2:
            d.line([p(pred[j]), p(uv[j])], fill=(255, 230, 0), width=1)
        x, y = p(pred[j])
        d.ellipse([x - 3, y - 3, x + 3, y + 3], outline=(255, 40, 40), width=2)
    d.text((4, 4), "%d gross" % int(bad.sum()), fill=(255, 255, 255))
    return im


def main():
    from PIL import Image
    ap = argparse.ArgumentParser()
    ap.add_argument("sheet")
    ap.add_argument("--weights", required=True)
    ap.add_argument("--data", required=True)
    ap.add_argument("--count", type=int, default=16)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--worst", action="store_true")
    ap.add_argument("--kind", choices=("ego",), default="ego")
    a = ap.parse_args()
    C.set_kind(a.kind)
    model, _ = load_model(a.weights)
    va = Data(a.data, "val")
    if not va.refresh():
        sys.exit("%s: no validation views" % a.data)
    idx = np.random.default_rng(a.seed).permutation(len(va))[:max(a.count * 8, a.count)]
    x, uv, st = batch(va, idx, None, False)
    pred = predict(model, x)
    uv, st = uv.numpy(), st.numpy()
    bad = gross_mask(pred, uv, st)
    pick = np.argsort(-bad.sum(1), kind="stable")[:a.count] if a.worst else np.arange(min(a.count, len(idx)))
    imgs = (x.permute(0, 2, 3, 1).numpy() * 255).astype(np.uint8)
    tiles = [tile(imgs[i], pred[i], uv[i], st[i], bad[i]) for i in pick]
    cols = 4
    w, h = tiles[0].size
    sheet = Image.new("RGB", (cols * w, ((len(tiles) + cols - 1) // cols) * h))
    for k, t in enumerate(tiles):
        sheet.paste(t, ((k % cols) * w, (k // cols) * h))
    sheet.save(a.sheet)
    print("%s: %d views, %.1f %% of their detections gross" % (
        a.sheet, len(tiles), 100 * bad[pick].sum() / max(1, (pred[pick, :, 2] >= C.THRESHOLD).sum())))


if __name__ == "__main__":
    main()
