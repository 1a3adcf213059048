"""Appearance augmentation for the head rig's detector (train.py --aug-look).

The held-out evaluation clips (tools/synth/eval_clips.sh) showed the
detector's 2D error doubling on looks it never saw: bare skin arms, a heavy
build, a washed-out or lamp-lit room (docs/BENCHMARKS.md, "Held-out clips").
train.py's own photometric augmentation (gain, contrast, saturation, channel
swap) keeps an image's colours in their order and its contrast near the
render's.  This module adds what those looks change:

- hue rotated about the grey axis by any angle (garments and skin of any
  colour: a limb is a limb by its shape, not its colour);
- grey images (colour gives nothing);
- gamma and haze (a washed-out, low-contrast scene, or a dark one);
- blur (a soft lens, motion);
- cut-out rectangles of noise or a flat colour (things in front of the
  body; the network has to place a joint from the limb's other parts).

Each is drawn per image with its own probability from the training's random
generator (numpy), so a resumed run continues the same sequence.  A stereo
pair's two views get the same colour draws (one camera model) but their own
cut-outs.
"""
import math

import numpy as np
import torch
import torch.nn.functional as Fn

P_HUE, P_GREY, P_GAMMA, P_HAZE, P_BLUR, P_CUT = 0.5, 0.15, 0.5, 0.3, 0.25, 0.4


def hue_matrices(angles):
    """(B,) angles -> (B,3,3) rotations of RGB about the grey axis (1,1,1)."""
    k = torch.full((3,), 1.0 / math.sqrt(3.0), dtype=angles.dtype)
    K = torch.tensor([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]], dtype=angles.dtype)
    eye = torch.eye(3, dtype=angles.dtype)
    s, c = torch.sin(angles).view(-1, 1, 1), torch.cos(angles).view(-1, 1, 1)
    return eye + s * K + (1 - c) * (K @ K)


def blur3(x, sigma):
    """x (N,3,H,W) blurred by a separable Gaussian of per-image sigma (N,) px."""
    r = 3
    t = torch.arange(-r, r + 1, dtype=x.dtype, device=x.device)
    w = torch.exp(-t.view(1, -1) ** 2 / (2 * sigma.view(-1, 1) ** 2))
    w = w / w.sum(1, keepdim=True)                      # (N, 7)
    N, Cc, H, W = x.shape
    y = x.reshape(1, N * Cc, H, W)
    wk = w.repeat_interleave(Cc, 0)                     # (N*3, 7)
    y = Fn.conv2d(Fn.pad(y, (r, r, 0, 0), mode="replicate"), wk.view(N * Cc, 1, 1, -1), groups=N * Cc)
    y = Fn.conv2d(Fn.pad(y, (0, 0, r, r), mode="replicate"), wk.view(N * Cc, 1, -1, 1), groups=N * Cc)
    return y.view(N, Cc, H, W)


def cut_out(x, rng):
    """Up to three rectangles of 8-32 px per view, each noise or a flat colour."""
    B, V, _, H, W = x.shape
    for b in np.nonzero(rng.random(B) < P_CUT)[0]:
        for v in range(V):
            for _ in range(int(rng.integers(1, 4))):
                h, w = min(H, int(rng.integers(8, 33))), min(W, int(rng.integers(8, 33)))
                y0, x0 = int(rng.integers(0, H - h + 1)), int(rng.integers(0, W - w + 1))
                if rng.random() < 0.5:
                    patch = torch.from_numpy(rng.random((3, h, w))).float().to(x.device)
                else:
                    patch = torch.from_numpy(rng.random((3, 1, 1))).float().to(x.device).expand(3, h, w)
                x[b, v, :, y0:y0 + h, x0:x0 + w] = patch
    return x


def augment_look(x, rng):
    """x (B,V,3,H,W) in [0,1] (V views of one frame) -> the same, new looks."""
    B = x.shape[0]
    dev = x.device

    def per_image(p, lo, hi, neutral):
        """(B,1,1,1,1) draws in [lo,hi) where a coin of probability p says so."""
        on = rng.random(B) < p
        val = np.where(on, rng.uniform(lo, hi, B), neutral)
        return torch.from_numpy(val).float().to(dev).view(B, 1, 1, 1, 1), on

    ang, on = per_image(P_HUE, -math.pi, math.pi, 0.0)
    if on.any():
        R = hue_matrices(ang.view(B).cpu()).to(dev)        # (B,3,3)
        x = torch.einsum("bij,bvjhw->bvihw", R, x)
    grey = torch.from_numpy(rng.random(B) < P_GREY).to(dev).view(B, 1, 1, 1, 1)
    x = torch.where(grey, x.mean(2, keepdim=True).expand_as(x), x)
    x = x.clamp(0, 1)
    gamma, _ = per_image(P_GAMMA, math.log(0.6), math.log(1.5), 0.0)
    x = x.clamp_min(1e-4) ** torch.exp(gamma)
    haze, _ = per_image(P_HAZE, 0.1, 0.45, 0.0)
    level, _ = per_image(1.0, 0.3, 1.0, 0.0)
    x = x * (1 - haze) + level * haze
    sigma, on = per_image(P_BLUR, 0.6, 1.4, 0.0)
    if on.any():
        sel = torch.from_numpy(on).to(dev)
        xs = x[sel]
        n, V = xs.shape[0], xs.shape[1]
        s = sigma.view(B)[sel].repeat_interleave(V)
        x[sel] = blur3(xs.reshape(n * V, 3, xs.shape[-2], xs.shape[-1]), s).view_as(xs)
    return cut_out(x, rng).clamp(0, 1)
