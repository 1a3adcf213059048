#!/usr/bin/python3
"""Two heat-map detectors as one ONNX model whose heat maps are the
weighted mean of theirs (docs/DETECTOR.md, "Offline model"):

    ensemble.py A.onnx B.onnx OUT.onnx [--weight-a 0.5] [--validation REPORT.json] [--sidecar-only]

Both models must take the same input and give heat maps of the same joints
and size; their sidecars (A.json, B.json) are read and OUT.json written:
A's input, joints, threshold and heat-map size, the members with their
weights, where their weights came from, and, with --validation (a
`train.py --report --report-out` file of OUT.onnx), the validation's
headline figures.  The result is checked in OpenCV DNN against the members
run on their own.  --sidecar-only leaves an existing OUT.onnx as it is and
writes OUT.json alone (to add the validation once OUT.onnx has been
scored, without merging and checking again)."""
import argparse
import json
import os
import sys

import numpy as np

SIDE_KEYS = ("input", "joints", "heatmap", "heatmap_sigma")


def sidecar(path):
    return json.load(open(os.path.splitext(path)[0] + ".json"))


def merge(path_a, path_b, weight_a):
    """The ONNX model: both graphs, names prefixed a_ and b_, fed the same
    image; heatmaps = weight_a * a + (1 - weight_a) * b."""
    import onnx
    from onnx import TensorProto, compose, helper
    a = compose.add_prefix(onnx.load(path_a), "a_")
    b = compose.add_prefix(onnx.load(path_b), "b_")
    shape_in = [d.dim_value for d in a.graph.input[0].type.tensor_type.shape.dim]
    shape_out = [d.dim_value for d in a.graph.output[0].type.tensor_type.shape.dim]
    nodes = [helper.make_node("Identity", ["image"], ["a_image"]),
             helper.make_node("Identity", ["image"], ["b_image"])]
    nodes += list(a.graph.node) + list(b.graph.node)
    nodes += [helper.make_node("Mul", ["a_heatmaps", "weight_a"], ["a_weighted"]),
              helper.make_node("Mul", ["b_heatmaps", "weight_b"], ["b_weighted"]),
              helper.make_node("Add", ["a_weighted", "b_weighted"], ["heatmaps"])]
    consts = [helper.make_tensor("weight_a", TensorProto.FLOAT, [1], [weight_a]),
              helper.make_tensor("weight_b", TensorProto.FLOAT, [1], [1.0 - weight_a])]
    graph = helper.make_graph(nodes, "ensemble",
                              [helper.make_tensor_value_info("image", TensorProto.FLOAT, shape_in)],
                              [helper.make_tensor_value_info("heatmaps", TensorProto.FLOAT, shape_out)],
                              list(a.graph.initializer) + list(b.graph.initializer) + consts)
    opset = max(a.opset_import[0].version, b.opset_import[0].version)
    return helper.make_model(graph, opset_imports=[helper.make_opsetid("", opset)],
                             producer_name="mocapd tools/train/ensemble.py")


def check(out, path_a, path_b, weight_a, size):
    """Max |ensemble - (w a + (1 - w) b)| on a random image, in OpenCV."""
    import cv2
    cv2.setNumThreads(1)
    x = np.random.default_rng(1).random((1, 3, size[0], size[1]), dtype=np.float32)
    got = {}
    for p in (out, path_a, path_b):
        net = cv2.dnn.readNetFromONNX(p)
        net.setInput(x, "image")
        got[p] = net.forward("heatmaps")
    want = weight_a * got[path_a] + (1 - weight_a) * got[path_b]
    return float(np.abs(got[out] - want).max())


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("out")
    ap.add_argument("--weight-a", type=float, default=0.5)
    ap.add_argument("--validation", help="train.py --report-out file of OUT.onnx")
    ap.add_argument("--sidecar-only", action="store_true", help="OUT.onnx is made: write OUT.json only")
    a = ap.parse_args()
    if not 0 <= a.weight_a <= 1:
        sys.exit("--weight-a %g: must be within 0..1" % a.weight_a)
    sa, sb = sidecar(a.a), sidecar(a.b)
    for k in SIDE_KEYS:
        if sa.get(k) != sb.get(k):
            sys.exit("%s and %s differ in %r: %s against %s" % (a.a, a.b, k, sa.get(k), sb.get(k)))
    if a.sidecar_only:
        if not os.path.exists(a.out):
            sys.exit("%s: not there; --sidecar-only writes the sidecar of a model already made" % a.out)
    else:
        import onnx
        onnx.save(merge(a.a, a.b, a.weight_a), a.out)
        err = check(a.out, a.a, a.b, a.weight_a, sa["input"])
        if err > 1e-5:
            sys.exit("%s: differs from its members by %.2e" % (a.out, err))
        print("%s: %d bytes, max |ensemble - members| = %.1e" % (a.out, os.path.getsize(a.out), err))
    write_sidecar(a, sa, sb)


def write_sidecar(a, sa, sb):
    """OUT.json: A's input contract, the members, their licences, and the
    validation's headline figures when given."""
    side = {k: sa[k] for k in SIDE_KEYS if k in sa}
    side["threshold"] = sa.get("threshold", 0.3)
    side["arch"] = "ensemble"
    side["members"] = [dict(file=os.path.basename(p), weight=w, arch=s.get("arch"), trained_on=s.get("trained_on"),
                            parameters=s.get("parameters"))
                       for p, s, w in ((a.a, sa, a.weight_a), (a.b, sb, 1 - a.weight_a))]
    side["parameters"] = sum(s.get("parameters") or 0 for s in (sa, sb))
    for s in (sa, sb):
        for k in ("started_from", "license"):
            if k in s:
                side[k] = s[k]
    if a.validation:
        sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
        from train import validation_card
        card = validation_card(json.load(open(a.validation)).get("validation"))
        if card:
            side["validation"] = card
    side["model_card"] = "docs/DETECTOR.md, \"Offline model\""
    path = os.path.splitext(a.out)[0] + ".json"
    with open(path, "w") as f:
        json.dump(side, f, indent=1)
        f.write("\n")
    print("%s: %d parameters%s" % (path, side["parameters"], ", with the validation" if "validation" in side else ""))


if __name__ == "__main__":
    main()
