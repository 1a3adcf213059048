#!/usr/bin/python3
"""Train, export and evaluate the 2D joint detector (docs/DETECTOR.md).

    /usr/bin/python3 tools/train/train.py --data build/detector/data --resume       # train
    /usr/bin/python3 tools/train/train.py --export config/models/ego_detector.onnx  # export
    /usr/bin/python3 tools/train/train.py --report                                  # 2D report
    /usr/bin/python3 tools/train/train.py --kind outside --resume                   # outside-in model

Checkpoints go to --ckpt (build/detector/ckpt.pt) every --ckpt-minutes and at
each epoch end; --resume continues from there (model, optimiser, epoch and
step, RNG).  An "epoch" is a fixed number of steps (--steps-per-epoch), and the
label files are re-read at each epoch start, so training can start while the
renderer is still adding frames.  Validation uses the generator's held-out
motion segments (split "val").  The evaluation clips' gt.json is read only by
--report, never for training or model selection.
"""
import argparse
import glob
import json
import math
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)
import common as C  # noqa: E402  (C.IN_W, C.IN_H, C.HM_W, C.HM_H: set by C.set_kind)
from common import EVALUATED, GROUPS, JOINTS, THRESHOLD, build_model, decode, load_rig, project  # noqa

import torch  # noqa: E402
import torch.nn.functional as Fn  # noqa: E402
import onnx_import as I  # noqa: E402
from augment_look import augment_look  # noqa: E402

# geometric augmentation per kind: roll (rad), zoom range, shift (input px)
AUG = {"ego": (0.2, (0.92, 1.08), 3.0), "outside": (0.2, (0.8, 1.2), 8.0)}


def log(*a):
    print(*a, file=sys.stderr, flush=True)


# ------------------------------------------------------------------ data
class Data:
    """All views of a split, images cached as uint8 in memory.  root: one
    data folder, or several joined by commas (v2 and v3 trained together);
    a view's key is (id, camera) in the first folder and ("K:id", camera)
    in the K-th (from 0), since each folder numbers its own frames."""

    def __init__(self, root, split):
        self.root, self.split = root, split
        self.roots = [r for r in root.split(",") if r]
        self.keys, self.uv, self.st = [], [], []
        self.img = np.zeros((0, C.IN_H, C.IN_W, 3), np.uint8)
        self.seen = set()
        self.stereo = False   # batch() stacks each view with its partner's (common.STEREO)
        self.partner = np.zeros(0, np.int64)
        self.device = torch.device("cpu")  # where images() keeps its tensor
        self.img_t = None

    def images(self):
        """The cached images as a uint8 NHWC tensor on self.device (on the
        CPU a view of self.img; on a GPU a copy, made again after a refresh)."""
        if self.img_t is None or len(self.img_t) != len(self.img):
            self.img_t = torch.from_numpy(self.img).to(self.device)
        return self.img_t

    def refresh(self):
        from PIL import Image
        new_keys, new_uv, new_st, new_img = [], [], [], []
        for k, fn in ((k, fn) for k, root in enumerate(self.roots)
                      for fn in sorted(glob.glob(os.path.join(root, "labels*.jsonl")))):
            for line in open(fn):
                try:
                    r = json.loads(line)
                except ValueError:
                    continue  # partial last line of a running renderer
                if r["split"] != self.split:
                    continue
                for cam, v in r["views"].items():
                    key = (r["id"] if k == 0 else "%d:%s" % (k, r["id"]), cam)
                    if key in self.seen:
                        continue
                    path = os.path.join(self.roots[k], r["images"][cam])
                    uv = v["uv"]
                    try:
                        im = Image.open(path).convert("RGB")
                        if im.size != (C.IN_W, C.IN_H):
                            w0, h0 = im.size
                            im = im.resize((C.IN_W, C.IN_H), Image.BILINEAR)
                            uv = [[(a + 0.5) * C.IN_W / w0 - 0.5, (b + 0.5) * C.IN_H / h0 - 0.5] for a, b in uv]
                        a = np.asarray(im)
                    except OSError:
                        continue
                    self.seen.add(key)
                    new_keys.append(key)
                    new_uv.append(uv)
                    new_st.append(v["state"])
                    new_img.append(a)
        if new_keys:
            self.keys += new_keys
            self.uv = np.concatenate([np.asarray(self.uv).reshape(-1, len(JOINTS), 2), np.array(new_uv)], 0)
            self.st = np.concatenate([np.asarray(self.st, dtype=np.int64).reshape(-1, len(JOINTS)),
                                      np.array(new_st, dtype=np.int64)], 0)
            self.img = np.concatenate([self.img, np.stack(new_img)], 0)
            self.pair_views()
        return len(new_keys)

    def pair_views(self):
        """partner[i]: the other camera's view of view i's frame (i itself
        when that view is missing)."""
        index = {k: i for i, k in enumerate(self.keys)}
        other = {"left": "right", "right": "left"}
        self.partner = np.array([index.get((f, other.get(cam, cam)), i) for i, (f, cam) in enumerate(self.keys)],
                                np.int64)

    def __len__(self):
        return len(self.keys)


