"""The end of `make demo` (daemon/demo.sh): a short table and the overlay page.

usage: demo_summary.py OUT_DIR GT_JSON

Reads OUT_DIR/frames.txt (mocapd --print: "frame N t=SECONDS STATE ...
name=(x,y,z) ..."), OUT_DIR/mocapd.log (its status and totals lines) and
the clip's ground truth; prints the table and writes OUT_DIR/overlays.html
with the overlays (OUT_DIR/overlay_NNNNN_CAM_overlay.png) and their legend.
Standard library only."""
import glob
import html
import json
import os
import re
import sys

# The project's target and what the tracker reaches on the whole walk clip
# this one is cut from (README.md, "Status"): the yardstick for the error.
TARGET_CM = 6.0
WALK_CLIP_CM = 11.6
EVALUATED = ["neck"] + [s + j for s in ("left_", "right_")
                        for j in ("shoulder", "elbow", "wrist", "hip", "knee", "ankle", "toe")]
# the colours of core/image/mc_draw.c
LEGEND = [("#ff4040", "tracked, left side"), ("#40a0ff", "tracked, right side"),
          ("#ffe640", "tracked, spine and head"), ("#40ff60", "ground truth (the clip's)")]


def frame_errors(frames_txt, gt):
    """Per tracked clip frame, the mean joint error in cm; and the count."""
    fps, frames = gt.get("fps", 30), gt["frames"]
    per_frame, tracked = {}, 0
    for line in open(frames_txt):
        m = re.match(r"frame \d+ t=([\d.]+) (\w+) ", line)
        if not m or "(not tracked)" in line:
            continue
        tracked += 1
        k = round(float(m.group(1)) * fps)
        if k >= len(frames):
            continue
        truth, errs = frames[k]["joints_left_cam"], []
        for name in EVALUATED:
            j = re.search(r" %s=\(([-\d.]+),([-\d.]+),([-\d.]+)\)" % name, line)
            if j and name in truth:
                errs.append(sum((float(a) - b) ** 2 for a, b in zip(j.groups(), truth[name])) ** 0.5)
        if errs:
            per_frame[k] = 100 * sum(errs) / len(errs)
    return per_frame, tracked


def log_figures(log):
    """The mean tracking rate and time per frame set over the status lines
    that tracked, and the totals line's latency."""
    rates, times, p50, p99 = [], [], None, None
    for line in open(log):
        m = re.search(r"status: tracking ([\d.]+) fps, ([\d.]+) ms", line)
        if m and float(m.group(1)) > 0:
            rates.append(float(m.group(1)))
            times.append(float(m.group(2)))
        m = re.search(r"capture to publish ([\d.]+) ms p50, ([\d.]+) ms p99", line)
        if m:
            p50, p99 = float(m.group(1)), float(m.group(2))
    mean = lambda v: sum(v) / len(v) if v else None
    return mean(rates), mean(times), p50, p99


def write_page(out, per_frame):
    pngs = sorted(glob.glob(os.path.join(out, "overlay_*_overlay.png")))
    by_frame = {}
    for p in pngs:
        m = re.match(r"overlay_(\d+)_(\w+)_overlay\.png", os.path.basename(p))
        if m:
            by_frame.setdefault(int(m.group(1)), []).append((m.group(2), os.path.basename(p)))
    legend = "".join('<span style="color:%s">&#9632;</span> %s &nbsp; ' % (c, html.escape(t)) for c, t in LEGEND)
    rows = []
    for k in sorted(by_frame):
        err = " &mdash; mean joint error %.1f cm" % per_frame[k] if k in per_frame else ""
        imgs = "".join('<figure><img src="%s"><figcaption>%s camera</figcaption></figure>' % (f, c)
                       for c, f in sorted(by_frame[k]))
        rows.append("<h2>clip frame %d%s</h2><div class=row>%s</div>" % (k, err, imgs))
    page = ("<!doctype html><meta charset=utf-8><title>mocapd demo overlays</title>"
            "<style>body{font-family:sans-serif;background:#222;color:#eee}.row{display:flex;gap:1em}"
            "figure{margin:0}img{image-rendering:pixelated}</style>"
            "<h1>mocapd demo: tracked skeleton over the camera images</h1><p>%s</p>%s" % (legend, "".join(rows)))
    path = os.path.join(out, "overlays.html")
    with open(path, "w") as f:
        f.write(page)
    return path, len(by_frame), len(pngs)


def main():
    out, gt_path = sys.argv[1], sys.argv[2]
    gt = json.load(open(gt_path))
    n = len(gt["frames"])
    per_frame, tracked = frame_errors(os.path.join(out, "frames.txt"), gt)
    rate, ms, p50, p99 = log_figures(os.path.join(out, "mocapd.log"))
    page, nframes, npngs = write_page(out, per_frame)
    rows = [("frame sets tracked", "%d of %d" % (tracked, n),
             "%d skipped: the tracker was slower than the cameras" % max(n - tracked, 0))]
    if per_frame:
        mean = sum(per_frame.values()) / len(per_frame)
        rows.append(("mean joint error", "%.1f cm" % mean,
                     "target %g cm; the whole walk clip: %g cm (README, Status)" % (TARGET_CM, WALK_CLIP_CM)))
    if rate:
        rows.append(("tracking rate", "%.1f fps" % rate, "the clip plays at %g fps; %.1f ms per frame set"
                     % (gt.get("fps", 30), ms)))
    if p50 is not None:
        rows.append(("capture to publish", "%.1f ms" % p50, "median; p99 %.1f ms" % p99))
    rows.append(("overlays", "%d images" % npngs, "%d frames, 3x, with a legend: %s" % (nframes, page)))
    print("== summary")
    for name, value, note in rows:
        print("  %-20s %-13s %s" % (name, value, note))


if __name__ == "__main__":
    main()
