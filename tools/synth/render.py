"""Synthetic frames for the 2D joint detector: head-mounted stereo fisheye
views (--kind ego, the default) or outside-in pinhole views (--kind outside).

    blender -b --factory-startup --python tools/synth/render.py -- \
        --out build/detector/data --seed 1 --first 0 --count 8000
    blender -b --factory-startup --python tools/synth/render.py -- --kind outside \
        --out build/detector/outside --seed 11 --first 0 --count 1000

With --split train|val (ego only), frame i is a v2 frame: the split's
motion families, builds, garments and scene kinds only, and a bystander in
some frames (docs/DETECTOR.md, "v2 data"; tools/synth/job.py runs the long
job).

With --kind outside, frame i is one posed actor seen by --views static
pinhole cameras (default 4) at random distances, heights, fields of view
and aims; labels go one line per frame with one entry per view.

Frame i is fully determined by (--seed, i): every frame draws its own actor,
pose, clothes, scene, lights, rig jitter and sensor effects from
numpy.random.default_rng([seed, i]).  Frames whose two JPEGs and label line
exist are skipped, so rerunning the same command resumes.  Labels go to
OUT/labels_FIRST.jsonl (one line per stereo pair, written after both images).
See docs/DETECTOR.md.

This file holds the command line and the ego frames; the Blender scene is in
scene.py, the outside-in frames in outside.py, the output folder's files in
output.py (all imported from this folder).
"""
import argparse
import json
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from motion import JOINTS, clips_of_split, family_of, load_clips, sample_pose  # noqa: E402
from fisheye import load_rig, project_cam  # noqa: E402
from output import done_indices, open_labels, postprocess  # noqa: E402
from outside import main_outside, relabel_outside, test_projection_outside  # noqa: E402
from scene import Scene, render_marker  # noqa: E402
from scene_v2 import BUILDS, BYSTANDER_P, GARMENTS, SCENE_KINDS  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=os.path.join(ROOT, "build/detector/data"))
    ap.add_argument("--rig", default=os.path.join(ROOT, "config/rigs/ego_stereo.json"))
    ap.add_argument("--mocap", default="/work/shared/data/mocap-train")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--first", type=int, default=0)
    ap.add_argument("--count", type=int, default=100)
    ap.add_argument("--kind", choices=("ego", "outside"), default="ego",
                    help="ego: the head-mounted stereo fisheye rig; outside: static pinhole cameras around the actor")
    ap.add_argument("--res", type=int, default=128, help="ego: image size (square)")
    ap.add_argument("--width", type=int, default=192, help="outside: image width")
    ap.add_argument("--height", type=int, default=144, help="outside: image height")
    ap.add_argument("--views", type=int, default=4, help="outside: cameras per posed actor")
    ap.add_argument("--relabel", action="store_true",
                    help="outside: recompute the labels of the frames already in OUT (same scenes, no rendering)")
    ap.add_argument("--data-version", type=int, choices=(2, 3), default=2,
                    help="with --split: 2 as the v2 job was rendered; 3 adds feet and shoulders of more "
                         "shapes and colours")
    ap.add_argument("--samples", type=int, default=8)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--val-fraction", type=float, default=0.1)
    ap.add_argument("--split", choices=("train", "val"), default=None,
                    help="ego, v2 data: render this split only, with the held-out factors (motion families, "
                         "builds, garments, scene kinds) of docs/DETECTOR.md 'v2 data', and a bystander in "
                         "some frames; without it the v1 data (split by motion segment)")
    ap.add_argument("--test-projection", action="store_true",
                    help="render marker spheres and check them against r = f*theta")
    a = ap.parse_args(argv)
    if a.split and a.kind != "ego":
        ap.error("--split (the v2 data) is for --kind ego only")
    if a.kind == "ego":
        a.res_w = a.res_h = a.res
    else:
        a.res_w, a.res_h = a.width, a.height
    return a


