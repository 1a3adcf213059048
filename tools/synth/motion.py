"""Training motions: BVH clips -> metric, Z-up world poses with a head frame.

No Blender here (render.py imports it; /usr/bin/python3 can run it to check
the clips: `python3 tools/synth/motion.py /work/shared/data/mocap-train`).
"""
import glob
import os
import sys
import zlib

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from bvh import Bvh, FAMILIES, JOINTS, fk  # noqa: E402

SEG_LEN = 150          # frames (5 s at 30 fps) per train/validation segment
VAL_EVERY = 8          # one segment in 8 is held out for validation
NECK_ABOVE_ANKLE = 0.89  # (Head joint - ankle) height as a fraction of stature
HEAD_TOP = 0.067       # head_top above the Head joint, fraction of stature
LEFT_RIGHT = [(a, "right_" + a[5:]) for a in JOINTS if a.startswith("left_")]


def _group(name):
    n = name.lower()
    if any(k in n for k in ("upleg", "thigh", "leg", "shin", "calf", "foot", "toe")):
        return "leg"
    if any(k in n for k in ("arm", "shldr", "hand", "elbow", "wrist")):
        return "arm"
    return "torso"


def _rot_to(a, b):
    """Rotation taking unit vector a to unit vector b."""
    v = np.cross(a, b)
    c = float(np.dot(a, b))
    if np.linalg.norm(v) < 1e-9:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    K = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + K + K @ K * (1.0 / (1.0 + c))


def _frame(U, Lraw):
    U = U / np.linalg.norm(U, axis=-1, keepdims=True)
    L = Lraw - np.sum(Lraw * U, -1, keepdims=True) * U
    L = L / np.linalg.norm(L, axis=-1, keepdims=True)
    F = np.cross(L, U)
    return np.stack([F, U, L], -1)  # columns F, U, L


class Clip:
    def __init__(self, path):
        self.path = path
        self.family = os.path.basename(os.path.dirname(path))
        self.name = self.family + "/" + os.path.basename(path)[:-4]
        self.b = b = Bvh(path)
        m = FAMILIES[self.family]
        self.jidx = {k: b.index[v] for k, v in m.items()}
        self.need = set(self.jidx.values())
        self.group = [_group(n) for n in b.names]
        first = 1 if self.family in ("cmu_mb", "cmu_daz") else 0  # frame 0: T-pose
        self.frames = np.arange(first, b.nframes)
        pos, rot = fk(b, self.frames, need=self.need)
        J = self.jidx
        ank = 0.5 * (pos[:, J["left_ankle"]] + pos[:, J["right_ankle"]])
        d = pos[:, J["neck"]] - ank
        up = np.median(d / np.linalg.norm(d, axis=1, keepdims=True), axis=0)
        up /= np.linalg.norm(up)
        self.R_up = _rot_to(up, np.array([0.0, 0.0, 1.0]))
        h = d @ up
        self.neck_height_units = float(np.percentile(h, 90))
        # head frame = R_head(t) @ A, A fitted so that on average it matches
        # the torso frame (up spine->neck, left = right shoulder -> left shoulder)
        B = _frame(pos[:, J["neck"]] - pos[:, J["spine"]],
                   pos[:, J["left_shoulder"]] - pos[:, J["right_shoulder"]])
        Rh = rot[:, J["neck"]]
        M = np.einsum("nji,njk->ik", Rh, B)
        u, _, vt = np.linalg.svd(M)
        self.A = u @ vt
        seg = (self.frames - first) // SEG_LEN
        key = zlib.crc32(self.name.encode())
        self.is_val = ((seg + key) % VAL_EVERY) == 0
        if len(np.unique(seg)) == 1:
            self.is_val[:] = (key % VAL_EVERY) == 0

    def split_frames(self, split):
        if split == "all":
            return self.frames
        return self.frames[self.is_val] if split == "val" else self.frames[~self.is_val]


# The held-out split of the v2 data (render.py --split, docs/DETECTOR.md,
# "v2 data"): motion families are CMU subjects (the clip name's prefix, e.g.
# cmu_iclone/02_07 -> s02).  Validation: subject 02 (walk, run, jump, bend
# over and scoop, swordplay, wash: cmu_mb/02_01 and cmu_iclone/02_*) and
# subjects 60 and 61 (salsa); every other subject is training.
VAL_FAMILIES = ("s02", "s60", "s61")


def family_of(name):
    """Motion family of a clip name (e.g. 'cmu_daz/94_06' -> 's94')."""
    return "s%02d" % int(name.split("/")[-1].split("_")[0])


def clips_of_split(clips, split):
    """The clips of one v2 split (train: every family but VAL_FAMILIES)."""
    return [c for c in clips if (family_of(c.name) in VAL_FAMILIES) == (split == "val")]


def load_clips(root):
    paths = sorted(glob.glob(os.path.join(root, "*", "*.bvh")))
    return [Clip(p) for p in paths]


def _rand_rot(rng, sigma_deg):
    ax = rng.normal(size=3)
    ax /= np.linalg.norm(ax)
    a = np.radians(rng.normal(0.0, sigma_deg))
    K = np.array([[0, -ax[2], ax[1]], [ax[2], 0, -ax[0]], [-ax[1], ax[0], 0]])
    return np.eye(3) + np.sin(a) * K + (1 - np.cos(a)) * K @ K


