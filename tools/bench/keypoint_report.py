#!/usr/bin/python3
"""The 2D report of a detector's keypoints against a clip's ground truth,
with the figures issue 36 asks every model card for.

    keypoint_report.py --clip DIR --keypoints FILE [--label NAME]

FILE is `mocap-bench --keypoints-out` (one JSON line per frame set, native
pixels); DIR a clip of ../shared/data/ego or ../shared/data/outside (gt.json
and calib.json or cameras.json).  All distances are at a 128-pixel-wide
scale (native pixels x 128 / image width), so that rigs compare.  Printed:

- median: of the keypoints of joints in the image;
- gross: the share of keypoints more than 10 px from the truth, or reported
  while the joint is outside the image;
- collapse: of left/right pairs whose truths are more than 20 px apart in a
  view, the share whose two keypoints lie within 2 px of each other (one
  limb reported under both labels);
- swap: of the other such pairs with both keypoints, the share closer to
  the truth with the labels exchanged.

The last line is machine-readable:
  KP2D clip=NAME median_px=X gross_pct=Y collapse_pct=Z swap_pct=W keypoints=N pairs=M
"""
import argparse
import json
import math
import os
import sys

import numpy as np

PAIRS = ["shoulder", "elbow", "wrist", "hip", "knee", "ankle", "toe"]


def ego_cameras(calib):
    """Projections of the head-mounted rig: points in the left camera frame."""
    f, cx, cy, w, h = calib["f"], calib["cx"], calib["cy"], calib["width"], calib["height"]
    right_from_left = np.array(calib["right_from_left"])

    def equidistant(p):
        r = math.hypot(p[0], p[1])
        theta = math.atan2(r, p[2])
        if theta > math.pi / 2:
            return None
        s = f * theta / r if r > 1e-12 else 0.0
        return cx + s * p[0], cy + s * p[1]

    def right(p):
        return equidistant(right_from_left[:3, :3] @ p + right_from_left[:3, 3])

    return {"left": (equidistant, w, h), "right": (right, w, h)}, "joints_left_cam"


def outside_cameras(cameras):
    import cv2
    out = {}
    for c in cameras["cameras"]:
        K = np.array([[c["fx"], 0, c["cx"]], [0, c["fy"], c["cy"]], [0, 0, 1]])
        T = np.array(c["world_to_camera"])
        rvec, tvec, dist = cv2.Rodrigues(T[:3, :3])[0], T[:3, 3], np.array(c["dist"], float)

        def project(p, K=K, T=T, rvec=rvec, tvec=tvec, dist=dist):
            if (T[:3, :3] @ p + T[:3, 3])[2] <= 0.05:
                return None
            uv, _ = cv2.projectPoints(np.array(p, float).reshape(1, 3), rvec, tvec, K, dist)
            return tuple(uv.reshape(2))

        out[c["name"]] = (project, c["width"], c["height"])
    return out, "joints_world"


def load_clip(clip):
    gt = json.load(open(os.path.join(clip, "gt.json")))
    if os.path.exists(os.path.join(clip, "calib.json")):
        cams, key = ego_cameras(json.load(open(os.path.join(clip, "calib.json"))))
    else:
        cams, key = outside_cameras(json.load(open(os.path.join(clip, "cameras.json"))))
    return gt, cams, key


def truth_2d(gt, cams, key, index, camera, joint):
    if index >= len(gt["frames"]) or joint not in gt["frames"][index][key]:
        return None
    p = np.array(gt["frames"][index][key][joint], float)
    project, w, h = cams[camera]
    uv = project(p)
    if uv is None:
        return "out"
    inside = -0.5 <= uv[0] < w - 0.5 and -0.5 <= uv[1] < h - 0.5
    return (uv[0] * 128.0 / w, uv[1] * 128.0 / w) if inside else "out"


def dist(a, b):
    return math.hypot(a[0] - b[0], a[1] - b[1])


def report(clip, keypoints, label):
    gt, cams, key = load_clip(clip)
    errors, gross, n = [], 0, 0
    pairs = collapsed = swapped = compared = 0
    for line in open(keypoints):
        frame = json.loads(line)
        k = frame["index"]
        for view in frame["views"]:
            cam = view["camera"]
            w = cams[cam][1]
            kp = {j: (v[0] * 128.0 / w, v[1] * 128.0 / w) for j, v in view["joints"].items()}
            truths = {}
            for j, uv in kp.items():
                t = truth_2d(gt, cams, key, k, cam, j)
                if t is None:
                    continue
                truths[j] = t
                n += 1
                if t == "out":
                    gross += 1
                    continue
                e = dist(uv, t)
                errors.append(e)
                gross += e > 10
            for part in PAIRS:
                a, b = "left_" + part, "right_" + part
                ta, tb = truth_2d(gt, cams, key, k, cam, a), truth_2d(gt, cams, key, k, cam, b)
                if a not in kp or b not in kp or not isinstance(ta, tuple) or not isinstance(tb, tuple):
                    continue
                if dist(ta, tb) <= 20:
                    continue
                pairs += 1
                if dist(kp[a], kp[b]) <= 2:
                    collapsed += 1
                    continue
                compared += 1
                swapped += dist(kp[a], tb) + dist(kp[b], ta) < dist(kp[a], ta) + dist(kp[b], tb)
    med = float(np.median(errors)) if errors else float("nan")
    pct = lambda a, b: 100.0 * a / b if b else float("nan")  # noqa: E731
    name = label or os.path.basename(os.path.normpath(clip))
    print(f"{name}: {n} keypoints, median {med:.2f} px at 128 wide, {pct(gross, n):.1f} % gross (>10 px or outside), "
          f"{pairs} left/right pairs apart in the truth: {pct(collapsed, pairs):.1f} % collapsed, "
          f"{pct(swapped, compared):.1f} % of the rest swapped")
    print(f"KP2D clip={name} median_px={med:.2f} gross_pct={pct(gross, n):.1f} collapse_pct={pct(collapsed, pairs):.1f} "
          f"swap_pct={pct(swapped, compared):.1f} keypoints={n} pairs={pairs}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--clip", required=True)
    ap.add_argument("--keypoints", required=True, help="mocap-bench --keypoints-out FILE")
    ap.add_argument("--label")
    args = ap.parse_args()
    try:
        report(args.clip, args.keypoints, args.label)
    except (OSError, KeyError, ValueError) as e:
        print(f"keypoint_report: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
