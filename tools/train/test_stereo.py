#!/usr/bin/python3
"""Tests of the stereo experiment (issue 36 item 4; `--arch v2s`): each
view paired with its partner camera's view, stacked as six channels
(`make check-train-tools`; needs `make deps-train`).

    /usr/bin/python3 -m pytest -q tools/train/test_stereo.py
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
pytest.importorskip("PIL.Image")
import common as C  # noqa: E402
import train as T  # noqa: E402
from test_pack import make_data  # noqa: E402


def drop_view(root, frame, cam):
    """Removes one view of a frame from the labels, as a render that lost it."""
    path = os.path.join(root, "labels_000000.jsonl")
    lines = open(path).read().split("\n")
    out = []
    for line in lines:
        try:
            r = json.loads(line)
        except ValueError:
            out.append(line)
            continue
        if r["id"] == frame:
            del r["views"][cam], r["images"][cam]
        out.append(json.dumps(r))
    open(path, "w").write("\n".join(out))


def test_partners(tmp_path):
    make_data(str(tmp_path))
    drop_view(str(tmp_path), 2, "right")
    d = T.Data(str(tmp_path), "train")
    d.refresh()
    for i, (frame, cam) in enumerate(d.keys):
        p = d.partner[i]
        if frame == 2:
            assert p == i  # no partner: the view itself
        else:
            assert d.keys[p] == (frame, "right" if cam == "left" else "left")


def test_stereo_batch_stacks_the_partner(tmp_path):
    C.set_kind("ego", "v2s")
    make_data(str(tmp_path))
    d = T.Data(str(tmp_path), "train")
    d.refresh()
    d.stereo = True
    idx = np.arange(len(d))
    x, uv, st = T.batch(d, idx, None, False)
    assert x.shape == (len(d), 6, 128, 128)
    mono = torch.from_numpy(d.img).permute(0, 3, 1, 2).float() / 255.0
    assert torch.equal(x[:, :3], mono)
    assert torch.equal(x[:, 3:], mono[torch.from_numpy(d.partner)])
    assert np.array_equal(uv.numpy(), d.uv.astype(np.float32))  # the labels stay the view's own
    # augmented: one geometric transform for both views (a pair of equal
    # images stays equal up to the per-pixel noise)
    d.partner = np.arange(len(d))
    xa, _, _ = T.batch(d, idx, np.random.default_rng(1), True)
    assert xa.shape == (len(d), 6, 128, 128)
    assert (xa[:, :3] - xa[:, 3:]).abs().mean() < 0.1


def test_stereo_network_and_no_export(tmp_path):
    C.set_kind("ego", "v2s")
    m = C.build_model("v2s").eval()
    with torch.no_grad():
        assert tuple(m(torch.rand(2, 6, 128, 128)).shape) == (2, len(C.JOINTS), 32, 32)
    ck = tmp_path / "s.pt"
    torch.save({"model": m.state_dict(), "args": {"arch": "v2s"}}, str(ck))
    r = subprocess.run([sys.executable, os.path.join(HERE, "train.py"), "--weights", str(ck),
                        "--export", str(tmp_path / "s.onnx")], capture_output=True, text=True)
    assert r.returncode != 0 and "stereo network" in r.stderr, r.stderr
    assert not (tmp_path / "s.onnx").exists()
