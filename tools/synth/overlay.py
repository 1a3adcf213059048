"""Draws the labels of rendered frames over their images, for checking by eye:

    python3 tools/synth/overlay.py OUT_DIR sheet.png [--ids 0,1,2] [--scale 3] [--max 12]

Every view of the chosen label lines (default: the first --max) becomes one
tile: joints as dots (green visible, orange occluded; state 2 not drawn),
the skeleton as lines, and a caption with the id, split and, for v2 frames,
family, build, garment, scene kind and whether a bystander is in the frame.
No Blender here (/usr/bin/python3 with PIL)."""
import argparse
import glob
import json
import os

from PIL import Image, ImageDraw

BONES = [(0, 1), (1, 2), (2, 3), (1, 4), (4, 5), (5, 6), (3, 7), (7, 8), (8, 9), (9, 10),
         (1, 11), (11, 12), (12, 13), (3, 14), (14, 15), (15, 16), (16, 17)]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("sheet")
    ap.add_argument("--ids", default="")
    ap.add_argument("--scale", type=int, default=3)
    ap.add_argument("--max", type=int, default=12)
    ap.add_argument("--cols", type=int, default=4)
    a = ap.parse_args()
    want = {int(x) for x in a.ids.split(",") if x}
    recs = []
    for fn in sorted(glob.glob(os.path.join(a.out, "labels*.jsonl"))):
        for line in open(fn):
            try:
                r = json.loads(line)
            except ValueError:
                continue
            if not want or r["id"] in want:
                recs.append(r)
    recs = recs[:a.max]
    tiles = []
    for r in recs:
        for cam, v in r["views"].items():
            im = Image.open(os.path.join(a.out, r["images"][cam])).convert("RGB")
            s = a.scale
            im = im.resize((im.width * s, im.height * s), Image.NEAREST)
            d = ImageDraw.Draw(im)
            uv = [((x + 0.5) * s - 0.5, (y + 0.5) * s - 0.5) for x, y in v["uv"]]
            st = v["state"]
            for i, j in BONES:
                if st[i] < 2 and st[j] < 2:
                    d.line([uv[i], uv[j]], fill=(255, 255, 255), width=1)
            for k, (x, y) in enumerate(uv):
                if st[k] == 2:
                    continue
                c = (0, 255, 0) if st[k] == 0 else (255, 140, 0)
                if k in (4, 5, 6, 7, 8, 9, 10):  # left side: ring
                    d.ellipse([x - 4, y - 4, x + 4, y + 4], outline=c, width=2)
                else:
                    d.ellipse([x - 3, y - 3, x + 3, y + 3], fill=c)
            cap = "%d %s %s" % (r["id"], cam[0], r["split"])
            if r.get("data") == "v2":
                cap += " %s %s %s %s%s" % (r["family"], r["build"], r["garment"], r["scene"],
                                            " +by" if r["bystander"] else "")
            d.rectangle([0, 0, im.width, 12], fill=(0, 0, 0))
            d.text((2, 1), cap, fill=(255, 255, 0))
            tiles.append(im)
    if not tiles:
        raise SystemExit("no frames")
    w, h = tiles[0].size
    cols = min(a.cols, len(tiles))
    rows = (len(tiles) + cols - 1) // cols
    sheet = Image.new("RGB", (cols * w, rows * h))
    for n, t in enumerate(tiles):
        sheet.paste(t, ((n % cols) * w, (n // cols) * h))
    sheet.save(a.sheet)
    print("%d views -> %s" % (len(tiles), a.sheet))


if __name__ == "__main__":
    main()
