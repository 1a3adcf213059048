"""The equidistant (Kannala-Brandt) fisheye projection of the project's rig
files, in numpy: shared by the renderer's labels (tools/synth/render.py) and
the trainer's 2D report (tools/train/common.py), so both project exactly as
the C core does (core/geom/mc_camera.c), and the rig file's reader."""

import json
import math

import numpy as np


def project_cam(cam, P):
    """P (N,3) in the camera frame (OpenCV) -> (u, v, theta)."""
    x, y, z = P[:, 0], P[:, 1], P[:, 2]
    rho = np.sqrt(x * x + y * y)
    th = np.arctan2(rho, z)
    k = cam["k"]
    thd = th * (1 + k[0] * th ** 2 + k[1] * th ** 4 + k[2] * th ** 6 + k[3] * th ** 8)
    r = cam["f"] * thd
    rs = np.where(rho > 1e-12, rho, 1.0)
    u = cam["cx"] + r * x / rs
    v = cam["cy"] + r * y / rs
    return u, v, th


def rig_from_cam_matrix(T):
    """A rig file's `rig_from_cam` (a 4x4 list, or {"rotation", "translation"})
    as a 4x4 numpy matrix."""
    if isinstance(T, dict):
        M = np.eye(4)
        M[:3, :3] = np.array(T["rotation"])
        M[:3, 3] = np.array(T["translation"])
        return M
    return np.array(T, dtype=float)


def load_rig(path, res):
    """A rig file's equidistant cameras, scaled to res x res pixels: a list
    of dicts (name, f, cx, cy, k, fov in radians, rig_from_cam 4x4)."""
    rig = json.load(open(path))
    cams = []
    for c in rig["cameras"]:
        assert c["model"] == "equidistant", c["model"]
        s = res / c["width"]
        M = rig_from_cam_matrix(c["rig_from_cam"])
        cams.append({"name": c["name"], "f": c["f"] * s, "cx": (c["cx"] + 0.5) * s - 0.5,
                     "cy": (c["cy"] + 0.5) * s - 0.5, "k": list(c.get("k", [0, 0, 0, 0])),
                     "fov": math.radians(c.get("fov_deg", 180.0)), "rig_from_cam": M})
    return cams
