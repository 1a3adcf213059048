"""Shared pieces of the 2D joint detector: joint list, network, heatmap decoding,
fisheye projection.  The decoding here is the one the C runtime implements."""
import json
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "synth"))
from fisheye import project_cam, rig_from_cam_matrix  # noqa: E402

JOINTS = ["head_top", "neck", "spine", "pelvis",
          "left_shoulder", "left_elbow", "left_wrist", "left_hip", "left_knee", "left_ankle", "left_toe",
          "right_shoulder", "right_elbow", "right_wrist", "right_hip", "right_knee", "right_ankle",
          "right_toe"]
GROUPS = {
    "torso": ["head_top", "neck", "spine", "pelvis", "left_shoulder", "right_shoulder", "left_hip", "right_hip"],
    "arms": ["left_elbow", "left_wrist", "right_elbow", "right_wrist"],
    "legs": ["left_knee", "left_ankle", "left_toe", "right_knee", "right_ankle", "right_toe"],
}
EVALUATED = [j for j in JOINTS if j not in ("head_top", "spine", "pelvis")]
IN = 128
HM = 32
THRESHOLD = 0.3
# Network input (width, height) per kind of view; heatmaps are 1/4 of it.
# The network needs both divisible by 16.  set_kind() switches the module's
# IN_W, IN_H, HM_W, HM_H (ego: 128x128 -> 32x32, outside: 192x144 -> 48x36).
KINDS = {"ego": (128, 128), "outside": (192, 144)}
IN_W, IN_H, HM_W, HM_H = IN, IN, HM, HM
KIND = "ego"


ARCHS = ("v1", "v2", "v3")
# Heat-map cells per input pixel side, per architecture: v3's heat maps are
# half the input (64x64 at 128x128) for sub-pixel keypoints.
HM_DIV = {"v1": 4, "v2": 4, "v3": 2}


def set_kind(kind, arch="v1"):
    global IN_W, IN_H, HM_W, HM_H, KIND
    KIND = kind
    IN_W, IN_H = KINDS[kind]
    HM_W, HM_H = IN_W // HM_DIV[arch], IN_H // HM_DIV[arch]


def set_heatmap(h, w):
    """Heat maps of h x w (an exported model's own, from its sidecar)."""
    global HM_W, HM_H
    HM_W, HM_H = w, h