def targets(uv, st):
    """uv (B,J,2) input pixels, st (B,J) states -> (B,J,HM_H,HM_W) Gaussian targets."""
    B, J = st.shape
    W, H = C.HM_W, C.HM_H
    sigma = C.target_sigma()
    xc = (uv[..., 0] + 0.5) * W / C.IN_W - 0.5
    yc = (uv[..., 1] + 0.5) * H / C.IN_H - 0.5
    gxs = torch.arange(W, dtype=torch.float32, device=uv.device)
    gys = torch.arange(H, dtype=torch.float32, device=uv.device)
    gx = torch.exp(-(gxs.view(1, 1, W) - xc.unsqueeze(-1)) ** 2 / (2 * sigma ** 2))
    gy = torch.exp(-(gys.view(1, 1, H) - yc.unsqueeze(-1)) ** 2 / (2 * sigma ** 2))
    peak = torch.where(st == 0, 1.0, torch.where(st == 1, 0.5, 0.0)).float()
    return gy.unsqueeze(-1) * gx.unsqueeze(-2) * peak.view(B, J, 1, 1)


def batch(data, idx, rng, augment, look=False):
    """Images (B,3,H,W) in [0,1], truths uv (B,J,2) and states (B,J) of the
    views idx, augmented or not, on data.device; look: also the looks of
    augment_look.py (--aug-look)."""
    dev = data.device
    x = data.images()[torch.from_numpy(np.asarray(idx)).to(dev)].permute(0, 3, 1, 2).float() / 255.0
    if data.stereo:  # the partner's view as channels 3-5, augmented alike
        pidx = torch.from_numpy(data.partner[np.asarray(idx)]).to(dev)
        x = torch.cat([x, data.images()[pidx].permute(0, 3, 1, 2).float() / 255.0], 1)
    uv = torch.from_numpy(data.uv[idx]).float().to(dev)
    st = torch.from_numpy(data.st[idx]).clone().to(dev)
    B = x.shape[0]
    if augment:
        def draw(a):  # the random draws, as float tensors beside the images
            return torch.from_numpy(np.asarray(a)).float().to(dev)
        # roll about the image centre (a camera roll: consistent with the lens),
        # small zoom and shift
        roll, zoom, shift = AUG[C.KIND]
        ang = draw(rng.uniform(-roll, roll, B))
        sc = draw(rng.uniform(zoom[0], zoom[1], B))
        sh = draw(rng.uniform(-shift, shift, (B, 2)))
        W, H = C.IN_W, C.IN_H
        c = draw([(W - 1) / 2.0, (H - 1) / 2.0])
        ca, sa = torch.cos(ang), torch.sin(ang)
        # output pixel p -> input pixel q = c + R^T (p - c - sh) / sc
        A = torch.zeros(B, 2, 3, device=dev)
        A[:, 0, 0], A[:, 0, 1] = ca / sc, sa / sc
        A[:, 1, 0], A[:, 1, 1] = -sa / sc, ca / sc
        # affine_grid works in normalised coords with align_corners=False: n = (p + 0.5) / W * 2 - 1
        # (H for y), i.e. p - c = D n with D = diag(W/2, H/2): the linear part becomes
        # D^-1 A D (A itself when W == H) and the translation -D^-1 A sh
        t = -(A[:, :, :2] @ sh.unsqueeze(-1)).squeeze(-1)
        if W != H:
            A[:, 0, 1] *= H / W
            A[:, 1, 0] *= W / H
        A[:, 0, 2] = t[:, 0] * 2 / W
        A[:, 1, 2] = t[:, 1] * 2 / H
        grid = Fn.affine_grid(A, x.shape, align_corners=False)
        x = Fn.grid_sample(x, grid, mode="bilinear", padding_mode="zeros", align_corners=False)
        # labels: forward map p = c + sh + sc R (q - c)
        d = uv - c
        R = torch.stack([torch.stack([ca, -sa], -1), torch.stack([sa, ca], -1)], -2)  # (B,2,2)
        uv = c + sh.unsqueeze(1) + sc.view(B, 1, 1) * torch.einsum("bij,bkj->bki", R, d)
        out = (uv < -0.5).any(-1) | (uv[..., 0] > W - 0.5) | (uv[..., 1] > H - 0.5)
        st[out] = 2
        # photometric, per image (B, views, 3, H, W): a stereo pair's two
        # views get the same draws, as one camera model would
        x = x.view(B, -1, 3, x.shape[-2], x.shape[-1])

        def draw5(a):
            return draw(a).unsqueeze(1)
        gain = draw5(rng.uniform(0.7, 1.3, (B, 1, 1, 1)))
        ch = draw5(rng.uniform(0.85, 1.15, (B, 3, 1, 1)))
        mean = x.mean(dim=(2, 3, 4), keepdim=True)
        con = draw5(rng.uniform(0.7, 1.3, (B, 1, 1, 1)))
        gray = x.mean(2, keepdim=True)
        sat = draw5(rng.uniform(0.5, 1.4, (B, 1, 1, 1)))
        x = gray + (x - gray) * sat
        x = ((x - mean) * con + mean) * gain * ch
        x = x + torch.randn_like(x) * draw5(rng.uniform(0, 0.04, (B, 1, 1, 1)))
        perm = rng.random(B) < 0.3  # channel swap: colours of clothes are not a cue
        if perm.any():
            p = rng.permutation(3)
            sel = torch.from_numpy(perm).to(dev)
            x[sel] = x[sel][:, :, torch.from_numpy(p).to(dev)]
        x = x.clamp(0, 1)
        if look:
            x = augment_look(x, rng)
        x = x.view(B, -1, x.shape[-2], x.shape[-1])
    return x, uv, st


