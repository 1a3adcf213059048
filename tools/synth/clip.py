"""Evaluation clips of our own: a head-mounted stereo sequence in the layout
of ../shared/data/ego/<clip>/ (left/%05d.jpg, right/%05d.jpg, calib.json,
gt.json) or, with --kind outside, four static cameras in that of
../shared/data/outside/<clip>/ (camK/%05d.jpg, cameras.json, gt.json),
rendered from a motion of ../shared/data/mocap-train.

    blender -b --factory-startup --python tools/synth/clip.py -- \\
        --out build/clips/ego_s02_sword --motion cmu_iclone/02_07 --frames 240 --seed 1 \\
        [--first 0] [--bystander cmu_iclone/02_10] [--split val]

The two dev clips are one motion family, actor and scene each; the project
is judged on others (issue 35, 36).  These clips are held out the way the
v2 data's validation is (docs/DETECTOR.md, "v2 data"): with --split val
(the default) the motion must be of a validation family (CMU subjects 02,
60, 61) and the actor's build, garment and scene kind are the validation's
(heavy, sleeveless, a furnished room with lamps), none of which the shipped
head-rig detector was trained on.  The actor's look and the scene are drawn
once from --seed, so every frame shows the same person in the same room;
the wearer's path is kept inside the room and away from its furniture, and
a bystander (--bystander MOTION) does their own motion 1-3 m from that
path.  `make eval-clips` renders the set that docs/BENCHMARKS.md reports.

Resumable: frames whose two JPEGs exist are skipped.  gt.json is written
last, so a folder with one is a whole clip (`make bench-heldout` takes
those).  Progress and an ETA go to stdout every 10 frames.
"""
import argparse
import json
import math
import os
import sys
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bvh import JOINTS  # noqa: E402
from motion import VAL_FAMILIES, clip_sequence, family_of, load_clips  # noqa: E402

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
FPS = 30.0  # mocap-train is at 30 fps, and so are the dev clips
OUTSIDE_DIST = (4.0, 6.0)  # m from the path's centre, as the dev clips' cameras


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", required=True, help="the clip's folder")
    ap.add_argument("--motion", required=True, help="a mocap-train clip, e.g. cmu_iclone/02_07")
    ap.add_argument("--first", type=int, default=0, help="its first frame (30 fps)")
    ap.add_argument("--frames", type=int, default=240)
    ap.add_argument("--seed", type=int, default=1, help="draws the actor, clothes, scene and rig mounting")
    ap.add_argument("--height", type=float, default=None, help="the actor's stature, m (default: drawn, 1.5-2.0)")
    ap.add_argument("--mirror", action="store_true", help="the motion mirrored (left and right swapped)")
    ap.add_argument("--bystander", default=None, help="a mocap-train clip for a bystander (default: none)")
    ap.add_argument("--bystander-first", type=int, default=0)
    ap.add_argument("--split", choices=("train", "val"), default="val",
                    help="the builds, garments and scene kinds to draw from (val: held out from training)")
    ap.add_argument("--data-version", type=int, choices=(2, 3), default=3)
    ap.add_argument("--kind", choices=("ego", "outside"), default="ego")
    ap.add_argument("--rig", default=os.path.join(ROOT, "config/rigs/ego_stereo.json"), help="ego: the rig")
    ap.add_argument("--mocap", default=os.path.join(ROOT, "../shared/data/mocap-train"))
    ap.add_argument("--res", type=int, default=256, help="ego: image size (square), as the dev clips")
    ap.add_argument("--samples", type=int, default=8)
    ap.add_argument("--threads", type=int, default=1)
    a = ap.parse_args(argv)
    # outside-in: 320x240, as the dev clips
    a.res_w, a.res_h = (a.res, a.res) if a.kind == "ego" else (320, 240)
    return a


