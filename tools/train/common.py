"""Shared pieces of the 2D joint detector: joint list, network, heatmap decoding,
fisheye projection.  The decoding here is the one the C runtime implements."""
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "synth"))
import fisheye  # noqa: E402
from fisheye import project_cam  # noqa: E402

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


# target Gaussian sigma in heat-map cells, by input pixels per cell side:
# 4 input pixels on 1/4 heat maps (v1, v2), 2 on v3's 1/2 heat maps
SIGMA = {4: 1.0, 2: 1.5}


# decode()'s sigma when not given: None for target_sigma(); an exported
# model's sidecar heatmap_sigma (train.py load_model), or --decode-sigma.
DECODE_SIGMA = None


def target_sigma():
    """The training targets' Gaussian sigma (cells) at today's heat-map size;
    the export writes it to the sidecar as heatmap_sigma."""
    return SIGMA[IN_W // HM_W]


def blur(h, sigma):
    """h (H, W) smoothed by a Gaussian of sigma cells: separable, radius
    ceil(3 sigma) (at most 8), edges repeated.  The same arithmetic as
    blur_plane() in detect/mc_detector_decode.c."""
    r = min(8, int(math.ceil(3 * sigma)))
    k = np.exp(-0.5 * np.arange(-r, r + 1) ** 2 / sigma ** 2)
    k /= k.sum()
    p = np.pad(h.astype(np.float64), r, mode="edge")
    H, W = h.shape
    rows = sum(k[i] * p[r:r + H, i:i + W] for i in range(2 * r + 1))
    p = np.pad(rows, ((r, r), (0, 0)), mode="edge")
    return sum(k[i] * p[i:i + H, :] for i in range(2 * r + 1))


def _log_parabola(a, b, c):
    """The vertex of the parabola through log a, log b, log c (at -1, 0, 1),
    clipped to [-1, 1]; 0 when they do not curve down."""
    la, lb, lc = (math.log(max(float(t), 1e-10)) for t in (a, b, c))
    d2 = la - 2 * lb + lc
    return float(np.clip(-0.5 * (lc - la) / d2, -1, 1)) if d2 < 0 else 0.0


def _centroid3x3(h, x, y):
    H, W = h.shape
    y0, y1, x0, x1 = max(0, y - 1), min(H, y + 2), max(0, x - 1), min(W, x + 2)
    win = np.maximum(h[y0:y1, x0:x1].astype(np.float64), 0)
    s = win.sum()
    if s <= 0:
        return float(x), float(y)
    yy, xx = np.mgrid[y0:y1, x0:x1]
    return (win * xx).sum() / s, (win * yy).sum() / s


def decode(hm, sigma=None):
    """hm: (J, H, W) array of values in [0, 1].  Returns (J, 3): u, v (input
    pixels, IN_W x IN_H: 128x128 for ego), confidence = the map's maximum.
    sigma (cells; default DECODE_SIGMA, else target_sigma()) > 0: the map smoothed by a
    Gaussian of sigma, its argmax cell, the sub-cell position from the
    parabola through the smoothed map's logs at the cell and its two
    neighbours in x and in y (DARK, Zhang et al. 2020).  sigma 0: the raw
    argmax and the weighted centroid of its 3x3 window.  Then
    u = (x_c + 0.5) * IN_W / W - 0.5, v = (y_c + 0.5) * IN_H / H - 0.5.
    detect/mc_detector_decode.c does the same."""
    J, H, W = hm.shape
    if sigma is None:
        sigma = target_sigma() if DECODE_SIGMA is None else DECODE_SIGMA
    out = np.zeros((J, 3))
    for j in range(J):
        y, x = divmod(int(np.argmax(hm[j])), W)
        conf = hm[j, y, x]
        if sigma > 0:
            h = blur(hm[j], sigma)
            y, x = divmod(int(np.argmax(h)), W)
            xc = x + (_log_parabola(h[y, x - 1], h[y, x], h[y, x + 1]) if 0 < x < W - 1 else 0.0)
            yc = y + (_log_parabola(h[y - 1, x], h[y, x], h[y + 1, x]) if 0 < y < H - 1 else 0.0)
        else:
            xc, yc = _centroid3x3(hm[j], x, y)
        out[j] = ((xc + 0.5) * IN_W / W - 0.5, (yc + 0.5) * IN_H / H - 0.5, conf)
    return out


def load_rig(path, res=IN):
    """The rig's cameras by name (fisheye.load_rig, the renderer's reader)."""
    return {c["name"]: c for c in fisheye.load_rig(path, res)}


def project(cam, P_rig):
    """P_rig (N,3) in the rig (= left camera) frame -> u, v, inside (N,) bool."""
    T = np.linalg.inv(cam["rig_from_cam"])
    P = P_rig @ T[:3, :3].T + T[:3, 3]
    u, v, th = project_cam(cam, P)
    inside = (th <= cam["fov"] / 2) & (u >= -0.5) & (u <= IN - 0.5) & (v >= -0.5) & (v <= IN - 0.5)
    return u, v, inside
