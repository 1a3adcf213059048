"""Minimal BVH reader and forward kinematics (numpy only).

Used by tools/synth/render.py inside Blender's Python, and importable from
/usr/bin/python3 for tests.  Joint positions come out in the file's units and
axes; render.py finds the up axis and the scale from the motion itself.
"""
import numpy as np

# DESIGN.md joint -> BVH joint name per skeleton family.  "X@end" is the End
# Site under X.  head_top is synthesised from the head frame (see render.py),
# so it is not listed here.
FAMILIES = {
    "cmu_mb": {
        "neck": "Head", "spine": "Spine1", "pelvis": "Hips",
        "left_shoulder": "LeftArm", "left_elbow": "LeftForeArm", "left_wrist": "LeftHand",
        "left_hip": "LeftUpLeg", "left_knee": "LeftLeg", "left_ankle": "LeftFoot",
        "left_toe": "LeftToeBase",
        "right_shoulder": "RightArm", "right_elbow": "RightForeArm", "right_wrist": "RightHand",
        "right_hip": "RightUpLeg", "right_knee": "RightLeg", "right_ankle": "RightFoot",
        "right_toe": "RightToeBase",
    },
    "cmu_daz": {
        "neck": "head", "spine": "abdomen", "pelvis": "hip",
        "left_shoulder": "lShldr", "left_elbow": "lForeArm", "left_wrist": "lHand",
        "left_hip": "lThigh", "left_knee": "lShin", "left_ankle": "lFoot",
        "left_toe": "lFoot@end",
        "right_shoulder": "rShldr", "right_elbow": "rForeArm", "right_wrist": "rHand",
        "right_hip": "rThigh", "right_knee": "rShin", "right_ankle": "rFoot",
        "right_toe": "rFoot@end",
    },
    "cmu_iclone": {
        "neck": "CC_Base_Head", "spine": "CC_Base_Spine01", "pelvis": "CC_Base_Hip",
        "left_shoulder": "CC_Base_L_Upperarm", "left_elbow": "CC_Base_L_Forearm",
        "left_wrist": "CC_Base_L_Hand",
        "left_hip": "CC_Base_L_Thigh", "left_knee": "CC_Base_L_Calf", "left_ankle": "CC_Base_L_Foot",
        "left_toe": "CC_Base_L_ToeBase",
        "right_shoulder": "CC_Base_R_Upperarm", "right_elbow": "CC_Base_R_Forearm",
        "right_wrist": "CC_Base_R_Hand",
        "right_hip": "CC_Base_R_Thigh", "right_knee": "CC_Base_R_Calf", "right_ankle": "CC_Base_R_Foot",
        "right_toe": "CC_Base_R_ToeBase",
    },
}

JOINTS = ["head_top", "neck", "spine", "pelvis",
          "left_shoulder", "left_elbow", "left_wrist", "left_hip", "left_knee", "left_ankle", "left_toe",
          "right_shoulder", "right_elbow", "right_wrist", "right_hip", "right_knee", "right_ankle",
          "right_toe"]


class Bvh:
    def __init__(self, path):
        self.path = path
        self.names, self.parents, self.offsets, self.channels = [], [], [], []
        toks = open(path).read().split()
        i = 0
        stack = []
        last = -1
        while toks[i] != "MOTION":
            t = toks[i]
            if t in ("ROOT", "JOINT"):
                name = toks[i + 1]
                i += 2
                self._add(name, stack[-1] if stack else -1)
                last = len(self.names) - 1
            elif t == "End":
                name = self.names[stack[-1]] + "@end"
                i += 2
                self._add(name, stack[-1])
                last = len(self.names) - 1
            elif t == "{":
                stack.append(last)
                i += 1
            elif t == "}":
                stack.pop()
                i += 1
            elif t == "OFFSET":
                self.offsets[last] = [float(x) for x in toks[i + 1:i + 4]]
                i += 4
            elif t == "CHANNELS":
                n = int(toks[i + 1])
                self.channels[last] = toks[i + 2:i + 2 + n]
                i += 2 + n
            else:
                i += 1
        i += 1
        assert toks[i] == "Frames:"
        nf = int(toks[i + 1])
        assert toks[i + 2] == "Frame" and toks[i + 3] == "Time:"
        self.frame_time = float(toks[i + 4])
        vals = np.array(toks[i + 5:], dtype=np.float64)
        nc = sum(len(c) for c in self.channels)
        self.motion = vals[:nf * nc].reshape(nf, nc)
        self.offsets = np.array(self.offsets)
        self.index = {n: k for k, n in enumerate(self.names)}
        col = 0
        self.col = []
        for c in self.channels:
            self.col.append(col)
            col += len(c)

    def _add(self, name, parent):
        self.names.append(name)
        self.parents.append(parent)
        self.offsets.append([0.0, 0.0, 0.0])
        self.channels.append([])

    @property
    def nframes(self):
        return self.motion.shape[0]


def _rot(axis, a):
    """Rotation matrices about axis ('X','Y','Z') for angles a (N,) in radians -> (N,3,3)."""
    c, s = np.cos(a), np.sin(a)
    o, z = np.ones_like(a), np.zeros_like(a)
    if axis == "X":
        m = [[o, z, z], [z, c, -s], [z, s, c]]
    elif axis == "Y":
        m = [[c, z, s], [z, o, z], [-s, z, c]]
    else:
        m = [[c, -s, z], [s, c, z], [z, z, o]]
    return np.moveaxis(np.array(m), [0, 1], [-2, -1])


def fk(b, frames, offset_scale=None, perturb=None, need=None):
    """Forward kinematics for frame indices `frames` (array).

    offset_scale: per-joint multiplier of the OFFSET (limb proportions).
    perturb: dict joint index -> (3,3) extra local rotation (pose noise).
    need: set of joint indices to compute (with their ancestors); None = all.
    Returns (pos (N,J,3), rot (N,J,3,3)) in file units/axes.
    """
    frames = np.atleast_1d(frames)
    n = len(frames)
    J = len(b.names)
    pos = np.zeros((n, J, 3))
    rot = np.zeros((n, J, 3, 3))
    mot = b.motion[frames]
    todo = None
    if need is not None:
        todo = set()
        for j in need:
            while j >= 0 and j not in todo:
                todo.add(j)
                j = b.parents[j]
    for j in range(J):
        if todo is not None and j not in todo:
            continue
        R = np.tile(np.eye(3), (n, 1, 1))
        t = np.zeros((n, 3))
        for k, ch in enumerate(b.channels[j]):
            v = mot[:, b.col[j] + k]
            if ch.endswith("rotation"):
                R = R @ _rot(ch[0].upper(), np.radians(v))
            else:
                t[:, "XYZ".index(ch[0].upper())] = v
        if perturb is not None and j in perturb:
            R = R @ perturb[j]
        off = b.offsets[j] * (offset_scale[j] if offset_scale is not None else 1.0)
        p = b.parents[j]
        if p < 0:
            pos[:, j] = t + off
            rot[:, j] = R
        else:
            pos[:, j] = pos[:, p] + np.einsum("nij,j->ni", rot[:, p], off)
            rot[:, j] = rot[:, p] @ R
    return pos, rot
