#!/usr/bin/python3
"""Which heat-map statistic tells a gross keypoint (more than 10 px off at
128x128) from a good one, on the held-out views (docs/BENCHMARKS.md, stop
43, "A confidence that tells"):

    /usr/bin/python3 tools/train/confidence_study.py [--weights MODEL] [--data DIR] [--every 4]

For each keypoint in the image that passes the threshold: the raw peak
(today's confidence), the smoothed peak (DARK's map), the peak over the
second-highest smoothed value more than 3 cells away, and q = 4 pi x
smoothed peak / the map's mass (1 for a lone target Gaussian of sigma 1
smoothed by sigma 1).  Prints each one's AUC (good above gross) and the
gross share by q."""
import argparse
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import common as C  # noqa: E402


def auc(score, good):
    """The chance that a good item scores above a bad one (ties count half)."""
    score, good = np.asarray(score, float), np.asarray(good, bool)
    order = np.argsort(score, kind="mergesort")
    ranks = np.empty(len(score))
    s = score[order]
    i = 0
    while i < len(s):  # average ranks over ties
        j = i
        while j + 1 < len(s) and s[j + 1] == s[i]:
            j += 1
        ranks[order[i:j + 1]] = 0.5 * (i + j)
        i = j + 1
    npos, nneg = good.sum(), len(good) - good.sum()
    return (ranks[good].sum() - npos * (npos - 1) / 2) / (npos * nneg)


def statistics(hm, sigma=1.0):
    """(smoothed peak, peak over second peak, q) of one heat map."""
    h = C.blur(hm, sigma)
    y, x = divmod(int(np.argmax(h)), h.shape[1])
    yy, xx = np.mgrid[0:h.shape[0], 0:h.shape[1]]
    far = (yy - y) ** 2 + (xx - x) ** 2 > 9
    second = h[far].max() if far.any() else 0.0
    mass = np.maximum(hm, 0).sum()
    return h[y, x], h[y, x] / max(second, 1e-6), 4 * math.pi * h[y, x] / max(mass, 1e-9)


def main():
    import torch
    import train as T
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--weights", default=os.path.join(HERE, "..", "..", "config/models/ego_detector.onnx"))
    ap.add_argument("--data", default=os.path.join(HERE, "..", "..", "build/detector/v2/data"))
    ap.add_argument("--every", type=int, default=4, help="every Nth held-out view")
    a = ap.parse_args()
    torch.set_num_threads(1)
    m, _ = T.load_model(a.weights)
    va = T.Data(a.data, "val")
    if not va.refresh():
        sys.exit("%s: no held-out views" % a.data)
    x, uv, st = T.batch(va, np.arange(0, len(va), a.every), None, False)
    rows = []
    with torch.no_grad():
        for i in range(0, len(x), 64):
            for n, hm in enumerate(torch.sigmoid(m(x[i:i + 64]).float()).numpy()):
                dec = C.decode(hm, sigma=1.0)
                for j in range(hm.shape[0]):
                    if st[i + n, j] == 2 or dec[j, 2] < C.THRESHOLD:
                        continue
                    err = float(np.hypot(*(dec[j, :2] - uv[i + n, j].numpy())))
                    rows.append((err, dec[j, 2], *statistics(hm[j])))
    R = np.array(rows)
    good = R[:, 0] <= 10
    print("%d keypoints, %.1f %% gross" % (len(R), 100 * (1 - good.mean())))
    for k, name in enumerate(("raw peak", "smoothed peak", "peak / second peak", "q")):
        print("%-20s AUC %.3f" % (name, auc(R[:, 1 + k], good)))
    q = R[:, 4]
    for lo, hi in ((0, .25), (.25, .5), (.5, .75), (.75, math.inf)):
        s = (q >= lo) & (q < hi)
        if s.any():
            print("q in [%.2f, %.2f): %d keypoints, %.1f %% gross" % (lo, hi, s.sum(), 100 * (1 - good[s].mean())))


if __name__ == "__main__":
    main()
