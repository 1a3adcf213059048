#!/usr/bin/python3
"""Tests of the appearance augmentation (`train.py --aug-look`,
tools/train/augment_look.py; `make check-train-tools`, needs `make deps-train`).

    /usr/bin/python3 -m pytest -q tools/train/test_augment_look.py
"""
import math
import os
import sys

import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
torch = pytest.importorskip("torch")
import augment_look as A  # noqa: E402


def test_hue_rotation_keeps_grey_and_is_a_rotation():
    R = A.hue_matrices(torch.tensor([0.0, 1.0, math.pi, -2.5]))
    grey = torch.tensor([0.4, 0.4, 0.4])
    for r in R:
        assert torch.allclose(r @ grey, grey, atol=1e-6)
        assert torch.allclose(r @ r.T, torch.eye(3), atol=1e-6)
    assert torch.allclose(R[0], torch.eye(3), atol=1e-7)
    # a third of a turn carries red to green
    r120 = A.hue_matrices(torch.tensor([2 * math.pi / 3]))[0]
    assert torch.allclose(r120 @ torch.tensor([1.0, 0.0, 0.0]), torch.tensor([0.0, 1.0, 0.0]), atol=1e-6)


def test_blur_keeps_flat_images_and_softens_edges():
    flat = torch.full((2, 3, 16, 16), 0.3)
    assert torch.allclose(A.blur3(flat, torch.tensor([0.7, 1.3])), flat, atol=1e-6)
    edge = torch.zeros(1, 3, 16, 16)
    edge[..., 8:] = 1.0
    b = A.blur3(edge, torch.tensor([1.0]))
    assert 0.05 < float(b[0, 0, 5, 7]) < 0.5 < float(b[0, 0, 5, 8]) < 0.95
    assert float(b[0, 0, 5, 0]) == pytest.approx(0.0, abs=1e-6)


def test_augment_look_range_shape_and_seeded():
    x = torch.rand(32, 1, 3, 24, 24)
    a = A.augment_look(x.clone(), np.random.default_rng(7))
    b = A.augment_look(x.clone(), np.random.default_rng(7))
    c = A.augment_look(x.clone(), np.random.default_rng(8))
    assert a.shape == x.shape
    assert float(a.min()) >= 0.0 and float(a.max()) <= 1.0
    assert torch.equal(a, b), "the same generator state gives the same looks (a resumed run)"
    assert not torch.equal(a, c)
    changed = (a - x).abs().flatten(1).amax(1) > 1e-3
    assert 0.5 < float(changed.float().mean()) <= 1.0, "most images get some new look"


def test_stereo_views_share_colour_draws():
    """Two views of one frame: equal inputs stay equal outside the cut-outs."""
    x = torch.rand(16, 1, 3, 24, 24).expand(16, 2, 3, 24, 24).clone()
    old = A.P_CUT
    A.P_CUT = 0.0
    try:
        a = A.augment_look(x, np.random.default_rng(3))
    finally:
        A.P_CUT = old
    assert torch.allclose(a[:, 0], a[:, 1], atol=1e-6)
