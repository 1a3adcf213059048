#!/usr/bin/python3
"""Tests of pack.py (data parts for a training machine) and of the v3
network's targets and time-budgeted training (`make check-train-tools`;
needs `make deps-train`).

    /usr/bin/python3 -m pytest -q tools/train/test_pack.py
"""
import json
import os
import subprocess
import sys

import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
torch = pytest.importorskip("torch")
Image = pytest.importorskip("PIL.Image")
import common as C  # noqa: E402
import train as T  # noqa: E402

PY = sys.executable


def make_data(root, n_train=6, n_val=2):
    """A tiny data folder as tools/synth writes it: smooth images (so that
    WebP keeps them close) and label lines, with a partial last line."""
    os.makedirs(os.path.join(root, "images"))
    rng = np.random.default_rng(3)
    yy, xx = np.mgrid[0:128, 0:128]
    with open(os.path.join(root, "labels_000000.jsonl"), "w") as f:
        for k in range(n_train + n_val):
            rec = {"id": k, "split": "train" if k < n_train else "val", "views": {}, "images": {},
                   "joints_left_cam": [[0.1, 0.2, 0.3]] * len(C.JOINTS)}
            for cam in ("left", "right"):
                img = np.stack([(xx + 7 * k) % 256, (yy * 2) % 256, np.full_like(xx, 40 * k % 256)], -1)
                rel = "images/%06d_%s.jpg" % (k, cam)
                Image.fromarray(img.astype(np.uint8)).save(os.path.join(root, rel), quality=95)
                rec["images"][cam] = rel
                rec["views"][cam] = {"uv": rng.uniform(0, 127, (len(C.JOINTS), 2)).round(3).tolist(),
                                     "state": rng.integers(0, 3, len(C.JOINTS)).tolist()}
            f.write(json.dumps(rec) + "\n")
        f.write('{"id": 99, "split": "tr')  # a renderer cut off mid-line


def test_pack_round_trip(tmp_path):
    src, out, merged = tmp_path / "data", tmp_path / "pack", tmp_path / "merged"
    make_data(str(src))
    r = subprocess.run([PY, os.path.join(HERE, "pack.py"), "--data", str(src), "--out", str(out),
                        "--part-mb", "0.01"], capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    parts = sorted(os.listdir(out))
    assert len(parts) >= 2, parts  # split by size
    merged.mkdir()
    for p in parts:
        subprocess.run(["cp", "-r", str(out / p) + "/.", str(merged)], check=True)
    for split in ("train", "val"):
        a, b = T.Data(str(src), split), T.Data(str(merged), split)
        assert a.refresh() == b.refresh() == (12 if split == "train" else 4)
        order = [b.keys.index(k) for k in a.keys]
        assert np.array_equal(a.uv, b.uv[order]) and np.array_equal(a.st, b.st[order])
        diff = np.abs(a.img.astype(int) - b.img[order].astype(int)).mean()
        assert diff < 6, diff
    line = json.loads(open(out / parts[0] / ("labels_%s.jsonl" % parts[0])).readline())
    assert "joints_left_cam" not in line and line["images"]["left"].endswith(".webp")


def test_v3_heatmaps_and_targets():
    C.set_kind("ego", "v3")
    try:
        assert (C.HM_W, C.HM_H) == (64, 64)
        uv = torch.tensor([[[40.0, 80.0]] * len(C.JOINTS)])
        st = torch.zeros(1, len(C.JOINTS), dtype=torch.long)
        tgt = T.targets(uv, st)
        assert tuple(tgt.shape) == (1, len(C.JOINTS), 64, 64)
        # the peak cell holds the keypoint: (u + 0.5) / 2 - 0.5 = 19.75, v: 39.75
        y, x = divmod(int(tgt[0, 0].argmax()), 64)
        assert (x, y) == (20, 40)
        hm = tgt[0].numpy()
        dec = C.decode(hm)
        assert np.abs(dec[:, :2] - uv[0].numpy()).max() < 0.6
    finally:
        C.set_kind("ego")


def test_time_budget_training(tmp_path):
    """--minutes ends training after the epoch that reaches the budget, with
    a best.pt where --best says, whatever --epochs allows."""
    data = tmp_path / "data"
    make_data(str(data))
    best = tmp_path / "kept" / "best.pt"
    best.parent.mkdir()
    r = subprocess.run([PY, os.path.join(HERE, "train.py"), "--data", str(data), "--ckpt", str(tmp_path / "ck.pt"),
                        "--best", str(best), "--arch", "v3", "--epochs", "1000", "--steps-per-epoch", "2",
                        "--batch", "4", "--threads", "1", "--minutes", "0.001"], capture_output=True, text=True,
                       timeout=300)
    assert r.returncode == 0, r.stderr
    assert "training done: 2 steps" in r.stderr, r.stderr[-500:]
    assert best.exists() and not (tmp_path / "best.pt").exists()


def test_two_data_folders_train_together(tmp_path):
    """--data A,B: every view of both, the second folder's ids kept apart
    from the first's, each view paired with its own folder's partner."""
    a, b = tmp_path / "v2", tmp_path / "v3"
    make_data(str(a))
    make_data(str(b), n_train=4)
    one, both = T.Data(str(a), "train"), T.Data("%s,%s" % (a, b), "train")
    assert one.refresh() == 12 and both.refresh() == 12 + 8
    assert both.keys[:12] == one.keys and both.keys[12] == ("1:0", "left")
    assert len(set(both.keys)) == len(both.keys)
    for i, (f, cam) in enumerate(both.keys):
        j = both.partner[i]
        assert both.keys[j] == (f, "right" if cam == "left" else "left")
    assert np.array_equal(both.img[:12], one.img)
    b_only = T.Data(str(b), "train")
    b_only.refresh()
    assert np.array_equal(both.img[12:], b_only.img) and np.array_equal(both.uv[12:], b_only.uv)
