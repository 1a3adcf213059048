"""Trains the pose prior: a Gaussian mixture over the body model's joint
angles (docs/TRACKER.md, "Pose prior"), from mocap-prior-fit's poses.

    /usr/bin/python3 tools/prior/train_prior.py build/prior/poses.txt \
        --out config/models/pose_prior.json

Left out: the neck's dofs (the torso's turn against the head: the fit solves
the root's placement with them, so they carry nothing), and the wrists' and
the forearms' twist (elbow .y), which no joint position fixes.  The prior
holds the spine and the limbs.  Frames whose
fit is poor (RMS over --max-rms) are dropped.

Validation is held out by actor and motion together: CMU subjects 135
(karate), 94 (Indian dance) and 16 (walks, runs) are fitted on nothing.  The
component count is chosen on that validation's mean negative log-likelihood;
the prior that ships is then refitted on every clip with that count.
Deterministic: numpy's generator with --seed.
"""
import argparse
import json
import math
import sys

import numpy as np

VAL_SUBJECTS = ("135", "94", "16")
SKIP_PREFIXES = ("neck.", "left_wrist.", "right_wrist.", "left_elbow.y", "right_elbow.y")
VAR_FLOOR = math.radians(2.0) ** 2  # no component narrower than 2 degrees


def load(path, max_rms):
    names, rows, subjects = None, [], []
    for line in open(path):
        if line.startswith("# dofs:"):
            names = line.split()[2:]
            continue
        f = line.split()
        if float(f[3]) > max_rms:
            continue
        rows.append([float(v) for v in f[4:]])
        subjects.append(f[0].split("/")[1].split("_")[0])
    if names is None:
        sys.exit("%s: no '# dofs:' line" % path)
    return names, np.array(rows), np.array(subjects)


def log_gauss(X, mu, L):
    """log N(x; mu, P^-1) for P = L L^T, for each row of X."""
    z = (X - mu) @ L
    d = X.shape[1]
    return np.sum(np.log(np.diag(L))) - 0.5 * d * math.log(2 * math.pi) - 0.5 * np.sum(z * z, 1)


def precision_chol(cov):
    """Lower-triangular L with L L^T = cov^-1."""
    P = np.linalg.inv(cov + VAR_FLOOR * np.eye(len(cov)))
    return np.linalg.cholesky(P)


def component_logs(X, w, mus, Ls):
    return np.stack([math.log(wk) + log_gauss(X, m, L) for wk, m, L in zip(w, mus, Ls)], 1)


def logsumexp(a):
    m = a.max(1, keepdims=True)
    return (m + np.log(np.exp(a - m).sum(1, keepdims=True)))[:, 0]


def fit_gmm(X, k, rng, iters=150):
    n, d = X.shape
    mus = X[rng.choice(n, k, replace=False)]
    for _ in range(10):  # k-means starts
        lab = np.argmin(((X[:, None, :] - mus[None]) ** 2).sum(-1), 1)
        mus = np.stack([X[lab == c].mean(0) if np.any(lab == c) else mus[c] for c in range(k)])
    w = np.full(k, 1.0 / k)
    Ls = [precision_chol(np.cov(X.T)) for _ in range(k)]
    last = -np.inf
    for _ in range(iters):
        a = component_logs(X, w, mus, Ls)
        ll = logsumexp(a)
        r = np.exp(a - ll[:, None])
        nk = r.sum(0) + 1e-9
        w = nk / n
        mus = (r.T @ X) / nk[:, None]
        Ls = []
        for c in range(k):
            D = X - mus[c]
            Ls.append(precision_chol((r[:, c, None] * D).T @ D / nk[c]))
        if ll.mean() - last < 1e-5:
            break
        last = ll.mean()
    return w, mus, Ls


def nll(X, g):
    return float(-logsumexp(component_logs(X, *g)).mean())


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("poses")
    ap.add_argument("--out", required=True)
    ap.add_argument("--components", default="4,8,16")
    ap.add_argument("--max-rms", type=float, default=0.06)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    names, P, subj = load(a.poses, a.max_rms)
    keep = [i for i, nm in enumerate(names) if not nm.startswith(SKIP_PREFIXES)]
    X = P[:, keep]
    val = np.isin(subj, VAL_SUBJECTS)
    print("poses: %d (%d held out: subjects %s), dofs: %d" % (len(X), val.sum(), ",".join(VAL_SUBJECTS), len(keep)))
    best = None
    for k in [int(c) for c in a.components.split(",")]:
        g = fit_gmm(X[~val], k, np.random.default_rng(a.seed))
        tr, va = nll(X[~val], g), nll(X[val], g)
        print("components %2d: mean NLL train %.2f, held out %.2f" % (k, tr, va))
        if best is None or va < best[1]:
            best = (k, va, tr)
    k = best[0]
    w, mus, Ls = fit_gmm(X, k, np.random.default_rng(a.seed))
    out = {
        "format": "mocapd pose prior 1",
        "note": "Gaussian mixture over joint angles (radians) of config/models/default.json; "
                "tools/prior/train_prior.py, docs/TRACKER.md 'Pose prior'",
        "trained_on": "shared/data/mocap-train (60 CMU clips, mirrored), fitted by mocap-prior-fit",
        "seed": a.seed,
        "validation": {"held_out_subjects": list(VAL_SUBJECTS), "components": k,
                       "nll_train": round(best[2], 3), "nll_held_out": round(best[1], 3)},
        "dofs": [names[i] for i in keep],
        "components": [{"weight": float(wk), "mean": [round(float(v), 6) for v in m],
                        "precision_chol": [[round(float(v), 6) for v in row[: i + 1]] for i, row in enumerate(L)]}
                       for wk, m, L in zip(w, mus, Ls)],
    }
    with open(a.out, "w") as f:
        json.dump(out, f, indent=1)
        f.write("\n")
    print("wrote %s: %d components over %d dofs" % (a.out, k, len(keep)))


if __name__ == "__main__":
    main()