# left/right channel pairs: (left index, right index)
PAIRS = [(JOINTS.index("left_" + p), JOINTS.index("right_" + p))
         for p in ("shoulder", "elbow", "wrist", "hip", "knee", "ankle", "toe")]


FEET = [JOINTS.index(s + "_" + j) for s in ("left", "right") for j in ("ankle", "toe")]


def loss_fn(logits, tgt, uv=None, st=None, pair_weight=0.0, feet_weight=1.0):
    """Weighted squared error of the heat maps; with pair_weight > 0 also the
    overlap of a left/right pair's two channels (sum over cells of their
    product) where the two truths are more than 20 input pixels apart: a
    penalty on one limb reported under both labels (issue 36, item 2).
    feet_weight scales the ankles' and toes' channels (the weakest joints)."""
    p = torch.sigmoid(logits)
    w = 1.0 + 30.0 * tgt
    if feet_weight != 1.0:
        jw = torch.ones(len(JOINTS), device=p.device)
        jw[FEET] = feet_weight
        w = w * jw.view(1, -1, 1, 1)
    loss = ((p - tgt) ** 2 * w).mean() * 10.0
    if pair_weight > 0 and uv is not None:
        li, ri = [a for a, _ in PAIRS], [b for _, b in PAIRS]
        overlap = (p[:, li] * p[:, ri]).sum(dim=(2, 3))                      # (B, P)
        apart = (uv[:, li] - uv[:, ri]).norm(dim=-1) > 20.0
        inside = (st[:, li] < 2) & (st[:, ri] < 2)
        mask = (apart & inside).float().to(p.device)
        loss = loss + pair_weight * 10.0 * (overlap * mask).sum() / p.numel()
    return loss


# ------------------------------------------------------------------ metrics
def gross_mask(pred, uv, st):
    """(N,J): detections more than 10 px off, or of joints outside the image."""
    err = np.linalg.norm(pred[..., :2] - uv, axis=-1)
    return (pred[..., 2] >= THRESHOLD) & ((st == 2) | (err > 10))


def score(pred, uv, st):
    """pred (N,J,3) decoded; uv, st ground truth. Returns dict of metrics."""
    det = pred[..., 2] >= THRESHOLD
    err = np.linalg.norm(pred[..., :2] - uv, axis=-1)
    inside = st < 2
    res = {}
    for g, names in GROUPS.items():
        ji = [JOINTS.index(n) for n in names]
        m = det[:, ji] & inside[:, ji]
        e = err[:, ji][m]
        res[g] = (float(np.median(e)) if len(e) else float("nan"),
                  float(np.percentile(e, 90)) if len(e) else float("nan"))
    vis = st == 0
    res["miss_visible"] = float((~det & vis).sum() / max(1, vis.sum()))
    res["miss_occluded"] = float((~det & (st == 1)).sum() / max(1, (st == 1).sum()))
    res["false"] = float(gross_mask(pred, uv, st).sum() / max(1, det.sum()))
    res["false_outside"] = int((det & (st == 2)).sum())
    res["n_detected"] = int(det.sum())
    for name, state in (("median_visible", 0), ("median_occluded", 1)):
        e = err[det & (st == state)]
        res[name] = float(np.median(e)) if len(e) else float("nan")
    res.update(pair_rates(pred, uv, st))
    return res


def pair_rates(pred, uv, st):
    """The left/right figures of tools/bench/keypoint_report.py, on decoded
    detections: of the pairs whose truths (both in the image) are more than
    20 px apart and whose two joints are detected, the share whose
    keypoints lie within 2 px of each other (collapse), and of the rest the
    share closer to the truth with the labels exchanged (swap)."""
    det = pred[..., 2] >= THRESHOLD
    pairs = collapsed = swapped = compared = 0
    for a, b in PAIRS:
        ok = (det[:, a] & det[:, b] & (st[:, a] < 2) & (st[:, b] < 2)
              & (np.linalg.norm(uv[:, a] - uv[:, b], axis=-1) > 20))
        pa, pb, ta, tb = pred[ok, a, :2], pred[ok, b, :2], uv[ok, a], uv[ok, b]
        close = np.linalg.norm(pa - pb, axis=-1) <= 2
        d = lambda x, y: np.linalg.norm(x - y, axis=-1)  # noqa: E731
        exchanged = d(pa, tb) + d(pb, ta) < d(pa, ta) + d(pb, tb)
        pairs += int(ok.sum())
        collapsed += int(close.sum())
        compared += int((~close).sum())
        swapped += int((exchanged & ~close).sum())
    return {"pairs": pairs, "collapse": collapsed / max(1, pairs), "swap": swapped / max(1, compared)}