def _cbr(i, o, s=1, k=3):
    import torch.nn as nn
    return [nn.Conv2d(i, o, k, s, k // 2, bias=False), nn.BatchNorm2d(o), nn.ReLU(inplace=True)]


def build_model(arch="v1"):
    """v1: the 103k-parameter encoder-decoder shipped until stop 38 (three
    scales, 29 M multiply-adds at 128x128).  v2 (issue 36): wider, and a
    fourth scale at 1/32 whose 3x3 convolutions see the whole view, so that
    a joint's channel can use the whole body's layout to tell left from
    right (about 84 M multiply-adds).  Both use only Conv/BN/ReLU, MaxPool,
    nearest Upsample, Add and Sigmoid: the ONNX contract of docs/DETECTOR.md."""
    import torch.nn as nn
    if arch not in ARCHS:
        raise ValueError("unknown architecture %r (known: %s)" % (arch, ", ".join(ARCHS)))
    cbr = _cbr
    up = lambda i, o: nn.Sequential(nn.Upsample(scale_factor=2, mode="nearest"), *cbr(i, o, k=1))  # noqa: E731

    class Net(nn.Module):
        """3xHxW -> 18x(H/4)x(W/4) (ego: 128x128 -> 32x32; H, W divisible by 16)."""

        def __init__(self):
            super().__init__()
            self.s32 = nn.Sequential(*cbr(3, 12, 2), *cbr(12, 24, 2), *cbr(24, 24))          # 32x32
            self.s16 = nn.Sequential(nn.MaxPool2d(2), *cbr(24, 40), *cbr(40, 40))           # 16x16
            self.s8 = nn.Sequential(nn.MaxPool2d(2), *cbr(40, 56), *cbr(56, 56))            # 8x8
            self.up8 = up(56, 40)
            self.m16 = nn.Sequential(*cbr(40, 40))
            self.up16 = up(40, 24)
            self.m32 = nn.Sequential(*cbr(24, 24))
            self.head = nn.Conv2d(24, len(JOINTS), 1)

        def forward(self, x):  # returns logits
            a = self.s32(x)
            b = self.s16(a)
            c = self.s8(b)
            b = self.m16(b + self.up8(c))
            a = self.m32(a + self.up16(b))
            return self.head(a)

    class NetV2(nn.Module):
        """As Net, wider, with a 1/32 scale (4x4 at 128x128) for whole-view context."""

        def __init__(self):
            super().__init__()
            self.s32 = nn.Sequential(*cbr(3, 16, 2), *cbr(16, 32, 2), *cbr(32, 32))                 # 32x32
            self.s16 = nn.Sequential(nn.MaxPool2d(2), *cbr(32, 64), *cbr(64, 64))                  # 16x16
            self.s8 = nn.Sequential(nn.MaxPool2d(2), *cbr(64, 96), *cbr(96, 96), *cbr(96, 96))     # 8x8
            self.s4 = nn.Sequential(nn.MaxPool2d(2), *cbr(96, 128), *cbr(128, 128), *cbr(128, 128))  # 4x4
            self.up4, self.m8 = up(128, 96), nn.Sequential(*cbr(96, 96))
            self.up8, self.m16 = up(96, 64), nn.Sequential(*cbr(64, 64))
            self.up16, self.m32 = up(64, 32), nn.Sequential(*cbr(32, 32))
            self.head = nn.Conv2d(32, len(JOINTS), 1)

        def forward(self, x):  # returns logits
            a = self.s32(x)
            b = self.s16(a)
            c = self.s8(b)
            d = self.s4(c)
            c = self.m8(c + self.up4(d))
            b = self.m16(b + self.up8(c))
            a = self.m32(a + self.up16(b))
            return self.head(a)

    class NetV3(nn.Module):
        """As NetV2, wider at 1/8 and 1/16, and with a 1/2 scale: heat maps of
        half the input (64x64 at 128x128), so that a keypoint's sub-cell
        position is a 2-pixel matter rather than a 4-pixel one (issue 36,
        item 3).  Trained on a GPU (docs/DETECTOR.md, "v3 network")."""

        def __init__(self):
            super().__init__()
            self.s64 = nn.Sequential(*cbr(3, 16, 2))                                               # 64x64
            self.s32 = nn.Sequential(*cbr(16, 32, 2), *cbr(32, 32))                                # 32x32
            self.s16 = nn.Sequential(nn.MaxPool2d(2), *cbr(32, 80), *cbr(80, 80))                  # 16x16
            self.s8 = nn.Sequential(nn.MaxPool2d(2), *cbr(80, 128), *cbr(128, 128), *cbr(128, 128))  # 8x8
            self.s4 = nn.Sequential(nn.MaxPool2d(2), *cbr(128, 192), *cbr(192, 192), *cbr(192, 192))  # 4x4
            self.up4, self.m8 = up(192, 128), nn.Sequential(*cbr(128, 128))
            self.up8, self.m16 = up(128, 80), nn.Sequential(*cbr(80, 80))
            self.up16, self.m32 = up(80, 32), nn.Sequential(*cbr(32, 32))
            self.up32, self.m64 = up(32, 16), nn.Sequential(*cbr(16, 16))
            self.head = nn.Conv2d(16, len(JOINTS), 1)

        def forward(self, x):  # returns logits
            e = self.s64(x)
            a = self.s32(e)
            b = self.s16(a)
            c = self.s8(b)
            d = self.s4(c)
            c = self.m8(c + self.up4(d))
            b = self.m16(b + self.up8(c))
            a = self.m32(a + self.up16(b))
            e = self.m64(e + self.up32(a))
            return self.head(e)

    return {"v1": Net, "v2": NetV2, "v3": NetV3}[arch]()


def decode(hm):
    """hm: (J, H, W) array of values in [0, 1].  Returns (J, 3): u, v (input
    pixels, IN_W x IN_H: 128x128 for ego), confidence.  Argmax cell,
    confidence = value there, sub-cell position = weighted centroid of the
    3x3 window (clipped at the borders), u = (x_c + 0.5) * IN_W / W - 0.5,
    v = (y_c + 0.5) * IN_H / H - 0.5."""
    J, H, W = hm.shape
    out = np.zeros((J, 3))
    for j in range(J):
        k = int(np.argmax(hm[j]))
        y, x = divmod(k, W)
        y0, y1, x0, x1 = max(0, y - 1), min(H, y + 2), max(0, x - 1), min(W, x + 2)
        win = hm[j, y0:y1, x0:x1].astype(np.float64)
        s = win.sum()
        if s > 0:
            yy, xx = np.mgrid[y0:y1, x0:x1]
            xc, yc = (win * xx).sum() / s, (win * yy).sum() / s
        else:
            xc, yc = float(x), float(y)
        out[j] = ((xc + 0.5) * IN_W / W - 0.5, (yc + 0.5) * IN_H / H - 0.5, hm[j, y, x])
    return out


def load_rig(path, res=IN):
    rig = json.load(open(path))
    cams = {}
    for c in rig["cameras"]:
        s = res / c["width"]
        M = rig_from_cam_matrix(c["rig_from_cam"])
        cams[c["name"]] = {"f": c["f"] * s, "cx": (c["cx"] + 0.5) * s - 0.5, "cy": (c["cy"] + 0.5) * s - 0.5,
                           "k": c.get("k", [0, 0, 0, 0]), "fov": math.radians(c.get("fov_deg", 180.0)),
                           "rig_from_cam": M}
    return cams


def project(cam, P_rig):
    """P_rig (N,3) in the rig (= left camera) frame -> u, v, inside (N,) bool."""
    T = np.linalg.inv(cam["rig_from_cam"])
    P = P_rig @ T[:3, :3].T + T[:3, 3]
    u, v, th = project_cam(cam, P)
    inside = (th <= cam["fov"] / 2) & (u >= -0.5) & (u <= IN - 0.5) & (v >= -0.5) & (v <= IN - 0.5)
    return u, v, inside