def sample_pose(clips, rng, split):
    """Random actor and pose. Returns a dict with metric Z-up world joints,
    head frame (columns F, U, L), stature, clip name, frame, mirror flag."""
    w = np.array([len(c.split_frames(split)) for c in clips], dtype=float) ** 0.7
    ci = rng.choice(len(clips), p=w / w.sum())
    c = clips[ci]
    fr = c.split_frames(split)
    frame = int(fr[rng.integers(len(fr))])
    H = rng.uniform(1.5, 2.0)
    gs = {"leg": rng.uniform(0.9, 1.1), "arm": rng.uniform(0.9, 1.1), "torso": rng.uniform(0.92, 1.08)}
    oscale = np.array([gs[g] for g in c.group])
    pert = {}
    for name, j in c.jidx.items():
        if name.endswith("@end"):
            continue
        if rng.random() < 0.6:
            big = name.endswith(("shoulder", "elbow", "hip", "knee")) and rng.random() < 0.3
            pert[j] = _rand_rot(rng, 20.0 if big else 7.0)
    # this frame plus 30 of the clip (same proportions) to place the floor
    ref = np.linspace(c.frames[0], c.frames[-1], 30).astype(int)
    allf = np.concatenate([[frame], ref])
    pos, rot = fk(c.b, allf, offset_scale=oscale, perturb=pert, need=c.need)
    s = NECK_ABOVE_ANKLE * H / c.neck_height_units
    pos = np.einsum("ij,nkj->nki", c.R_up, pos) * s
    J = c.jidx
    feet = pos[:, [J["left_toe"], J["right_toe"], J["left_ankle"], J["right_ankle"]], 2]
    floor = float(np.percentile(feet.min(axis=1)[1:], 5)) - 0.02 * H
    floor = min(floor, float(feet[0].min()) - 0.015 * H)
    p0 = pos[0]
    centre = p0[J["pelvis"]].copy()
    centre[2] = floor
    joints = {k: p0[j] - centre for k, j in J.items()}
    Hf = c.R_up @ rot[0, J["neck"]] @ c.A
    joints["head_top"] = joints["neck"] + HEAD_TOP * H * Hf[:, 1]
    mirror = bool(rng.random() < 0.5)
    if mirror:
        M = np.diag([-1.0, 1.0, 1.0])
        j2 = {k: M @ v for k, v in joints.items()}
        for a, b in LEFT_RIGHT:
            j2[a], j2[b] = j2[b], j2[a]
        joints = j2
        Hf = np.stack([M @ Hf[:, 0], M @ Hf[:, 1], -(M @ Hf[:, 2])], 1)
    return {"joints": joints, "head": Hf, "height": H, "clip": c.name, "frame": frame,
            "mirror": mirror, "split": split}


def clip_sequence(c, first, n, H, mirror=False):
    """Frames first .. first + n - 1 of clip c (indices into c.frames) as one
    motion in one world, for an actor H m tall: pose dicts like
    sample_pose's (metric, Z up, the floor at z = 0, the origin on the floor
    under the first frame's pelvis), with no proportions changed and no
    joint perturbed (a perturbation held for a whole clip is a stiff joint,
    not a style).  For the evaluation clips of tools/synth/clip.py."""
    fr = c.frames[first:first + n]
    if len(fr) < n:
        raise ValueError("%s has %d frames from %d, not %d" % (c.name, len(fr), first, n))
    ref = np.linspace(c.frames[0], c.frames[-1], 30).astype(int)
    pos, rot = fk(c.b, np.concatenate([fr, ref]), need=c.need)
    s = NECK_ABOVE_ANKLE * H / c.neck_height_units
    pos = np.einsum("ij,nkj->nki", c.R_up, pos) * s
    J = c.jidx
    feet = pos[:, [J["left_toe"], J["right_toe"], J["left_ankle"], J["right_ankle"]], 2].min(axis=1)
    # as sample_pose's floor, and under every foot of the sequence
    floor = min(float(np.percentile(feet, 5)) - 0.02 * H, float(feet[:n].min()) - 0.015 * H)
    centre = pos[0, J["pelvis"]].copy()
    centre[2] = floor
    M = np.diag([-1.0, 1.0, 1.0])
    out = []
    for i in range(n):
        joints = {k: pos[i, j] - centre for k, j in J.items()}
        Hf = c.R_up @ rot[i, J["neck"]] @ c.A
        joints["head_top"] = joints["neck"] + HEAD_TOP * H * Hf[:, 1]
        if mirror:
            j2 = {k: M @ v for k, v in joints.items()}
            for a, b in LEFT_RIGHT:
                j2[a], j2[b] = j2[b], j2[a]
            joints = j2
            Hf = np.stack([M @ Hf[:, 0], M @ Hf[:, 1], -(M @ Hf[:, 2])], 1)
        out.append({"joints": joints, "head": Hf, "height": H, "clip": c.name, "frame": int(fr[i]),
                    "mirror": mirror, "split": "all"})
    return out


if __name__ == "__main__":
    clips = load_clips(sys.argv[1] if len(sys.argv) > 1 else "/work/shared/data/mocap-train")
    rng = np.random.default_rng(0)
    nt = sum(len(c.split_frames("train")) for c in clips)
    nv = sum(len(c.split_frames("val")) for c in clips)
    print("clips", len(clips), "train frames", nt, "val frames", nv)
    for c in clips:
        print(c.name, len(c.frames), "val", int(c.is_val.sum()), "up", np.round(np.linalg.inv(c.R_up)[:, 2], 2),
              "neckH", round(c.neck_height_units, 2))
    for i in range(4):
        p = sample_pose(clips, rng, "train")
        j = p["joints"]
        print(p["clip"], p["frame"], round(p["height"], 2),
              {k: np.round(j[k], 2).tolist() for k in ("head_top", "neck", "pelvis", "left_ankle", "left_wrist")},
              "F", np.round(p["head"][:, 0], 2), "U", np.round(p["head"][:, 1], 2), "L", np.round(p["head"][:, 2], 2))
