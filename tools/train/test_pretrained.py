#!/usr/bin/python3
"""Tests of pretrained.py: the shipped MoveNet read back into torch, and the
head rig's network started from it (`make check-train-tools`; needs
`make deps-train` and python3-onnx).

    /usr/bin/python3 -m pytest -q tools/train/test_pretrained.py
"""
import os
import subprocess
import sys

import numpy as np
import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
torch = pytest.importorskip("torch")
pytest.importorskip("onnx")
import common as C  # noqa: E402
import pretrained as P  # noqa: E402

F = torch.nn.functional


def test_symmetric_padding_matches_tensorflow_same():
    """A stride-2 convolution padded (0, 0, 1, 1), as TensorFlow's SAME
    pads it, equals the wider kernel with symmetric padding."""
    g = torch.Generator().manual_seed(1)
    x, w = torch.randn(2, 3, 16, 16, generator=g), torch.randn(5, 3, 3, 3, generator=g)
    want = F.conv2d(F.pad(x, (0, 1, 0, 1)), w, stride=2)
    w2, pad = P._symmetric(w, [0, 0, 1, 1])
    assert w2.shape == (5, 3, 4, 4) and pad == (1, 1)
    got = F.conv2d(x, w2, stride=2, padding=pad)
    assert got.shape == want.shape
    assert float((got - want).abs().max()) < 1e-5
    with pytest.raises(ValueError):
        P._symmetric(w, [1, 1, 0, 0])


def test_hard_sigmoid_is_onnx_hard_sigmoid():
    x = torch.linspace(-10, 10, 101)
    for alpha, beta in ((1 / 6, 0.0), (0.2, 0.5)):
        want = torch.clamp(x * alpha + beta, 0, 1)
        assert float((P._hard_sigmoid(x, alpha, beta) - want).abs().max()) < 1e-6


def test_trunk_reproduces_movenet():
    """The whole MoveNet graph run by OnnxTrunk gives OpenCV DNN's heat
    maps (the converter's own check is against TensorFlow.js)."""
    cv2 = pytest.importorskip("cv2")
    trunk = P.OnnxTrunk(P.MOVENET_ONNX, "heatmaps")
    x = torch.rand(1, 3, 192, 192, generator=torch.Generator().manual_seed(2))
    with torch.no_grad():
        got = trunk(x).numpy()
    net = cv2.dnn.readNetFromONNX(P.MOVENET_ONNX)
    net.setInput(x.numpy(), "image")
    want = net.forward("heatmaps")
    assert got.shape == want.shape == (1, 17, 48, 48)
    assert float(np.abs(got - want).max()) < 1e-4


def test_head_starts_as_movenets_coco_head():
    """Before training, our shoulder channel is MoveNet's shoulder channel
    and the neck the mean of both shoulders' logits."""
    C.set_kind("ego", "mn")
    model = C.build_model("mn").eval()
    ref = P.OnnxTrunk(P.MOVENET_ONNX, "BiasAdd_330")  # COCO heat-map logits
    x = torch.rand(2, 3, 128, 128, generator=torch.Generator().manual_seed(3))
    with torch.no_grad():
        ours, coco = model(x), ref(x)
    assert ours.shape == (2, len(C.JOINTS), 32, 32)
    ls, rs = P.COCO.index("left_shoulder"), P.COCO.index("right_shoulder")
    assert float((ours[:, C.JOINTS.index("left_shoulder")] - coco[:, ls]).abs().max()) < 1e-4
    neck = (coco[:, ls] + coco[:, rs]) / 2
    assert float((ours[:, C.JOINTS.index("neck")] - neck).abs().max()) < 1e-4


def test_unsupported_op_is_named(tmp_path):
    onnx = pytest.importorskip("onnx")
    from onnx import TensorProto, helper
    g = helper.make_graph([helper.make_node("Tanh", ["x"], ["y"], name="squash")], "g",
                          [helper.make_tensor_value_info("x", TensorProto.FLOAT, [1, 1])],
                          [helper.make_tensor_value_info("y", TensorProto.FLOAT, [1, 1])])
    path = str(tmp_path / "tanh.onnx")
    onnx.save(helper.make_model(g), path)
    with pytest.raises(ValueError, match="squash.*Tanh"):
        P.OnnxTrunk(path, "y")


def test_export_reads_in_opencv(tmp_path):
    """The exported network (sigmoid heat maps) runs in OpenCV 4.6 DNN as
    in torch: no Pad or three-input Clip nodes that it cannot read."""
    pytest.importorskip("cv2")
    C.set_kind("ego", "mn")
    model = C.build_model("mn")
    ck = str(tmp_path / "mn.pt")
    torch.save({"model": model.state_dict(), "state": {}, "params": 0, "arch": "mn"}, ck)
    out = subprocess.run([sys.executable, os.path.join(HERE, "train.py"), "--arch", "mn", "--weights", ck,
                          "--export", str(tmp_path / "mn.onnx")], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-2000:]
    line = [s for s in out.stderr.splitlines() if "max |cv - torch|" in s]
    assert line, out.stderr[-2000:]
    assert float(line[0].split("=")[1].split(",")[0]) < 1e-4


