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


ARCHS = ("v1", "v2", "v3", "mn", "v2s")
# Networks that see the stereo pair: the view and its partner camera's view
# stacked as 6 input channels, heat maps for the first (issue 36 item 4).
STEREO = ("v2s",)


def in_channels(arch):
    """Input channels of an architecture: RGB, or two views' RGB."""
    return 6 if arch in STEREO else 3
# Heat-map cells per input pixel side, per architecture: v3's heat maps are
# half the input (64x64 at 128x128) for sub-pixel keypoints.
HM_DIV = {"v1": 4, "v2": 4, "v3": 2, "mn": 4, "v2s": 4}


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
    scales, 29 M multiply-adds at 128x128, heat maps of 1/4 the input).
    v2 (issue 36): wider, and a fourth scale at 1/32 whose 3x3 convolutions
    see the whole view, so that a joint's channel can use the whole body's
    layout to tell left from right (80 M multiply-adds).  v3: wider at 1/8
    and 1/16, and a 1/2 scale, so that the heat maps are half the input
    (64x64 at 128x128) and a keypoint's sub-cell position is a 2-pixel
    matter rather than a 4-pixel one (129 M multiply-adds; trained on a GPU,
    docs/DETECTOR_EXPERIMENTS.md "v3 network").  mn: pretrained MoveNet Lightning's
    backbone and pyramid with a head for our joints (pretrained.py; heat
    maps of 1/4 the input).  v2s: v2 with the partner camera's view as three
    more input channels (an experiment: the runtime feeds one view).  v1-v3
    use only Conv/BN/ReLU, MaxPool, nearest Upsample, Add and Sigmoid: the
    ONNX contract of docs/DETECTOR.md."""
    import torch.nn as nn
    if arch not in ARCHS:
        raise ValueError("unknown architecture %r (known: %s)" % (arch, ", ".join(ARCHS)))
    if arch == "mn":
        from pretrained import MoveNetEgo
        return MoveNetEgo(JOINTS)
    cbr = _cbr
    pool = nn.MaxPool2d

    def seq(*layers):
        return nn.Sequential(*layers)

    def up(i, o):
        return seq(nn.Upsample(scale_factor=2, mode="nearest"), *cbr(i, o, k=1))

    class Pyramid(nn.Module):
        """Encoder stages, finest first, each one scale coarser than the one
        before; then from the coarsest up, at each finer scale, the coarser
        result up-sampled (`up`), added to that scale's encoder output and
        merged by a convolution (`merge`); a 1x1 head on the finest.  The
        attribute names (s32, up8, m16, ...: the scale's cells at 128x128)
        are the checkpoints' keys."""

        def __init__(self, stages, merges, head_in):
            super().__init__()
            self.encoder = [name for name, _ in stages]
            self.decoder = [(u, m) for u, _, m, _ in merges]
            for name, module in stages:
                setattr(self, name, module)
            for u, up_module, m, merge in merges:
                setattr(self, u, up_module)
                setattr(self, m, merge)
            self.head = nn.Conv2d(head_in, len(JOINTS), 1)

        def forward(self, x):  # returns logits
            feats = []
            for name in self.encoder:
                x = getattr(self, name)(x)
                feats.append(x)
            y = feats[-1]
            for (u, m), skip in zip(self.decoder, reversed(feats[:-1])):
                y = getattr(self, m)(skip + getattr(self, u)(y))
            return self.head(y)

    if arch == "v1":  # 3xHxW -> 18x(H/4)x(W/4)
        return Pyramid([("s32", seq(*cbr(3, 12, 2), *cbr(12, 24, 2), *cbr(24, 24))),
                        ("s16", seq(pool(2), *cbr(24, 40), *cbr(40, 40))),
                        ("s8", seq(pool(2), *cbr(40, 56), *cbr(56, 56)))],
                       [("up8", up(56, 40), "m16", seq(*cbr(40, 40))),
                        ("up16", up(40, 24), "m32", seq(*cbr(24, 24)))], 24)
    if arch in ("v2", "v2s"):  # as v1, wider, with a 1/32 scale (4x4 at 128x128) for whole-view context
        return Pyramid([("s32", seq(*cbr(in_channels(arch), 16, 2), *cbr(16, 32, 2), *cbr(32, 32))),
                        ("s16", seq(pool(2), *cbr(32, 64), *cbr(64, 64))),
                        ("s8", seq(pool(2), *cbr(64, 96), *cbr(96, 96), *cbr(96, 96))),
                        ("s4", seq(pool(2), *cbr(96, 128), *cbr(128, 128), *cbr(128, 128)))],
                       [("up4", up(128, 96), "m8", seq(*cbr(96, 96))),
                        ("up8", up(96, 64), "m16", seq(*cbr(64, 64))),
                        ("up16", up(64, 32), "m32", seq(*cbr(32, 32)))], 32)
    # v3: 3xHxW -> 18x(H/2)x(W/2)
    return Pyramid([("s64", seq(*cbr(3, 16, 2))),
                    ("s32", seq(*cbr(16, 32, 2), *cbr(32, 32))),
                    ("s16", seq(pool(2), *cbr(32, 80), *cbr(80, 80))),
                    ("s8", seq(pool(2), *cbr(80, 128), *cbr(128, 128), *cbr(128, 128))),
                    ("s4", seq(pool(2), *cbr(128, 192), *cbr(192, 192), *cbr(192, 192)))],
                   [("up4", up(192, 128), "m8", seq(*cbr(128, 128))),
                    ("up8", up(128, 80), "m16", seq(*cbr(80, 80))),
                    ("up16", up(80, 32), "m32", seq(*cbr(32, 32))),
                    ("up32", up(32, 16), "m64", seq(*cbr(16, 16)))], 16)


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