def find_clip(clips, name, split, what):
    by_name = {c.name: c for c in clips}
    if name not in by_name:
        sys.exit("clip.py: %s '%s' is not a clip of the mocap folder (it has: %s)"
                 % (what, name, ", ".join(sorted(by_name))))
    c = by_name[name]
    if split == "val" and family_of(name) not in VAL_FAMILIES:
        sys.exit("clip.py: %s '%s' is of family %s, which the detectors trained on; --split val takes %s"
                 % (what, name, family_of(name), ", ".join(VAL_FAMILIES)))
    return c


def ping_pong(k, n):
    """Frame k of a motion of n frames played forward, back, forward..."""
    m = k % (2 * n - 2)
    return m if m < n else 2 * n - 2 - m


def ego_cams(rig, res):
    """The head rig's cameras at res x res, as calib_json takes them."""
    from fisheye import load_rig
    return [dict(c, res=res, rig_path=rig) for c in load_rig(rig, res)]


def ego_views(a, seq):
    """The head rig: its cameras, the left camera's world pose per frame
    (fixed to the head, the mounting drawn once from --seed), each frame's
    views (name, world-from-camera, None) and the lens file."""
    from render import rig_pose
    cams = ego_cams(a.rig, a.res)
    rigs = [rig_pose(s["head"], s["joints"]["neck"], np.random.default_rng([a.seed, 2])) for s in seq]
    views = [[(cam["name"], rigs[k] @ cam["rig_from_cam"], None) for cam in cams] for k in range(a.frames)]
    return cams, rigs, views, ("calib.json", calib_json(cams))


def outside_views(a, env):
    """Outside-in: four static pinhole cameras around the path's centre
    (drawn once from --seed), the same views (name, world-from-camera,
    intrinsics) every frame, and the lens file; env's room grows to hold
    the cameras."""
    from outside import outside_cams
    c3 = np.array([env["centre"][0], env["centre"][1], 1.0])
    fixed = outside_cams({"pelvis": c3, "spine": c3, "neck": c3}, np.random.default_rng([a.seed, 2]), 4,
                         a.res_w, a.res_h, dist=OUTSIDE_DIST)
    views = [("cam%d" % i, T, K) for i, (K, T) in enumerate(fixed)]
    far = max(float(np.linalg.norm(T[:2, 3] - c3[:2])) for _, T, _ in views)
    env["room_half"] = (far + 0.3, far + 0.3)
    return [], None, [views] * a.frames, ("cameras.json", cameras_json(views))


def path_env(seq):
    """The wearer's path (pelvis, on the floor) for scene_v2.setup_v2's env."""
    p = np.array([s["joints"]["pelvis"][:2] for s in seq])
    lo, hi = p.min(0), p.max(0)
    return {"centre": tuple(0.5 * (lo + hi)), "half": tuple(0.5 * (hi - lo) + 0.35),
            "facing": seq[0]["head"][:, 0]}


def calib_json(cams):
    """calib.json as the dev clips have it (mc_rig_import_ego_calib reads
    it): the equidistant lens, right_from_left and the lens again as an
    OCamCalib polynomial, fitted here to r = f theta."""
    L, R = cams
    right_from_left = np.linalg.inv(R["rig_from_cam"]) @ L["rig_from_cam"]
    f = L["f"]
    rho = np.linspace(0, f * math.pi / 2 * 0.999, 400)
    theta = rho / f
    w = np.where(rho > 0, rho / np.tan(np.maximum(theta, 1e-9)), f)
    A = np.stack([np.ones_like(rho), rho ** 2, rho ** 3, rho ** 4], 1)
    coef = np.linalg.lstsq(A, w, rcond=None)[0]
    err = np.abs(np.arctan2(rho, A @ coef) - theta).max() * f
    return {"model": "equidistant-fisheye",
            "note": "made by tools/synth/clip.py from %s: r_pixels = f * theta, OpenCV camera axes, metres"
                    % os.path.basename(L["rig_path"]),
            "width": L["res"], "height": L["res"], "f": f, "cx": L["cx"], "cy": L["cy"],
            "fov_deg": math.degrees(L["fov"]), "right_from_left": right_from_left.tolist(),
            "baseline_m": float(np.linalg.norm(right_from_left[:3, 3])),
            "ocam_poly": {"form": "w(rho) = a0 + a2*rho^2 + a3*rho^3 + a4*rho^4; ray = (u-cx, v-cy, w)",
                          "a0": coef[0], "a2": coef[1], "a3": coef[2], "a4": coef[3], "max_abs_err_px": err}}