def predict(model, x, bs=64):
    out = []
    model.eval()
    with torch.no_grad():
        for i in range(0, len(x), bs):
            hm = torch.sigmoid(model(x[i:i + bs]).float()).cpu().numpy()
            out += [decode(h) for h in hm]
    return np.array(out)


def validate(model, val):
    if len(val) == 0:
        return None
    idx = np.arange(len(val))
    x, uv, st = batch(val, idx, None, False)
    pred = predict(model, x, 256)
    r = score(pred, uv.cpu().numpy(), st.cpu().numpy())
    with torch.no_grad():  # in chunks: all views at once took 24 GB with --arch mn
        tot = 0.0
        for i in range(0, len(x), 256):
            tot += float(loss_fn(model(x[i:i + 256]), targets(uv[i:i + 256], st[i:i + 256]))) * len(x[i:i + 256])
        r["loss"] = tot / len(x)
    return r


def fmt(r):
    loss = "loss %.4f  " % r["loss"] if "loss" in r else ""
    return loss + ("torso %.2f/%.2f  arms %.2f/%.2f  legs %.2f/%.2f px (median/p90)  "
            "median visible %.2f occluded %.2f px  missed vis %.1f%% occl %.1f%%  gross %.1f%%  "
            "collapse %.1f%%  swap %.1f%%" % (
                *r["torso"], *r["arms"], *r["legs"], r["median_visible"],
                r["median_occluded"], 100 * r["miss_visible"], 100 * r["miss_occluded"], 100 * r["false"],
                100 * r["collapse"], 100 * r["swap"]))


# ------------------------------------------------------------------ train
def init_weights(model, path, arch):
    """model's weights from a checkpoint or from a shipped ONNX model of
    the same architecture (onnx_import: its BatchNorms are folded away, so
    training must keep them frozen). Returns whether they must be."""
    if not path.endswith(".onnx"):
        model.load_state_dict(torch.load(path, map_location="cpu")["model"])
        return False
    side_path = os.path.splitext(path)[0] + ".json"
    try:
        have = json.load(open(side_path)).get("arch", "v1")
    except (OSError, ValueError) as e:
        sys.exit("--init %s: its sidecar %s, which names its architecture, cannot be read: %s" % (path, side_path, e))
    if have != arch:
        sys.exit("--init %s is a %s network (its sidecar %s says), not --arch %s" % (path, have, side_path, arch))
    try:
        I.load_fused_weights(model, path, Exported, (C.IN_H, C.IN_W))
    except ValueError as e:
        sys.exit("--init: %s" % e)
    return True


