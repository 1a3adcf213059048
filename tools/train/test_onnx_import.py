#!/usr/bin/python3
"""Tests of onnx_import.py: a network exported as train.py --export does
reads back into torch with the same outputs (`make check-train-tools`;
needs `make deps-train` and python3-onnx).

    /usr/bin/python3 -m pytest -q tools/train/test_onnx_import.py
"""
import os
import sys

import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
torch = pytest.importorskip("torch")
pytest.importorskip("onnx")
import common as C  # noqa: E402
import onnx_import as I  # noqa: E402
import train as T  # noqa: E402


def _trained_looking(arch, seed):
    """A model of arch with random weights and BatchNorm statistics, as
    after training (fresh BatchNorms are identities, which would hide a
    folding mistake)."""
    torch.manual_seed(seed)
    m = C.build_model(arch)
    with torch.no_grad():
        for mod in m.modules():
            if isinstance(mod, torch.nn.BatchNorm2d):
                mod.weight.uniform_(0.5, 1.5)
                mod.bias.uniform_(-0.2, 0.2)
                mod.running_mean.uniform_(-0.3, 0.3)
                mod.running_var.uniform_(0.5, 2.0)
    return m.eval()


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    C.set_kind("ego")
    m = _trained_looking("v1", 3)
    path = str(tmp_path_factory.mktemp("onnx") / "net.onnx")
    model = I._export(T.Exported(m).eval(), (C.IN_H, C.IN_W))
    with open(path, "wb") as f:
        f.write(model.SerializeToString())
    return m, path


def test_read_back_gives_the_same_heat_maps(exported):
    want_model, path = exported
    got_model = I.load_fused_weights(C.build_model("v1"), path, T.Exported, (C.IN_H, C.IN_W)).eval()
    x = torch.rand(2, 3, C.IN_H, C.IN_W, generator=torch.Generator().manual_seed(5))
    with torch.no_grad():
        want, got = torch.sigmoid(want_model(x)), torch.sigmoid(got_model(x))
    assert float((want - got).abs().max()) < 1e-4
    # and not by accident: a fresh model differs
    with torch.no_grad():
        other = torch.sigmoid(C.build_model("v1").eval()(x))
    assert float((want - other).abs().max()) > 1e-2


def test_another_architecture_is_refused(exported):
    _, path = exported
    with pytest.raises(ValueError, match="architecture"):
        I.load_fused_weights(C.build_model("v2"), path, T.Exported, (C.IN_H, C.IN_W))


def test_frozen_batchnorms_keep_their_statistics(exported):
    _, path = exported
    m = I.load_fused_weights(C.build_model("v1"), path, T.Exported, (C.IN_H, C.IN_W))
    bns = [b for b in m.modules() if isinstance(b, torch.nn.BatchNorm2d)]
    before = [b.running_var.clone() for b in bns]
    m.train()
    I.freeze_batchnorm(m)
    m(torch.rand(4, 3, C.IN_H, C.IN_W) * 3)
    assert all(torch.equal(a, b.running_var) for a, b in zip(before, bns))
    assert all(np.allclose(b.running_var.numpy(), 1 - b.eps) for b in bns)
