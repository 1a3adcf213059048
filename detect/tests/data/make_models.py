#!/usr/bin/python3
"""Writes the small ONNX models the detector tests use (Debian's torch 1.13;
run with /usr/bin/python3).  The committed outputs are what CI uses (CI has
no torch); run this again only to change them:

    /usr/bin/python3 detect/tests/data/make_models.py detect/tests/data
    /usr/bin/python3 detect/tests/data/make_models.py --standin build/detect

  bad_input.onnx     input 1x1x96x96 (one channel, wrong size), output
                     1x18x32x32: the runtime must refuse it for its input.
  bad_channels.onnx  input 1x3x128x128, output 1x17x32x32 (17 heatmaps, not
                     18): refused for its output channels.
  bad_rank.onnx      input 1x3x128x128, output 1x18432 (the heatmaps
                     flattened): refused for its output rank.
  fixed_wrist.onnx   input 1x3x128x128, output 1x18x32x32 that ignores the
                     image: every heatmap is 0 except right_wrist (channel 13),
                     which peaks at cell (X, Y) below.  The mocap-detect end
                     to end test uses it as a detector whose answer is known.
  --standin DIR      DIR/standin_ego.onnx: a random ~35k-parameter heatmap
                     network of the shipped model's shape (1x18x32x32, sigmoid),
                     for development and the benchmark before the real model
                     lands (not committed).
"""
import json
import os
import sys

import torch
import torch.nn as nn

torch.manual_seed(1)

# right_wrist's peak in fixed_wrist.onnx, heatmap cells (32x32); for a
# 256x256 view that is native pixel 8 * x + 3.5: (139.5, 75.5), up and to the
# right of the demo clip's right wrist.
WRIST_X, WRIST_Y = 17, 9


def export(model, shape, path):
    model.eval()
    x = torch.zeros(*shape)
    torch.onnx.export(model, x, path, opset_version=11, input_names=['image'], output_names=['heatmaps'])
    print(path, os.path.getsize(path), 'bytes')


class Tiny(nn.Module):
    def __init__(self, cin, cout):
        super().__init__()
        self.conv = nn.Conv2d(cin, cout, 4, stride=4)

    def forward(self, x):
        return torch.sigmoid(self.conv(x))


class Flat(Tiny):
    def forward(self, x):
        return torch.flatten(torch.sigmoid(self.conv(x)), 1)


class Fixed(nn.Module):
    def __init__(self):
        super().__init__()
        self.conv = nn.Conv2d(3, 18, 4, stride=4)
        nn.init.zeros_(self.conv.weight)
        nn.init.zeros_(self.conv.bias)
        c = torch.zeros(1, 18, 32, 32)
        c[0, 13, WRIST_Y, WRIST_X] = 0.9
        for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)):
            c[0, 13, WRIST_Y + dy, WRIST_X + dx] = 0.2
        self.register_buffer('c', c)

    def forward(self, x):
        return self.conv(x) + self.c


class Standin(nn.Module):
    def __init__(self):
        super().__init__()
        def block(a, b, s):
            return [nn.Conv2d(a, b, 3, stride=s, padding=1), nn.ReLU()]
        self.net = nn.Sequential(*block(3, 16, 2), *block(16, 32, 2), *block(32, 48, 1),
                                 *block(48, 48, 1), nn.Conv2d(48, 18, 1), nn.Sigmoid())

    def forward(self, x):
        return self.net(x)


def main():
    if len(sys.argv) == 3 and sys.argv[1] == '--standin':
        os.makedirs(sys.argv[2], exist_ok=True)
        m = Standin()
        print('stand-in parameters:', sum(p.numel() for p in m.parameters()))
        path = os.path.join(sys.argv[2], 'standin_ego.onnx')
        export(m, (1, 3, 128, 128), path)
        return
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.dirname(os.path.abspath(__file__))
    export(Tiny(1, 18), (1, 1, 96, 96), os.path.join(out, 'bad_input.onnx'))
    export(Tiny(3, 17), (1, 3, 128, 128), os.path.join(out, 'bad_channels.onnx'))
    export(Flat(3, 18), (1, 3, 128, 128), os.path.join(out, 'bad_rank.onnx'))
    export(Fixed(), (1, 3, 128, 128), os.path.join(out, 'fixed_wrist.onnx'))


if __name__ == '__main__':
    main()