def train(a):
    torch.set_num_threads(a.threads)
    dev = torch.device("cuda" if torch.cuda.is_available() else "cpu")
    torch.backends.cudnn.benchmark = dev.type == "cuda"
    amp = a.amp and dev.type == "cuda"  # bfloat16 on a GPU; the loss stays in float32
    torch.manual_seed(a.seed)
    model = build_model(a.arch).to(dev)
    opt = torch.optim.AdamW(model.parameters(), lr=a.lr, weight_decay=1e-4)
    total = a.epochs * a.steps_per_epoch
    state = {"epoch": 0, "step": 0, "best": None, "history": [], "train_s": 0.0}
    rng = np.random.default_rng(a.seed)
    if a.init and not (a.resume and os.path.exists(a.ckpt)):
        state["frozen_bn"] = init_weights(model, a.init, a.arch)
        state["init"] = a.init
        log("initialised from %s%s" % (a.init, " (BatchNorms frozen)" if state["frozen_bn"] else ""))
    if a.resume and os.path.exists(a.ckpt):
        ck = torch.load(a.ckpt, map_location="cpu")
        model.load_state_dict(ck["model"])
        opt.load_state_dict(ck["opt"])
        state = ck["state"]
        rng.bit_generator.state = ck["rng"]
        log("resumed from %s: epoch %d step %d" % (a.ckpt, state["epoch"], state["step"]))
    nparam = sum(p.numel() for p in model.parameters())
    log("model: %d parameters, device %s, %d epochs x %d steps x batch %d" % (
        nparam, dev, a.epochs, a.steps_per_epoch, a.batch))
    tr, va = Data(a.data, "train"), Data(a.data, "val")
    tr.device = va.device = dev
    tr.stereo = va.stereo = a.arch in C.STEREO
    budget = a.minutes * 60 if a.minutes else None

    def progress():
        """Where the learning-rate schedule is: by steps, or by time spent
        when --minutes gives the training a time budget."""
        if budget:
            return min(1.0, (state["train_s"] + time.time() - last_ck) / budget)
        return min(1.0, state["step"] / total)

    def save(path):
        tmp = path + ".tmp"
        torch.save({"model": model.state_dict(), "opt": opt.state_dict(), "state": state,
                    "rng": rng.bit_generator.state, "args": vars(a), "params": nparam}, tmp)
        os.replace(tmp, path)

    last_ck = time.time()
    while state["epoch"] < a.epochs:
        n1, n2 = tr.refresh(), va.refresh()
        log("epoch %d: %d train views (+%d), %d val views (+%d)" % (state["epoch"] + 1, len(tr), n1, len(va), n2))
        if len(tr) < a.batch:
            log("not enough data yet; waiting 60 s")
            time.sleep(60)
            continue
        model.train()
        if state.get("frozen_bn"):
            I.freeze_batchnorm(model)
        t0 = time.time()
        ep_start_step = state["step"] - state["epoch"] * a.steps_per_epoch
        run = 0.0
        for s in range(ep_start_step, a.steps_per_epoch):
            lr = a.lr * 0.5 * (1 + math.cos(math.pi * progress()))
            warm = min(1.0, (state["step"] + 1) / max(1, a.warmup))
            for gp in opt.param_groups:
                gp["lr"] = lr * warm
            idx = rng.integers(0, len(tr), a.batch)
            x, uv, st = batch(tr, idx, rng, True, a.aug_look)
            tgt = targets(uv, st)
            with torch.autocast(dev.type, dtype=torch.bfloat16, enabled=amp):
                logits = model(x)
            loss = loss_fn(logits.float(), tgt, uv, st, a.pair_weight, a.feet_weight)
            opt.zero_grad()
            loss.backward()
            opt.step()
            state["step"] += 1
            run = 0.98 * run + 0.02 * float(loss) if s > ep_start_step else float(loss)
            el = time.time() - t0
            done = s + 1 - ep_start_step
            if done % 10 == 0 or s + 1 == a.steps_per_epoch:
                ips = done * a.batch / el
                left = ((1 - progress()) * budget if budget else (total - state["step"]) * a.batch / ips)
                sys.stderr.write("\r  epoch %d/%d step %d/%d loss %.4f lr %.2e %.0f img/s ETA epoch %.0fs, all %.0f min " % (
                    state["epoch"] + 1, a.epochs, s + 1, a.steps_per_epoch, run, lr * warm, ips,
                    (a.steps_per_epoch - s - 1) * a.batch / ips, left / 60))
                sys.stderr.flush()
            if time.time() - last_ck > a.ckpt_minutes * 60:
                state["train_s"] += time.time() - last_ck
                save(a.ckpt)
                last_ck = time.time()
        sys.stderr.write("\n")
        state["epoch"] += 1
        r = validate(model, va)
        if r is not None:
            log("  val: " + fmt(r))
            state["history"].append({"epoch": state["epoch"], "step": state["step"], "val": r,
                                     "train_views": len(tr)})
            key = r["loss"]
            if state["best"] is None or key < state["best"]:
                state["best"] = key
                torch.save({"model": model.state_dict(), "state": dict(state), "params": nparam, "arch": a.arch},
                           a.best or os.path.join(os.path.dirname(a.ckpt), "best.pt"))
        state["train_s"] += time.time() - last_ck
        last_ck = time.time()
        save(a.ckpt)
        if budget and state["train_s"] >= budget:
            break
    log("training done: %d steps, %.1f min" % (state["step"], state["train_s"] / 60))


# ------------------------------------------------------------------ export / report
class Exported(torch.nn.Module):
    def __init__(self, m):
        super().__init__()
        self.m = m

    def forward(self, image):
        return torch.sigmoid(self.m(image))


def ck_arch(ck):
    """The architecture a checkpoint was trained with (v1 before --arch existed)."""
    return (ck.get("args") or {}).get("arch") or ck.get("arch") or "v1"


class OnnxModel:
    """A shipped ONNX detector through OpenCV DNN, called like the torch
    model (returns logits), so that --report can score a model whose
    checkpoint is gone (the v1 model shipped before issue 36)."""

    def __init__(self, path):
        import cv2
        cv2.setNumThreads(1)
        self.net = cv2.dnn.readNetFromONNX(path)

    def eval(self):
        return self

    def __call__(self, x):
        out = []
        for i in range(len(x)):
            self.net.setInput(x[i:i + 1].numpy(), "image")
            out.append(self.net.forward("heatmaps"))
        p = torch.from_numpy(np.concatenate(out)).clamp(1e-6, 1 - 1e-6)
        return torch.log(p / (1 - p))


def load_model(path):
    """The model at path (a checkpoint or an exported ONNX with its sidecar)
    and its checkpoint dict; sets the heat-map size to the model's."""
    if path.endswith(".onnx"):
        side = json.load(open(os.path.splitext(path)[0] + ".json"))
        C.set_heatmap(*side["heatmap"])
        if C.DECODE_SIGMA is None:  # decoded as the runtime would (0 when the sidecar is silent)
            C.DECODE_SIGMA = side.get("heatmap_sigma", 0)
        return OnnxModel(path), {}
    ck = torch.load(path, map_location="cpu")
    C.set_kind(C.KIND, ck_arch(ck))
    m = build_model(ck_arch(ck))
    m.load_state_dict(ck["model"])
    m.eval()
    return m, ck


def validation_card(r):
    """The headline figures of a checkpoint's validation, for the sidecar."""
    if not r or "median_visible" not in r:
        return None
    return {"gross_pct": round(100 * r["false"], 1), "median_visible_px": round(r["median_visible"], 2),
            "median_occluded_px": round(r["median_occluded"], 2), "collapse_pct": round(100 * r["collapse"], 1),
            "swap_pct": round(100 * r["swap"], 1), "note": "px at 128x128; the held-out split of docs/DETECTOR.md"}