def gt_json(a, seq, rigs, look):
    """gt.json: joints in the left camera (ego, rigs: its world pose per
    frame) or in the world (outside-in, rigs None)."""
    frames = []
    for k, s in enumerate(seq):
        f = {"index": k, "time": round(k / FPS, 6)}
        if rigs is None:
            f["joints_world"] = {n: [round(float(c), 5) for c in s["joints"][n]] for n in JOINTS}
        else:
            T_lw = np.linalg.inv(rigs[k])
            f["joints_left_cam"] = {n: [round(float(c), 5) for c in T_lw[:3, :3] @ s["joints"][n] + T_lw[:3, 3]]
                                    for n in JOINTS}
            f["left_cam_to_world"] = rigs[k].tolist()
        frames.append(f)
    return {"source": a.motion, "first": a.first, "fps": FPS, "height_m": round(seq[0]["height"], 3),
            "mirror": a.mirror, "seed": a.seed, "look": look, "bystander": a.bystander,
            "made_by": "tools/synth/clip.py", "joint_names": JOINTS, "frames": frames}


def cameras_json(views):
    """cameras.json as the outside-in dev clips have it."""
    cams = []
    for name, T_wc, K in views:
        cams.append({"name": name, "model": "pinhole", "width": K["w"], "height": K["h"], "fx": K["fx"],
                     "fy": K["fy"], "cx": K["cx"], "cy": K["cy"], "dist": [0.0] * 5,
                     "world_to_camera": np.linalg.inv(T_wc).tolist()})
    return {"note": "made by tools/synth/clip.py: static pinhole cameras, OpenCV axes, metres; world z up, "
                    "the floor at z = 0", "cameras": cams}


# What makes the frames: a folder is resumed only with the same values.
CLIP_KEYS = ("kind", "motion", "first", "frames", "seed", "mirror", "bystander", "bystander_first", "split",
             "data_version", "res", "samples", "rig")


FINISH = "median 3x3, noise 0.01, JPEG 92"  # finish_jpeg's, kept in clip.json


def check_same_clip(a, H):
    """Writes OUT/clip.json, or refuses (exit 1) to resume a folder that
    another command line started: its frames would mix two clips."""
    want = {k: getattr(a, k) for k in CLIP_KEYS}
    want["height"] = round(H, 4)
    want["finish"] = FINISH
    path = os.path.join(a.out, "clip.json")
    if os.path.exists(path):
        have = json.load(open(path))
        diff = ["%s %r, not %r" % (k, have.get(k), v) for k, v in want.items() if have.get(k) != v]
        if diff:
            sys.exit("clip.py: %s was started with %s; remove the folder or use another --out"
                     % (path, "; ".join(diff)))
    else:
        write_json(path, want)


def write_json(path, obj):
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(obj, f, indent=1)
    os.replace(tmp, path)


