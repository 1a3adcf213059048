#!/usr/bin/python3
"""Writes the outside-in test rig in both formats: rig.json (the project's
rig format, kind outside-in) and cameras.json (the evaluation data's
outside-in calibration: OpenCV intrinsics and world_to_camera).  Four
320x240 pinhole cameras stand 4 m from the origin at 90-degree steps, 1.6 m
high, looking at (0, 0, 1); world z up, floor at z = 0.  cam1 has lens
distortion so that the importer's distortion path is exercised."""
import json
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))


def look_at(eye, target):
    """world_to_camera rotation (rows = camera x, y, z axes in world) and translation."""
    z = [t - e for t, e in zip(target, eye)]
    n = math.sqrt(sum(c * c for c in z))
    z = [c / n for c in z]
    up = [0.0, 0.0, 1.0]
    x = [z[1] * up[2] - z[2] * up[1], z[2] * up[0] - z[0] * up[2], z[0] * up[1] - z[1] * up[0]]
    n = math.sqrt(sum(c * c for c in x))
    x = [c / n for c in x]
    y = [z[1] * x[2] - z[2] * x[1], z[2] * x[0] - z[0] * x[2], z[0] * x[1] - z[1] * x[0]]
    R = [x, y, z]
    t = [-sum(R[i][j] * eye[j] for j in range(3)) for i in range(3)]
    return R, t


cams_json, rig_cams = [], []
for k in range(4):
    a = math.radians(90 * k + 20)
    eye = [4.0 * math.cos(a), 4.0 * math.sin(a), 1.6]
    R, t = look_at(eye, [0.0, 0.0, 1.0])
    dist = [-0.05, 0.01, 0.0005, -0.0003, 0.0] if k == 1 else [0.0] * 5
    w2c = [R[0] + [t[0]], R[1] + [t[1]], R[2] + [t[2]], [0.0, 0.0, 0.0, 1.0]]
    cams_json.append({"name": "cam%d" % k, "model": "pinhole", "width": 320, "height": 240,
                      "fx": 280.0, "fy": 280.0, "cx": 159.5, "cy": 119.5, "dist": dist,
                      "world_to_camera": w2c})
    Rt = [[R[j][i] for j in range(3)] for i in range(3)]  # camera-to-world rotation
    rig_cams.append({"name": "cam%d" % k, "model": "pinhole", "width": 320, "height": 240,
                     "fx": 280.0, "fy": 280.0, "cx": 159.5, "cy": 119.5, "k": dist, "max_theta_deg": 40,
                     "rig_from_cam": {"rotation": Rt, "translation": eye}})
with open(os.path.join(HERE, "cameras.json"), "w") as f:
    json.dump({"note": "test fixture, tests/data/outside/make_fixtures.py", "cameras": cams_json}, f, indent=1)
with open(os.path.join(HERE, "rig.json"), "w") as f:
    json.dump({"name": "outside_test", "kind": "outside-in",
               "note": "test fixture, tests/data/outside/make_fixtures.py", "cameras": rig_cams}, f, indent=1)