# ---------------------------------------------------------------- rig / camera
project = project_cam


def rig_pose(head, neck, rng):
    """World-from-left-camera (OpenCV axes) from the head frame, with mounting jitter."""
    F, U, L = head[:, 0], head[:, 1], head[:, 2]
    fwd = 0.30 + rng.uniform(-0.04, 0.04)
    upo = 0.10 + rng.uniform(-0.04, 0.04)
    side = rng.uniform(-0.02, 0.02)
    tilt = math.radians(14.0 + rng.uniform(-6.0, 6.0))
    mid = neck + fwd * F + upo * U + side * L
    c, s = math.cos(tilt), math.sin(tilt)
    y = -c * F + s * U
    z = -c * U - s * F
    x = np.cross(y, z)
    R = np.stack([x, y, z], 1)
    # small yaw/roll/pitch of the whole rig
    for axis, deg in ((0, 4.0), (1, 4.0), (2, 4.0)):
        a = math.radians(rng.uniform(-deg, deg))
        ca, sa = math.cos(a), math.sin(a)
        Rl = np.eye(3)
        i, j = [(1, 2), (2, 0), (0, 1)][axis]
        Rl[i, i], Rl[i, j], Rl[j, i], Rl[j, j] = ca, -sa, sa, ca
        R = R @ Rl
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = mid - 0.15 * R[:, 0]  # left camera: 0.15 m towards the wearer's left (-x)
    return T


def labels_for(scene, cams, T_wl, J, pose):
    T_lw = np.linalg.inv(T_wl)
    P_w = np.array([J[k] for k in JOINTS])
    P_l = (T_lw[:3, :3] @ P_w.T).T + T_lw[:3, 3]
    views = {}
    for cam in cams:
        T_wc = T_wl @ cam["rig_from_cam"]
        T_cw = np.linalg.inv(T_wc)
        P_c = (T_cw[:3, :3] @ P_w.T).T + T_cw[:3, 3]
        u, v, th = project(cam, P_c)
        res = scene.args.res
        st = []
        for i, k in enumerate(JOINTS):
            if th[i] > cam["fov"] / 2 or not (-0.5 <= u[i] <= res - 0.5 and -0.5 <= v[i] <= res - 0.5):
                st.append(2)
            elif scene.occluded(T_wc[:3, 3], P_w[i], k):
                st.append(1)
            else:
                st.append(0)
        views[cam["name"]] = {"uv": [[round(float(a), 3), round(float(b), 3)] for a, b in zip(u, v)],
                              "state": st}
    return {"joints_left_cam": [[round(float(c), 5) for c in p] for p in P_l], "views": views}, views


def test_projection(args, cams):
    """Bright marker spheres at known camera-frame points; compare rendered
    centroids with the r = f*theta projection."""
    sc = Scene(args, cams)
    for ob in list(sc.seg.values()) + [sc.room, sc.floor] + [c[0] for c in sc.clutter]:
        Scene._show(ob, False)
    sc._show(sc.sun, False)
    sc.bg.inputs[0].default_value = (0, 0, 0, 1)
    sc.sc.view_settings.view_transform = "Standard"
    T = np.eye(4)
    T[:3, :3] = np.array([[1, 0, 0], [0, 0, 1], [0, -1, 0]], dtype=float)  # arbitrary
    T[:3, 3] = (1, 2, 3)
    pts = [(0.5, 0.2, 1.0), (-0.8, -0.4, 0.6), (0.3, 0.9, 0.2), (0.0, 0.0, 1.0)]
    ok = True
    for i, p in enumerate(pts):
        ob, uc, vc = render_marker(sc, T, p, i, 0.02)
        u, v, th = project(cams[0], np.array([p]))
        print("point", p, "rendered (%.2f, %.2f)" % (uc, vc), "projected (%.2f, %.2f)" % (u[0], v[0]))
        ok &= abs(uc - u[0]) < 1.0 and abs(vc - v[0]) < 1.0
        Scene._show(ob, False)
    print("PROJECTION", "OK" if ok else "MISMATCH")


