#!/usr/bin/python3
"""Tests of the detector trainer's left/right figures and penalty
(`make check-train-tools`; needs `make deps-train`: python3-torch, numpy).

    /usr/bin/python3 -m pytest -q tools/train/test_metrics.py
"""
import os
import sys

import numpy as np
import pytest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
torch = pytest.importorskip("torch")
import common as C  # noqa: E402
import train as T  # noqa: E402

LW, RW = C.JOINTS.index("left_wrist"), C.JOINTS.index("right_wrist")
LK, RK = C.JOINTS.index("left_knee"), C.JOINTS.index("right_knee")


def frame(uv_by_joint, conf=0.9):
    """One view's (J, 3) detections and (J, 2) truths; joints not named are
    outside the image (state 2) and not detected."""
    pred = np.zeros((len(C.JOINTS), 3))
    uv = np.zeros((len(C.JOINTS), 2))
    st = np.full(len(C.JOINTS), 2)
    for j, (truth, guess) in uv_by_joint.items():
        uv[j], st[j] = truth, 0
        pred[j] = (*guess, conf)
    return pred, uv, st


def rates(*frames):
    pred, uv, st = (np.stack(x) for x in zip(*frames))
    return T.pair_rates(pred, uv, st)


def test_collapse_swap_and_right():
    right = frame({LW: ((30, 60), (31, 60)), RW: ((90, 60), (89, 61))})
    collapsed = frame({LW: ((30, 60), (90, 60)), RW: ((90, 60), (91, 60))})
    swapped = frame({LW: ((30, 60), (88, 60)), RW: ((90, 60), (32, 60))})
    r = rates(right, collapsed, swapped)
    assert r["pairs"] == 3
    assert r["collapse"] == pytest.approx(1 / 3)
    assert r["swap"] == pytest.approx(1 / 2)  # of the two pairs not collapsed


def test_pairs_close_in_the_truth_or_undetected_do_not_count():
    near = frame({LK: ((60, 60), (60, 60)), RK: ((70, 60), (60, 61))})  # truths 10 px apart
    pred, uv, st = frame({LW: ((30, 60), (90, 60)), RW: ((90, 60), (90, 60))})
    pred[RW, 2] = 0.1  # below the threshold: not detected
    r = rates(near, (pred, uv, st))
    assert r["pairs"] == 0 and r["collapse"] == 0 and r["swap"] == 0


def blob_logits(centres):
    """(1, J, 32, 32) logits: a sharp blob per joint at its heat-map cell, else far below 0."""
    x = torch.full((1, len(C.JOINTS), C.HM, C.HM), -12.0)
    for j, (cx, cy) in centres.items():
        x[0, j, cy, cx] = 12.0
    return x


def test_pair_penalty_only_for_a_collapse():
    uv = torch.zeros(1, len(C.JOINTS), 2)
    st = torch.full((1, len(C.JOINTS)), 2)
    uv[0, LW], uv[0, RW] = torch.tensor([30.0, 60.0]), torch.tensor([90.0, 60.0])
    st[0, LW] = st[0, RW] = 0
    tgt = T.targets(uv, st)
    apart = blob_logits({LW: (7, 15), RW: (22, 15)})
    together = blob_logits({LW: (22, 15), RW: (22, 15)})
    for logits in (apart, together):
        plain = float(T.loss_fn(logits, tgt))
        assert float(T.loss_fn(logits, tgt, uv, st, 0.0)) == pytest.approx(plain)
    assert float(T.loss_fn(apart, tgt, uv, st, 10.0)) == pytest.approx(float(T.loss_fn(apart, tgt)), abs=1e-6)
    extra = float(T.loss_fn(together, tgt, uv, st, 10.0)) - float(T.loss_fn(together, tgt))
    assert extra > 1e-3
    # truths close together: the same collapse is not penalised
    uv[0, RW] = torch.tensor([36.0, 60.0])
    assert float(T.loss_fn(together, tgt, uv, st, 10.0)) == pytest.approx(float(T.loss_fn(together, tgt)))


def test_architectures():
    for arch in C.ARCHS:
        out = C.build_model(arch).eval()(torch.rand(1, C.in_channels(arch), C.IN, C.IN))
        hm = C.IN // C.HM_DIV[arch]
        assert tuple(out.shape) == (1, len(C.JOINTS), hm, hm)
    with pytest.raises(ValueError, match="unknown architecture"):
        C.build_model("v9")


def test_feet_weight():
    """--feet-weight scales the ankles' and toes' share of the loss only."""
    tgt = torch.zeros(1, len(C.JOINTS), C.HM, C.HM)
    logits = torch.full_like(tgt, -12.0)
    LA = C.JOINTS.index("left_ankle")
    logits[0, LA, 3, 3] = 5.0  # a wrong peak on the ankle's channel
    plain, heavy = float(T.loss_fn(logits, tgt)), float(T.loss_fn(logits, tgt, feet_weight=3.0))
    assert heavy == pytest.approx(3 * plain, rel=1e-3)
    logits[0, LA, 3, 3], logits[0, LW, 3, 3] = -12.0, 5.0  # the same on a wrist's channel
    assert float(T.loss_fn(logits, tgt, feet_weight=3.0)) == pytest.approx(float(T.loss_fn(logits, tgt)))


def gaussian(x0, y0, sigma, peak, size=32):
    yy, xx = np.mgrid[0:size, 0:size]
    return peak * np.exp(-((xx - x0) ** 2 + (yy - y0) ** 2) / (2 * sigma ** 2))


def test_decode_dark_matches_the_runtime():
    """The numbers of test_decode_dark in detect/tests/test_detector.c: a
    Gaussian's centre to a hundredth of a cell (the centroid is pulled to the
    cell's middle), a broad peak over a taller spike, confidence the map's
    maximum."""
    cells = lambda u: (u + 0.5) * C.HM_W / C.IN_W - 0.5  # noqa: E731
    assert C.target_sigma() == 1.0 and (C.HM_W, C.IN_W) == (32, 128)
    hm = gaussian(10.4, 20.3, 1.0, 0.9)[None]
    u, v, conf = C.decode(hm)[0]
    assert abs(cells(u) - 10.4) < 0.01 and abs(cells(v) - 20.3) < 0.01 and conf == hm[0, 20, 10]
    assert abs(cells(C.decode(hm, sigma=0)[0, 0]) - 10.4) > 0.1
    two = gaussian(24, 12, 1.0, 0.8)
    two[5, 5] = 0.95
    u, v, conf = C.decode(two[None])[0]
    assert abs(cells(u) - 24) < 0.01 and abs(cells(v) - 12) < 0.01 and conf == 0.95
    assert cells(C.decode(two[None], sigma=0)[0, 0]) == 5


def test_confidence_study_statistics():
    import confidence_study as S
    assert S.auc([0.9, 0.8, 0.2, 0.1], [True, True, False, False]) == 1.0
    assert S.auc([0.1, 0.2, 0.8, 0.9], [True, True, False, False]) == 0.0
    assert S.auc([0.5, 0.5, 0.5, 0.5], [True, False, True, False]) == 0.5
    lone = gaussian(12, 20, 1.0, 0.9)
    peak, ratio, q = S.statistics(lone)
    assert abs(q - 1) < 0.02 and ratio > 10
    two = lone + gaussian(25, 5, 1.0, 0.9)
    assert abs(S.statistics(two)[2] - 0.5) < 0.02 and S.statistics(two)[1] < 1.05
