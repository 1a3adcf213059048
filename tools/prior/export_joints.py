"""Training poses for the pose prior: mocap-train's BVH clips -> joint
positions in each frame's head axes, as text for `mocap-prior-fit`.

Each output line is one frame:  CLIP MIRROR FRAME  then x y z (metres) for
the 17 joints of bvh.JOINTS after head_top, relative to the neck (the BVH
Head joint), in the body model's root axes: x to the actor's right, y down,
z forward.  The same frame mirrored (left and right swapped, x negated) is
a second line: a mirrored pose is as human as the original.

    /usr/bin/python3 tools/prior/export_joints.py ../shared/data/mocap-train \
        --stride 2 > build/prior/joints.txt

Only mocap-train is read (the evaluation motions in ../shared/data/mocap are
not).  The units are fixed by a 1.75 m stature; bone lengths do not matter
to the prior, which holds joint angles only.
"""
import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "synth"))
from bvh import JOINTS, fk  # noqa: E402
from motion import LEFT_RIGHT, NECK_ABOVE_ANKLE, load_clips  # noqa: E402

STATURE_M = 1.75
NAMES = JOINTS[1:]  # head_top is synthesised in the renders; the prior skips it


def head_axes_joints(clip, frames):
    """(N, 17, 3) joints in model root axes, metres, neck at the origin."""
    pos, rot = fk(clip.b, frames, need=clip.need)
    s = NECK_ABOVE_ANKLE * STATURE_M / clip.neck_height_units
    J = clip.jidx
    neck = pos[:, J["neck"]]
    # The head frame's columns (forward, up, left) in file axes, as motion.py
    # builds it for the renders.
    H = np.einsum("nij,jk->nik", rot[:, J["neck"]], clip.A)
    out = np.zeros((len(frames), len(NAMES), 3))
    for k, name in enumerate(NAMES):
        d = (pos[:, J[name]] - neck) * s
        f = np.einsum("ni,ni->n", d, H[:, :, 0])
        u = np.einsum("ni,ni->n", d, H[:, :, 1])
        left = np.einsum("ni,ni->n", d, H[:, :, 2])
        out[:, k] = np.stack([-left, -u, f], 1)
    return out


def mirrored(joints):
    m = joints.copy()
    m[:, :, 0] *= -1
    idx = {n: k for k, n in enumerate(NAMES)}
    for a, b in LEFT_RIGHT:
        m[:, [idx[a], idx[b]]] = m[:, [idx[b], idx[a]]]
    return m


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("root", help="the mocap-train folder")
    ap.add_argument("--stride", type=int, default=2, help="keep every Nth frame (default 2: 15 fps)")
    a = ap.parse_args()
    out = sys.stdout
    out.write("# joints: " + " ".join(NAMES) + "\n")
    for clip in load_clips(a.root):
        frames = clip.frames[:: a.stride]
        j = head_axes_joints(clip, frames)
        for mirror, jj in ((0, j), (1, mirrored(j))):
            for f, p in zip(frames, jj):
                out.write("%s %d %d %s\n" % (clip.name, mirror, f, " ".join("%.4f" % v for v in p.ravel())))
        print("%s: %d frames" % (clip.name, len(frames)), file=sys.stderr)


if __name__ == "__main__":
    main()