def export(a):
    path = a.weights or a.ckpt
    m, ck = load_model(path)
    if ck and ck_arch(ck) in C.STEREO:
        sys.exit("%s: a stereo network (--arch %s) has no runtime yet: the detector runtime "
                 "feeds one view (docs/DETECTOR_EXPERIMENTS.md, \"Both views at once\")" % (path, ck_arch(ck)))
    if hasattr(m, "trunk"):  # --arch mn: ReLU6 in fewer nodes (pretrained.OnnxTrunk.fold_relu6)
        log("folded %d activations for export" % m.trunk.fold_relu6())
    net = Exported(m).eval()
    I.export_onnx(net, (C.IN_H, C.IN_W), a.export)
    st = ck.get("state", {})
    what = ("synthetic head-mounted stereo fisheye views (tools/synth/render.py --seed %d, " if C.KIND == "ego" else
            "synthetic outside-in pinhole views, 4:3 (tools/synth/render.py --kind outside --seed %d, ")
    side = {"input": [C.IN_H, C.IN_W], "joints": JOINTS, "threshold": THRESHOLD, "heatmap": [C.HM_H, C.HM_W],
            "heatmap_sigma": C.target_sigma(),
            "trained_on": (what +
                           "%s training views) of CMU motions from mocap-train only (mocap/ held out); "
                           "%s: epoch %d, step %d, synthetic validation loss %.4f; see docs/DETECTOR.md") % (
                              a.data_seed, (st.get("history") or [{}])[-1].get("train_views", "?"),
                              os.path.basename(path), st.get("epoch", -1), st.get("step", -1),
                              st.get("best") or float("nan")),
            "seed": a.seed,
            "arch": ck_arch(ck),
            "validation": validation_card((st.get("history") or [{}])[-1].get("val")),
            "parameters": ck.get("params"),
            "input_format": "float32 NCHW 1x3x%dx%d, RGB, [0,1]; output heatmaps float32 1x18x%dx%d in [0,1]" % (
                C.IN_H, C.IN_W, C.HM_H, C.HM_W)}
    if st.get("init"):  # trained further from another model (--init)
        side["started_from"] = "%s (train.py --init)" % st["init"]
    if ck_arch(ck) == "mn":  # the weights it started from, and their terms
        from pretrained import PRETRAINED_CARD
        side.update(PRETRAINED_CARD)
    side_path = os.path.splitext(a.export)[0] + ".json"
    with open(side_path, "w") as f:
        json.dump(side, f, indent=1)
        f.write("\n")
    log("exported %s (%d bytes) and %s" % (a.export, os.path.getsize(a.export), side_path))
    # check: the exported graph through OpenCV DNN if present, on a random view
    x = torch.rand(1, 3, C.IN_H, C.IN_W)
    try:
        import cv2
        cv2.setNumThreads(1)
        net_cv = cv2.dnn.readNetFromONNX(a.export)
        blob = x.numpy()
        net_cv.setInput(blob, "image")
        y = net_cv.forward("heatmaps")
        with torch.no_grad():
            yt = net(x).numpy()
        t = time.time()
        for _ in range(50):
            net_cv.setInput(blob, "image")
            net_cv.forward("heatmaps")
        ms = (time.time() - t) / 50 * 1000
        log("OpenCV %s: output %s, max |cv - torch| = %.2e, %.2f ms per view (1 thread)" % (
            cv2.__version__, y.shape, float(np.abs(y - yt).max()), ms))
    except ImportError:
        log("python3-opencv not installed: OpenCV check skipped")


def per_joint_median_px(pred, uv, st):
    """Per joint, the median pixel error of its detections (confidence at
    least THRESHOLD) of in-image joints (state < 2), or None."""
    det = pred[..., 2] >= THRESHOLD
    err = np.linalg.norm(pred[..., :2] - uv, axis=-1)
    return {j: (round(float(np.median(err[:, i][det[:, i] & (st[:, i] < 2)])), 2)
                if (det[:, i] & (st[:, i] < 2)).any() else None)
            for i, j in enumerate(JOINTS)}


