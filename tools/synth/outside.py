"""--kind outside of the detector's data generator (tools/synth/render.py):
one posed actor seen by static pinhole cameras at random distances, heights,
fields of view and aims (docs/DETECTOR_OUTSIDE.md); the frame
loop, relabelling (--relabel) and the projection check (--test-projection).
Runs inside Blender (bpy, through scene.py).
"""
import argparse
import json
import math
import os
import time

import numpy as np

from motion import JOINTS, load_clips, sample_pose
from output import done_indices, postprocess
from scene import Scene, render_marker

# Camera randomisation for --kind outside (docs/DETECTOR_OUTSIDE.md).
OUT_DIST = (2.5, 8.0)       # m, horizontal distance from the torso
OUT_HEIGHT = (0.8, 3.0)     # m above the floor
OUT_HFOV = (40.0, 80.0)     # degrees, horizontal field of view (aspect from the image)
OUT_AZ_JITTER = 0.45        # rad: views k of n at a0 + 2 pi k / n +- this
OUT_AIM_SIGMA = 0.22        # aim error, fraction of the half field of view (normal, clipped at 0.9)
OUT_ROLL_DEG = 3.0          # roll sigma


def outside_intrinsics(w, h, hfov):
    """Pinhole with square pixels, principal point at the image centre
    (pixel centres at integers): Blender's camera with no lens shift."""
    fx = (w / 2.0) / math.tan(hfov / 2.0)
    return {"fx": fx, "fy": fx, "cx": (w - 1) / 2.0, "cy": (h - 1) / 2.0, "w": w, "h": h}


def _rot(axis, a):
    ca, sa = math.cos(a), math.sin(a)
    Rl = np.eye(3)
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    Rl[i, i], Rl[i, j], Rl[j, i], Rl[j, j] = ca, -sa, sa, ca
    return Rl


def outside_cams(J, rng, n, w, h, dist=OUT_DIST):
    """n static pinhole cameras around the actor, `dist` m away (a range):
    list of (intrinsics, world-from-camera 4x4, OpenCV axes).  They aim at
    the torso with jitter."""
    torso = (J["pelvis"] + J["spine"] + J["neck"]) / 3.0
    a0 = rng.uniform(0, 2 * math.pi)
    out = []
    for k in range(n):
        az = a0 + 2 * math.pi * k / n + rng.uniform(-OUT_AZ_JITTER, OUT_AZ_JITTER)
        d = rng.uniform(*dist)
        ch = rng.uniform(*OUT_HEIGHT)
        hfov = math.radians(rng.uniform(*OUT_HFOV))
        K = outside_intrinsics(w, h, hfov)
        vfov = 2 * math.atan((h / 2.0) / K["fy"])
        C = np.array([torso[0] + d * math.cos(az), torso[1] + d * math.sin(az), ch])
        z = torso - C
        z /= np.linalg.norm(z)
        x = np.cross(z, [0.0, 0.0, 1.0])
        x /= np.linalg.norm(x)
        y = np.cross(z, x)
        R = np.stack([x, y, z], 1)
        yaw = float(np.clip(rng.normal(0, OUT_AIM_SIGMA), -0.9, 0.9)) * hfov / 2
        pitch = float(np.clip(rng.normal(0, OUT_AIM_SIGMA), -0.9, 0.9)) * vfov / 2
        roll = math.radians(rng.normal(0, OUT_ROLL_DEG))
        R = R @ _rot(1, yaw) @ _rot(0, pitch) @ _rot(2, roll)
        T = np.eye(4)
        T[:3, :3] = R
        T[:3, 3] = C
        out.append((K, T))
    return out


def project_pinhole(K, P):
    """P (N,3) camera frame -> u, v, z."""
    z = P[:, 2]
    zs = np.where(np.abs(z) > 1e-9, z, 1e-9)
    return K["fx"] * P[:, 0] / zs + K["cx"], K["fy"] * P[:, 1] / zs + K["cy"], z


def outside_labels(scene, views, J):
    P_w = np.array([J[k] for k in JOINTS])
    out = {}
    for name, (K, T_wc) in views:
        T_cw = np.linalg.inv(T_wc)
        P_c = (T_cw[:3, :3] @ P_w.T).T + T_cw[:3, 3]
        u, v, z = project_pinhole(K, P_c)
        st = []
        for i, k in enumerate(JOINTS):
            if z[i] < 0.05 or not (-0.5 <= u[i] <= K["w"] - 0.5 and -0.5 <= v[i] <= K["h"] - 0.5):
                st.append(2)
            elif scene.occluded(T_wc[:3, 3], P_w[i], k):
                st.append(1)
            else:
                st.append(0)
        out[name] = {"uv": [[round(float(a), 3), round(float(b), 3)] for a, b in zip(u, v)], "state": st,
                     "K": [round(K["fx"], 4), round(K["fy"], 4), K["cx"], K["cy"]],
                     "world_to_camera": [[round(float(c), 6) for c in r] for r in T_cw]}
    return out


def set_pinhole(scene, K):
    cd = scene.cam.data
    cd.sensor_fit = "HORIZONTAL"
    cd.sensor_width = 36.0
    cd.lens = 36.0 * K["fx"] / K["w"]
    cd.shift_x = cd.shift_y = 0.0