def draw_v2(clips, rng, split):
    """Wearer's pose, look (build, garment, scene kind) and the bystander's
    pose (None in 1 - BYSTANDER_P of the frames) of a v2 frame; clips are
    the split's only, so is every factor."""
    pose = sample_pose(clips, rng, "all")
    look = {"split": split, "build": str(rng.choice(BUILDS[split])), "garment": str(rng.choice(GARMENTS[split])),
            "scene": str(rng.choice(SCENE_KINDS[split]))}
    bypose = None
    if rng.random() < BYSTANDER_P:
        others = [c for c in clips if c.name != pose["clip"]]
        bypose = sample_pose(others, rng, "all")
    return pose, look, bypose


def main():
    args = parse_args()
    if args.kind == "outside":
        if args.test_projection:
            test_projection_outside(args)
        elif args.relabel:
            relabel_outside(args)
        else:
            main_outside(args)
        return
    cams = load_rig(args.rig, args.res)
    if args.test_projection:
        test_projection(args, cams)
        return
    out = args.out
    img_dir = os.path.join(out, "images")
    os.makedirs(img_dir, exist_ok=True)
    done = done_indices(out)
    todo = [i for i in range(args.first, args.first + args.count) if i not in done]
    print("synth: %d frames to render (%d already done), seed %d" % (len(todo), args.count - len(todo), args.seed),
          flush=True)
    if not todo:
        return
    clips = load_clips(args.mocap)
    scene = Scene(args, cams)
    if args.split:
        clips = clips_of_split(clips, args.split)
        scene.init_v2()
    lab = open_labels(os.path.join(out, "labels_%06d.jsonl" % args.first))
    tmp = os.path.join(out, "tmp_%06d.png" % args.first)
    t0 = time.time()
    for n, i in enumerate(todo):
        rng = np.random.default_rng([args.seed, i])
        if args.split:
            split = args.split
            pose, look, bypose = draw_v2(clips, rng, split)
            look["version"] = args.data_version
            J = scene.setup_v2(pose, rng, look, bypose)
        else:
            split = "val" if rng.random() < args.val_fraction else "train"
            pose = sample_pose(clips, rng, split)
            J = scene.setup(pose, rng)
            look = None
        T_wl = rig_pose(pose["head"], J["neck"], rng)
        rec, views = labels_for(scene, cams, T_wl, J, pose)
        for cam in cams:
            T_wc = T_wl @ cam["rig_from_cam"]
            scene.render_view(T_wc, tmp)
            postprocess(tmp, os.path.join(img_dir, "%06d_%s.jpg" % (i, cam["name"])), rng)
        rec.update({"id": i, "seed": args.seed, "split": split, "clip": pose["clip"], "frame": pose["frame"],
                    "mirror": pose["mirror"], "height_m": round(pose["height"], 3),
                    "images": {c["name"]: "images/%06d_%s.jpg" % (i, c["name"]) for c in cams}})
        if look is not None:
            rec.update({"data": "v%d" % args.data_version, "family": family_of(pose["clip"]), "build": look["build"],
                        "garment": look["garment"], "longpants": look["longpants"], "scene": look["scene"],
                        "bystander": bypose is not None})
            if bypose is not None:
                rec.update({"bystander_clip": look["bystander_clip"], "bystander_m": look["bystander_m"]})
        lab.write(json.dumps(rec) + "\n")
        lab.flush()
        if (n + 1) % 10 == 0 or n + 1 == len(todo):
            el = time.time() - t0
            fps = (n + 1) / el
            print("synth: %d/%d  %.2f pairs/s  ETA %.0f min" % (n + 1, len(todo), fps, (len(todo) - n - 1) / fps / 60),
                  flush=True)
    lab.close()


if __name__ == "__main__":
    main()