def report(a):
    from PIL import Image
    path = a.weights or a.ckpt
    m, ck = load_model(path)
    stereo = ck_arch(ck) in C.STEREO if ck else False
    torch.set_num_threads(a.threads)
    cams = load_rig(a.rig)
    out = {}
    for clip in sorted(glob.glob(os.path.join(a.ego, "*", "gt.json"))):
        d = os.path.dirname(clip)
        name = os.path.basename(d)
        gt = json.load(open(clip))
        names = gt["joint_names"]
        order = [names.index(j) for j in JOINTS]
        allp, alluv, allst = [], [], []
        views = {cam: [np.asarray(Image.open(os.path.join(d, cam, "%05d.jpg" % k)).convert("RGB")
                                  .resize((C.IN, C.IN), Image.BILINEAR)) for k in range(len(gt["frames"]))]
                 for cam in ("left", "right")}
        for cam, partner in (("left", "right"), ("right", "left")):
            xs, uvs, sts = [], [], []
            for k, fr in enumerate(gt["frames"]):
                P = np.array([fr["joints_left_cam"][n] for n in names])[order]
                u, v, inside = project(cams[cam], P)
                xs.append(np.concatenate([views[cam][k], views[partner][k]], -1) if stereo else views[cam][k])
                uvs.append(np.stack([u, v], -1))
                sts.append(np.where(inside, 0, 2))
            x = torch.from_numpy(np.stack(xs)).permute(0, 3, 1, 2).float() / 255.0
            allp.append(predict(m, x))
            alluv.append(np.stack(uvs))
            allst.append(np.stack(sts))
        pred, uv, st = np.concatenate(allp), np.concatenate(alluv), np.concatenate(allst)
        r = score(pred, uv, st)
        r["per_joint_median_px"] = per_joint_median_px(pred, uv, st)
        r["views"] = int(len(pred))
        r["in_image"] = int((st < 2).sum())
        out[name] = r
        log("%s (%d views): %s (%d outside)" % (name, len(pred), fmt(r), r["false_outside"]))
    if all(os.path.isdir(d) for d in a.data.split(",")):
        va = Data(a.data, "val")
        va.stereo = stereo
        if va.refresh():
            r = validate(m, va)
            out["validation"] = dict(r, views=len(va), data=a.data)
            log("validation %s (%d views): %s" % (a.data, len(va), fmt(r)))
    if a.report_out:
        with open(a.report_out, "w") as f:
            json.dump(out, f, indent=1)
    return out


def project_pinhole_cv(cam, P_w):
    """OpenCV pinhole (with k1 k2 p1 p2 k3) of world points -> u, v, z (native pixels)."""
    T = np.array(cam["world_to_camera"], dtype=float)
    P = P_w @ T[:3, :3].T + T[:3, 3]
    z = P[:, 2]
    zs = np.where(np.abs(z) > 1e-9, z, 1e-9)
    x, y = P[:, 0] / zs, P[:, 1] / zs
    k = list(cam.get("dist") or []) + [0.0] * 5
    k1, k2, p1, p2, k3 = k[:5]
    r2 = x * x + y * y
    rad = 1 + k1 * r2 + k2 * r2 ** 2 + k3 * r2 ** 3
    xd = x * rad + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * rad + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return cam["fx"] * xd + cam["cx"], cam["fy"] * yd + cam["cy"], z