def main_outside(args):
    out = args.out
    img_dir = os.path.join(out, "images")
    os.makedirs(img_dir, exist_ok=True)
    done = done_indices(out)
    todo = [i for i in range(args.first, args.first + args.count) if i not in done]
    print("synth: %d frames to render (%d already done), seed %d, outside-in, %d views of %dx%d" % (
        len(todo), args.count - len(todo), args.seed, args.views, args.res_w, args.res_h), flush=True)
    if not todo:
        return
    clips = load_clips(args.mocap)
    scene = Scene(args, [])
    lab = open(os.path.join(out, "labels_%06d.jsonl" % args.first), "a")
    tmp = os.path.join(out, "tmp_%06d.png" % args.first)
    t0 = time.time()
    for n, i in enumerate(todo):
        rng, pose, split, views, labels, J = frame_outside(args, clips, scene, i)
        rec = {"views": labels}
        for name, (K, T_wc) in views:
            set_pinhole(scene, K)
            scene.render_view(T_wc, tmp)
            postprocess(tmp, os.path.join(img_dir, "%06d_%s.jpg" % (i, name)), rng)
        rec.update({"id": i, "seed": args.seed, "kind": "outside", "split": split, "clip": pose["clip"],
                    "frame": pose["frame"], "mirror": pose["mirror"], "height_m": round(pose["height"], 3),
                    "size": [args.res_w, args.res_h],
                    "joints_world": [[round(float(c), 5) for c in J[k]] for k in JOINTS],
                    "images": {name: "images/%06d_%s.jpg" % (i, name) for name, _ in views}})
        lab.write(json.dumps(rec) + "\n")
        lab.flush()
        if (n + 1) % 10 == 0 or n + 1 == len(todo):
            el = time.time() - t0
            fps = (n + 1) / el
            print("synth: %d/%d  %.2f frames/s (%d views each)  ETA %.0f min" % (
                n + 1, len(todo), fps, args.views, (len(todo) - n - 1) / fps / 60), flush=True)
    lab.close()


def frame_outside(args, clips, scene, i):
    """Scene, cameras and labels of frame i (no rendering); returns (rng, pose, views, labels, J)."""
    rng = np.random.default_rng([args.seed, i])
    split = "val" if rng.random() < args.val_fraction else "train"
    pose = sample_pose(clips, rng, split)
    Jp = {k: np.asarray(v, dtype=float) for k, v in pose["joints"].items()}
    cams = outside_cams(Jp, rng, args.views, args.res_w, args.res_h)
    J = scene.setup(pose, rng, cams=[T for _, T in cams])
    views = [("cam%d" % k, c) for k, c in enumerate(cams)]
    return rng, pose, split, views, outside_labels(scene, views, J), J


def relabel_outside(args):
    """Recompute `views` of every label line in OUT from (seed, id): the
    scene is rebuilt exactly as when it was rendered, the images are kept."""
    clips = load_clips(args.mocap)
    scene = Scene(args, [])
    n = 0
    for fn in sorted(os.listdir(args.out)):
        if not (fn.startswith("labels") and fn.endswith(".jsonl")):
            continue
        path = os.path.join(args.out, fn)
        recs = []
        for line in open(path):
            try:
                recs.append(json.loads(line))
            except ValueError:
                pass
        for r in recs:
            a = argparse.Namespace(**vars(args))
            a.seed = r["seed"]
            _, pose, split, views, lab, _ = frame_outside(a, clips, scene, r["id"])
            assert (pose["clip"], pose["frame"], split) == (r["clip"], r["frame"], r["split"]), r["id"]
            for name, v in lab.items():
                assert np.allclose(v["uv"], r["views"][name]["uv"], atol=2e-3), (r["id"], name)
            r["views"] = lab
            n += 1
        with open(path + ".tmp", "w") as f:
            for r in recs:
                f.write(json.dumps(r) + "\n")
        os.replace(path + ".tmp", path)
        print("synth: relabelled %s (%d frames, %d in all)" % (fn, len(recs), n), flush=True)


def test_projection_outside(args):
    """Marker spheres at known camera-frame points through the pinhole camera."""
    sc = Scene(args, [])
    for ob in list(sc.seg.values()) + [sc.room, sc.floor] + [c[0] for c in sc.clutter]:
        Scene._show(ob, False)
    sc._show(sc.sun, False)
    sc.bg.inputs[0].default_value = (0, 0, 0, 1)
    sc.sc.view_settings.view_transform = "Standard"
    K = outside_intrinsics(args.res_w, args.res_h, math.radians(55.0))
    set_pinhole(sc, K)
    T = np.eye(4)
    T[:3, :3] = _rot(0, 0.4) @ _rot(2, 0.3)
    T[:3, 3] = (1, 2, 3)
    pts = [(0.5, 0.2, 3.0), (-0.8, -0.4, 2.6), (0.3, 0.6, 2.2), (0.0, 0.0, 4.0), (-1.2, 0.8, 3.5)]
    ok = True
    for i, p in enumerate(pts):
        ob, uc, vc = render_marker(sc, T, p, i, 0.03)
        u, v, _ = project_pinhole(K, np.array([p]))
        print("point", p, "rendered (%.2f, %.2f)" % (uc, vc), "projected (%.2f, %.2f)" % (u[0], v[0]))
        ok &= abs(uc - u[0]) < 0.5 and abs(vc - v[0]) < 0.5
        Scene._show(ob, False)
    print("PROJECTION", "OK" if ok else "MISMATCH")