def test_fold_relu6_keeps_the_function():
    """Folding ReLU6's shift into the biases and its scale into the next
    weights changes no output, and leaves no Mul by 6 behind."""
    trunk = P.OnnxTrunk(P.MOVENET_ONNX, "heatmaps").eval()
    x = torch.rand(2, 3, 192, 192, generator=torch.Generator().manual_seed(4))
    with torch.no_grad():
        before = trunk(x)
        assert trunk.fold_relu6() == 35
        after = trunk(x)
    assert float((before - after).abs().max()) < 1e-5
    passed = sum(1 for n, a in zip(trunk.nodes, trunk.attrs) if n.op_type == "Mul" and "_pass" in a)
    assert passed == 35


def _ensemble(*args):
    return subprocess.run([sys.executable, os.path.join(HERE, "ensemble.py")] + list(args),
                          capture_output=True, text=True, timeout=300)


def test_ensemble_is_the_weighted_mean(tmp_path):
    """Two models as one: the shipped model with a copy of itself whose
    heat maps are scaled, so that the mean is known; the sidecar lists both."""
    cv2 = pytest.importorskip("cv2")
    import json
    import shutil
    import onnx
    from onnx import helper
    ego = os.path.join(P.ROOT, "config", "models", "ego_detector.onnx")
    a, b = str(tmp_path / "a.onnx"), str(tmp_path / "b.onnx")
    shutil.copy(ego, a)
    shutil.copy(os.path.splitext(ego)[0] + ".json", str(tmp_path / "a.json"))
    m = onnx.load(ego)  # b: the same network, heat maps x 0.5
    for n in m.graph.node:
        n.output[:] = ["raw" if o == "heatmaps" else o for o in n.output]
    m.graph.node.append(helper.make_node("Mul", ["raw", "half"], ["heatmaps"]))
    m.graph.initializer.append(helper.make_tensor("half", onnx.TensorProto.FLOAT, [1], [0.5]))
    onnx.save(m, b)
    shutil.copy(os.path.splitext(ego)[0] + ".json", str(tmp_path / "b.json"))
    out = str(tmp_path / "e.onnx")
    r = _ensemble(a, b, out, "--weight-a", "0.25")
    assert r.returncode == 0, r.stderr
    x = np.random.default_rng(5).random((1, 3, 128, 128), dtype=np.float32)
    heat = {}
    for p in (a, out):
        net = cv2.dnn.readNetFromONNX(p)
        net.setInput(x, "image")
        heat[p] = net.forward("heatmaps")
    assert float(np.abs(heat[out] - (0.25 + 0.75 * 0.5) * heat[a]).max()) < 1e-5
    side = json.load(open(str(tmp_path / "e.json")))
    assert side["arch"] == "ensemble" and [w["weight"] for w in side["members"]] == [0.25, 0.75]
    assert side["joints"] == C.JOINTS and side["heatmap"] == [32, 32] and "validation" not in side
    assert side["heatmap_sigma"] == 1.0  # the members' decoding carries over
    # --sidecar-only: the validation added, the model file left as it was
    report = tmp_path / "report.json"
    json.dump({"validation": {"false": 0.285, "median_visible": 3.97, "median_occluded": 7.63, "collapse": 0.001,
                              "swap": 0.03}}, open(str(report), "w"))
    before = open(out, "rb").read()
    os.utime(out, (1, 1))
    r = _ensemble(a, b, out, "--weight-a", "0.25", "--validation", str(report), "--sidecar-only")
    assert r.returncode == 0, r.stderr
    assert open(out, "rb").read() == before and os.stat(out).st_mtime == 1
    side = json.load(open(str(tmp_path / "e.json")))
    assert side["validation"]["gross_pct"] == 28.5 and [w["weight"] for w in side["members"]] == [0.25, 0.75]
    r = _ensemble(a, b, str(tmp_path / "none.onnx"), "--sidecar-only")
    assert r.returncode != 0 and "none.onnx: not there" in r.stderr


def test_ensemble_refuses_members_that_differ(tmp_path):
    import json
    import shutil
    ego = os.path.join(P.ROOT, "config", "models", "ego_detector")
    for name in ("a", "b"):
        shutil.copy(ego + ".onnx", str(tmp_path / (name + ".onnx")))
    side = json.load(open(ego + ".json"))
    json.dump(side, open(str(tmp_path / "a.json"), "w"))
    json.dump(dict(side, heatmap=[64, 64]), open(str(tmp_path / "b.json"), "w"))
    r = _ensemble(str(tmp_path / "a.onnx"), str(tmp_path / "b.onnx"), str(tmp_path / "e.onnx"))
    assert r.returncode != 0 and "'heatmap'" in r.stderr
    assert not os.path.exists(str(tmp_path / "e.onnx"))