def report_outside(a):
    """2D report on ../shared/data/outside/<clip>: every camera's frames
    resized to the network input as the C runtime does it (OpenCV's
    INTER_AREA; PIL's BOX filter, close to it, without python3-opencv),
    truth = gt.json joints_world through cameras.json."""
    from PIL import Image
    try:
        import cv2
        cv2.setNumThreads(1)

        def shrink(im):
            return cv2.resize(np.asarray(im), (C.IN_W, C.IN_H), interpolation=cv2.INTER_AREA)
        how = "OpenCV INTER_AREA"
    except ImportError:
        def shrink(im):
            return np.asarray(im.resize((C.IN_W, C.IN_H), Image.BOX))
        how = "PIL BOX (python3-opencv not installed)"
    log("resize: %s" % how)
    path = a.weights or a.ckpt
    m, ck = load_model(path)
    torch.set_num_threads(a.threads)
    out = {}
    for clip in sorted(glob.glob(os.path.join(a.outside, "*", "gt.json"))):
        d = os.path.dirname(clip)
        name = os.path.basename(d)
        gt = json.load(open(clip))
        cams = json.load(open(os.path.join(d, "cameras.json")))["cameras"]
        names = gt["joint_names"]
        order = [names.index(j) for j in JOINTS]
        allp, alluv, allst, scale = [], [], [], []
        for K, cam in enumerate(cams):
            w, h = cam["width"], cam["height"]
            sx, sy = C.IN_W / w, C.IN_H / h
            xs, uvs, sts = [], [], []
            for k, fr in enumerate(gt["frames"]):
                P = np.array([fr["joints_world"][n] for n in names])[order]
                u, v, z = project_pinhole_cv(cam, P)
                inside = (z > 0.05) & (u >= -0.5) & (u <= w - 0.5) & (v >= -0.5) & (v <= h - 0.5)
                im = Image.open(os.path.join(d, "cam%d" % K, "%05d.jpg" % k)).convert("RGB")
                xs.append(shrink(im) if im.size != (C.IN_W, C.IN_H) else np.asarray(im))
                uvs.append(np.stack([(u + 0.5) * sx - 0.5, (v + 0.5) * sy - 0.5], -1))
                sts.append(np.where(inside, 0, 2))
            x = torch.from_numpy(np.stack(xs)).permute(0, 3, 1, 2).float() / 255.0
            allp.append(predict(m, x))
            alluv.append(np.stack(uvs))
            allst.append(np.stack(sts))
            scale.append(w / C.IN_W)
        pred, uv, st = np.concatenate(allp), np.concatenate(alluv), np.concatenate(allst)
        r = score(pred, uv, st)
        r["per_joint_median_px"] = per_joint_median_px(pred, uv, st)
        r["per_camera"] = {}
        n = len(gt["frames"])
        for K in range(len(cams)):
            sl = slice(K * n, (K + 1) * n)
            rc = score(pred[sl], uv[sl], st[sl])
            r["per_camera"]["cam%d" % K] = {g: rc[g] for g in GROUPS}
            r["per_camera"]["cam%d" % K]["missed"] = rc["miss_visible"]
        r["native_scale"] = scale[0]
        r["views"] = int(len(pred))
        r["in_image"] = int((st < 2).sum())
        r["input"] = [C.IN_W, C.IN_H]
        r["resize"] = how
        out[name] = r
        f = scale[0]
        log("%s (%d views, %dx%d input): torso %.2f/%.2f  arms %.2f/%.2f  legs %.2f/%.2f px (median/p90, input px; "
            "x%.2f for %dx%d); missed %.1f%% of in-image joints; false %.1f%% of detections (%d outside)" % (
                name, len(pred), C.IN_W, C.IN_H, *r["torso"], *r["arms"], *r["legs"], f, cams[0]["width"],
                cams[0]["height"], 100 * r["miss_visible"], 100 * r["false"], r["false_outside"]))
    if a.report_out:
        with open(a.report_out, "w") as fo:
            json.dump(out, fo, indent=1)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--kind", choices=("ego", "outside"), default="ego",
                    help="ego: 128x128 head-mounted fisheye views (default); outside: 192x144 outside-in "
                         "pinhole views (defaults under build/detector/outside/)")
    ap.add_argument("--data", default=None, help="default build/detector/data (outside: build/detector/outside/data); "
                    "several folders joined by commas are trained on together")
    ap.add_argument("--ckpt", default=None, help="default build/detector/ckpt.pt (outside: build/detector/outside/ckpt.pt)")
    ap.add_argument("--weights", help="checkpoint for --export/--report (default --ckpt)")
    ap.add_argument("--best", help="where training keeps its best epoch (default best.pt beside --ckpt)")
    ap.add_argument("--resume", action="store_true")
    ap.add_argument("--init", help="start from these weights (a ckpt.pt/best.pt, or a shipped MODEL.onnx of the "
                    "same --arch: its BatchNorms stay frozen), new optimiser and schedule")
    ap.add_argument("--warmup", type=int, default=200, help="warm-up steps")
    ap.add_argument("--arch", choices=C.ARCHS, default="v1", help="network (common.build_model)")
    ap.add_argument("--pair-weight", type=float, default=0.0,
                    help="weight of the left/right overlap penalty (0: off; see loss_fn)")
    ap.add_argument("--feet-weight", type=float, default=1.0,
                    help="weight of the ankles' and toes' heat maps in the training loss (not in validation's)")
    ap.add_argument("--aug-look", action="store_true",
                    help="also hue, grey, gamma, haze, blur and cut-out augmentation (augment_look.py)")
    ap.add_argument("--epochs", type=int, default=30)
    ap.add_argument("--steps-per-epoch", type=int, default=250)
    ap.add_argument("--batch", type=int, default=32)
    ap.add_argument("--lr", type=float, default=3e-3)
    ap.add_argument("--seed", type=int, default=1, help="training seed (init, sampling, augmentation)")
    ap.add_argument("--data-seed", type=int, default=1, help="the renderer's --seed, for the sidecar")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--minutes", type=float, default=0,
                    help="time budget: the learning rate follows the time spent, and training ends after the "
                         "epoch that reaches it (0: --epochs decide)")
    ap.add_argument("--amp", action="store_true", help="on a GPU, the network in bfloat16 (autocast)")
    ap.add_argument("--ckpt-minutes", type=float, default=3.0)
    ap.add_argument("--export", metavar="ONNX")
    ap.add_argument("--report", action="store_true")
    ap.add_argument("--decode-sigma", type=float, default=None,
                    help="--report: decode with this smoothing (cells; 0 = the 3x3 centroid) instead of the "
                         "model's (its sidecar heatmap_sigma, or the training targets' sigma)")
    ap.add_argument("--report-out", default=None,
                    help="default build/detector/report.json (outside: build/detector/outside/report.json)")
    ap.add_argument("--rig", default=os.path.join(ROOT, "config/rigs/ego_stereo.json"))
    ap.add_argument("--ego", default="/work/shared/data/ego")
    ap.add_argument("--outside", default="/work/shared/data/outside", help="outside-in clips for --report")
    a = ap.parse_args()
    C.set_kind(a.kind, a.arch)
    C.DECODE_SIGMA = a.decode_sigma
    sub = "build/detector" if a.kind == "ego" else "build/detector/outside"
    a.data = a.data or os.path.join(ROOT, sub, "data")
    a.ckpt = a.ckpt or os.path.join(ROOT, sub, "ckpt.pt")
    a.report_out = a.report_out or os.path.join(ROOT, sub, "report.json")
    os.makedirs(os.path.dirname(a.ckpt), exist_ok=True)
    if a.export or a.report:
        if a.export:
            export(a)
        if a.report:
            report(a) if a.kind == "ego" else report_outside(a)
        return
    train(a)


if __name__ == "__main__":
    main()
