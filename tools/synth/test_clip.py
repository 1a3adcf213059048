#!/usr/bin/python3
"""Tests of the evaluation clips' motion, ground truth and lens file
(tools/synth/clip.py; `make check-train-tools`; no Blender needed).

    /usr/bin/python3 -m pytest -q tools/synth/test_clip.py
"""
import math
import os
import sys
import types

import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import clip  # noqa: E402
from motion import clip_sequence, load_clips  # noqa: E402

MOCAP = os.path.join(HERE, "..", "..", "..", "shared", "data", "mocap-train")
RIG = os.path.join(HERE, "..", "..", "config", "rigs", "ego_stereo.json")


@pytest.fixture(scope="module")
def clips():
    if not os.path.isdir(MOCAP):
        pytest.skip("no %s" % MOCAP)
    return {c.name: c for c in load_clips(MOCAP)}


def test_sequence_is_one_motion_on_the_floor(clips):
    seq = clip_sequence(clips["cmu_iclone/02_06"], 150, 120, 1.8)
    pel = np.array([s["joints"]["pelvis"] for s in seq])
    # one world: the pelvis starts over the origin and moves as a person
    # does (under 2 m/s between frames), bending down to scoop
    assert np.allclose(pel[0, :2], 0.0)
    assert np.linalg.norm(np.diff(pel, axis=0), axis=1).max() * 30 < 2.0
    assert np.ptp(pel[:, 2]) > 0.2
    feet = np.array([[s["joints"][k][2] for k in ("left_ankle", "right_ankle", "left_toe", "right_toe")]
                     for s in seq])
    assert feet.min() > 0.0  # never under the floor
    assert np.percentile(feet.min(axis=1), 50) < 0.15  # and standing on it
    head = np.array([s["joints"]["head_top"][2] for s in seq])
    assert 1.6 < head.max() < 1.9  # the stature asked for


def test_a_folder_is_resumed_with_its_own_clip_only(tmp_path):
    a = types.SimpleNamespace(out=str(tmp_path), kind="ego", motion="cmu_iclone/02_07", first=0, frames=10, seed=1,
                              mirror=False, bystander=None, bystander_first=0, split="val", data_version=3,
                              res=256, samples=8, rig=RIG)
    clip.check_same_clip(a, 1.7)
    clip.check_same_clip(a, 1.7)  # the same again: resumed
    a.first = 95
    with pytest.raises(SystemExit, match="first 0, not 95"):
        clip.check_same_clip(a, 1.7)


def test_mirror_swaps_sides(clips):
    a = clip_sequence(clips["cmu_iclone/02_07"], 0, 5, 1.7)
    b = clip_sequence(clips["cmu_iclone/02_07"], 0, 5, 1.7, mirror=True)
    M = np.diag([-1.0, 1.0, 1.0])
    for k in range(5):
        assert np.allclose(b[k]["joints"]["right_wrist"], M @ a[k]["joints"]["left_wrist"])
        assert np.allclose(b[k]["joints"]["neck"], M @ a[k]["joints"]["neck"])


def test_bystander_plays_forward_and_back():
    assert [clip.ping_pong(k, 3) for k in range(7)] == [0, 1, 2, 1, 0, 1, 2]


def test_too_few_frames_refused(clips):
    c = clips["cmu_mb/02_01"]
    with pytest.raises(ValueError, match="02_01 has"):
        clip_sequence(c, 0, len(c.frames) + 1, 1.7)


def test_val_split_takes_held_out_motions_only(clips):
    c = clip.find_clip(list(clips.values()), "cmu_iclone/02_07", "val", "--motion")
    assert c.name == "cmu_iclone/02_07"
    train_motion = next(n for n in clips if not n.split("/")[1].startswith(("02_", "60_", "61_")))
    with pytest.raises(SystemExit, match="which the detectors trained on"):
        clip.find_clip(list(clips.values()), train_motion, "val", "--motion")
    with pytest.raises(SystemExit, match="is not a clip"):
        clip.find_clip(list(clips.values()), "cmu_mb/99_99", "train", "--motion")


def test_calib_is_the_dev_clips_lens():
    c = clip.calib_json(clip.ego_cams(RIG, 256))
    assert c["model"] == "equidistant-fisheye" and c["width"] == 256 and c["fov_deg"] == 180
    assert abs(c["baseline_m"] - 0.30) < 1e-6
    # right_from_left takes the left camera's origin 0.3 m to the right camera's left
    assert np.allclose(np.array(c["right_from_left"])[:3, 3], [-0.3, 0, 0], atol=1e-6)
    # the polynomial is the same lens: a ray at 60 degrees lands at f * theta
    p = c["ocam_poly"]
    rho = c["f"] * math.radians(60)
    w = p["a0"] + p["a2"] * rho ** 2 + p["a3"] * rho ** 3 + p["a4"] * rho ** 4
    assert abs(math.degrees(math.atan2(rho, w)) - 60) < 0.1
    assert p["max_abs_err_px"] < 0.5


def test_gt_is_in_the_left_camera(clips):
    seq = clip_sequence(clips["cmu_iclone/02_07"], 0, 3, 1.7)
    T = np.eye(4)
    T[:3, :3] = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]
    T[:3, 3] = [0.1, 0.2, 1.9]
    a = types.SimpleNamespace(motion="cmu_iclone/02_07", first=0, mirror=False, seed=1, bystander=None)
    g = clip.gt_json(a, seq, [T] * 3, {"build": "heavy"})
    assert g["fps"] == 30.0 and len(g["frames"]) == 3 and g["joint_names"][0] == "head_top"
    f = g["frames"][2]
    back = T[:3, :3] @ np.array(f["joints_left_cam"]["left_knee"]) + T[:3, 3]
    assert np.allclose(back, seq[2]["joints"]["left_knee"], atol=1e-4)
    assert f["time"] == pytest.approx(2 / 30.0, abs=1e-6)
    # outside-in: the joints in the world, as they are
    g = clip.gt_json(a, seq, None, {"build": "heavy"})
    assert g["frames"][1]["joints_world"]["neck"] == pytest.approx(seq[1]["joints"]["neck"].tolist(), abs=1e-5)
    assert "left_cam_to_world" not in g["frames"][1]


def test_cameras_file_is_the_dev_clips_layout():
    T = np.eye(4)
    T[:3, 3] = [4.0, 0.5, 1.8]
    K = {"fx": 266.3, "fy": 266.3, "cx": 159.5, "cy": 119.5, "w": 320, "h": 240}
    c = clip.cameras_json([("cam0", T, K)])["cameras"][0]
    assert c["name"] == "cam0" and c["model"] == "pinhole" and (c["width"], c["height"]) == (320, 240)
    assert np.allclose(np.array(c["world_to_camera"]) @ [4.0, 0.5, 1.8, 1.0], [0, 0, 0, 1])