def main():
    a = parse_args()
    # Blender's modules only now: --help and the argument checks work without it
    from scene_v2 import BUILDS, GARMENTS, SCENE_KINDS  # noqa: F401 (also adds Scene.setup_v2)

    clips = load_clips(a.mocap)
    c = find_clip(clips, a.motion, a.split, "--motion")
    look_rng = np.random.default_rng([a.seed, 0])
    H = a.height if a.height else float(look_rng.uniform(1.5, 2.0))
    look = {"split": a.split, "build": str(look_rng.choice(BUILDS[a.split])),
            "garment": str(look_rng.choice(GARMENTS[a.split])), "scene": str(look_rng.choice(SCENE_KINDS[a.split])),
            "version": a.data_version}
    seq = clip_sequence(c, a.first, a.frames, H, a.mirror)
    byseq = None
    if a.bystander:
        b = find_clip(clips, a.bystander, a.split, "--bystander")
        n = min(max(a.frames, 2), len(b.frames) - a.bystander_first)
        if n < 2:
            sys.exit("clip.py: --bystander %s has fewer than 2 frames from %d" % (a.bystander, a.bystander_first))
        bs = clip_sequence(b, a.bystander_first, n, float(look_rng.uniform(1.5, 2.0)))
        # a short motion plays forward and back (no jump at its end)
        byseq = [bs[ping_pong(k, n)] for k in range(a.frames)]
    env = path_env(seq)
    if a.kind == "ego":
        cams, rigs, views, lens = ego_views(a, seq)
    else:
        cams, rigs, views, lens = outside_views(a, env)
    for name, _, _ in views[0]:
        os.makedirs(os.path.join(a.out, name), exist_ok=True)
    check_same_clip(a, H)
    write_json(os.path.join(a.out, lens[0]), lens[1])
    jpg = [[os.path.join(a.out, name, "%05d.jpg" % k) for name, _, _ in views[0]] for k in range(a.frames)]
    todo = [k for k in range(a.frames) if not all(os.path.exists(p) for p in jpg[k])]
    print("clip: %s, %d frames to render (%d done): %s from frame %d, %.2f m, %s, %s, %s%s" % (
        a.out, len(todo), a.frames - len(todo), a.motion, a.first, H, look["build"], look["garment"],
        look["scene"], ", bystander " + a.bystander if a.bystander else ""), flush=True)
    if todo:
        render(a, cams, todo, seq, byseq, env, views, look, jpg)
    write_json(os.path.join(a.out, "gt.json"), gt_json(a, seq, rigs, look))


def finish_jpeg(png, jpg, rng):
    """A camera's frame: the render with mild sensor noise, as a JPEG.  Not
    the detector data's postprocess, whose gain, gamma and blur are drawn
    anew for every view: in a sequence that is a camera whose exposure
    jumps from frame to frame, which no real one does.  A 3x3 median takes
    out most of the path tracer's noise at 8 samples (Debian's Blender has
    no denoiser; 24 samples look the same at three times the time)."""
    from PIL import Image, ImageFilter
    im = Image.open(png).convert("RGB").filter(ImageFilter.MedianFilter(3))
    im = np.asarray(im).astype(np.float32) / 255.0
    im = im + rng.normal(0, 0.01, im.shape)
    Image.fromarray((np.clip(im, 0, 1) * 255 + 0.5).astype(np.uint8)).save(jpg, quality=92)


def render(a, cams, todo, seq, byseq, env, views, look, jpg):
    from outside import set_pinhole
    from scene import Scene
    scene = Scene(a, cams)
    scene.init_v2()

    tmp = os.path.join(a.out, "tmp.png")
    t0 = time.time()
    for n, k in enumerate(todo):
        # the same draws every frame: the same actor, clothes and room
        scene.setup_v2(seq[k], np.random.default_rng([a.seed, 1]), dict(look), byseq[k] if byseq else None, env)
        for ci, (_, T_wc, K) in enumerate(views[k]):
            if K is not None:
                set_pinhole(scene, K)
            scene.render_view(T_wc, tmp)
            part = jpg[k][ci][:-4] + ".part.jpg"  # a killed render leaves no whole-looking JPEG
            finish_jpeg(tmp, part, np.random.default_rng([a.seed, 3, k, ci]))
            os.replace(part, jpg[k][ci])
        if (n + 1) % 10 == 0 or n + 1 == len(todo):
            rate = (n + 1) / (time.time() - t0)
            print("clip: %d/%d  %.2f frames/s  ETA %.1f min" % (n + 1, len(todo), rate,
                                                             (len(todo) - n - 1) / rate / 60), flush=True)
    if os.path.exists(tmp):
        os.remove(tmp)


if __name__ == "__main__":
    main()
