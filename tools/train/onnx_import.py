"""Weights of a shipped ONNX detector (exported by train.py --export from
one of common.build_model's Conv/BN/ReLU architectures) read back into
the torch model, so that a shipped network whose checkpoint is gone can be
trained further (train.py --init MODEL.onnx).

The export folds every BatchNorm into the convolution before it, so the
ONNX graph holds one weight and one bias per convolution.  They go back as
the convolution's weight and a BatchNorm that does nothing but add the
bias (scale 1, running mean 0, running variance 1 - eps).  Such a network
must be trained with its BatchNorms frozen (freeze_batchnorm): in training
mode they would normalise by the batch's statistics, which the folded
weights never saw.

Which ONNX convolution is which torch module: both graphs come from the
same export of the same architecture, so their Conv nodes come in the same
order.  A fresh export of the torch model, its convolutions marked with
their index in one weight, tells that order."""
import inspect
import io

import numpy as np
import torch


def conv_bn_pairs(model):
    """[(conv, bn or None)] for every Conv2d: the BatchNorm2d right after
    it in the same Sequential, if any."""
    pairs, seen = [], set()
    for mod in model.modules():
        if isinstance(mod, torch.nn.Sequential):
            kids = list(mod.children())
            for i, k in enumerate(kids):
                if isinstance(k, torch.nn.Conv2d) and id(k) not in seen:
                    bn = kids[i + 1] if i + 1 < len(kids) and isinstance(kids[i + 1], torch.nn.BatchNorm2d) else None
                    pairs.append((k, bn))
                    seen.add(id(k))
    for mod in model.modules():
        if isinstance(mod, torch.nn.Conv2d) and id(mod) not in seen:
            pairs.append((mod, None))
            seen.add(id(mod))
    return pairs


def export_onnx(net, shape, target):
    """Writes net (image -> heat maps, input of shape (h, w)) as ONNX to
    target (a path or a binary file): the detector runtime's contract, as
    train.py --export ships it."""
    # torch 2.5 and later would otherwise use its dynamo exporter, whose
    # graphs (opset 18) OpenCV 4.6 does not read
    legacy = {"dynamo": False} if "dynamo" in inspect.signature(torch.onnx.export).parameters else {}
    torch.onnx.export(net, torch.zeros(1, 3, *shape), target, opset_version=11, input_names=["image"],
                      output_names=["heatmaps"], do_constant_folding=True, **legacy)


def _export(net, shape):
    """net as an ONNX ModelProto, exported as export_onnx does."""
    import onnx
    buf = io.BytesIO()
    export_onnx(net, shape, buf)
    return onnx.load_from_string(buf.getvalue())


def _conv_weights(graph):
    """[(weight, bias or None)] of the graph's Conv nodes, in node order."""
    from onnx import numpy_helper
    init = {i.name: numpy_helper.to_array(i) for i in graph.initializer}
    out = []
    for n in graph.node:
        if n.op_type == "Conv":
            w = init.get(n.input[1])
            if w is None:
                raise ValueError("Conv node %s: its weight %s is not an initializer" % (n.name, n.input[1]))
            b = init.get(n.input[2]) if len(n.input) > 2 else None
            out.append((w, b))
    return out


def _identity_bn(bn, bias):
    with torch.no_grad():
        bn.weight.fill_(1.0)
        bn.bias.copy_(torch.from_numpy(bias))
        bn.running_mean.zero_()
        bn.running_var.fill_(1.0 - bn.eps)


def _order(model, pairs, wrap, shape):
    """For each Conv node of the export, in node order, its index in pairs
    (conv_bn_pairs(model)): each convolution's first weight is set to its
    index + 1 and BatchNorms to identities, then read back from a fresh
    export.  Changes the model's weights (they are overwritten next)."""
    with torch.no_grad():
        for k, (conv, bn) in enumerate(pairs):
            conv.weight.zero_()
            conv.weight.view(-1)[0] = k + 1
            if conv.bias is not None:
                conv.bias.zero_()
            if bn is not None:
                _identity_bn(bn, np.zeros(bn.num_features, np.float32))
    marks = [int(round(float(w.reshape(-1)[0]))) - 1 for w, _ in _conv_weights(_export(wrap(model).eval(), shape).graph)]
    if sorted(marks) != list(range(len(pairs))):
        raise ValueError("the export's convolutions do not map one to one onto the model's (%d nodes, %d modules)"
                         % (len(marks), len(pairs)))
    return marks


def load_fused_weights(model, onnx_path, wrap, shape):
    """Sets model's weights from the ONNX file at onnx_path, which an
    export of the same architecture wrote (wrap: the module the export
    wraps the model in; shape: the input's (h, w)).  Raises ValueError
    when the file's convolutions do not fit the model's."""
    import onnx
    got = _conv_weights(onnx.load(onnx_path).graph)
    pairs = conv_bn_pairs(model)
    order = _order(model, pairs, wrap, shape)
    if len(got) != len(order):
        raise ValueError("%s: %d convolutions, the model has %d: another architecture?" % (
            onnx_path, len(got), len(order)))
    with torch.no_grad():
        for (w, b), k in zip(got, order):
            conv, bn = pairs[k]
            if tuple(w.shape) != tuple(conv.weight.shape):
                raise ValueError("%s: a convolution of shape %s where the model has %s: another architecture?" % (
                    onnx_path, tuple(w.shape), tuple(conv.weight.shape)))
            conv.weight.copy_(torch.from_numpy(np.array(w)))
            bias = np.array(b) if b is not None else np.zeros(w.shape[0], np.float32)
            if conv.bias is not None:
                conv.bias.copy_(torch.from_numpy(bias))
                if bn is not None:
                    _identity_bn(bn, np.zeros(bn.num_features, np.float32))
            elif bn is not None:
                _identity_bn(bn, bias)
            elif b is not None and np.any(b != 0):
                raise ValueError("%s: a biased convolution where the model's has no bias" % onnx_path)
    return model


def freeze_batchnorm(model):
    """Puts every BatchNorm in evaluation mode (running statistics used and
    kept); call after model.train()."""
    for m in model.modules():
        if isinstance(m, torch.nn.modules.batchnorm._BatchNorm):
            m.eval()
