"""A long, resumable render job for the v2 detector data (docs/DETECTOR.md,
"v2 data"): `make detector-data-v2` runs

    python3 tools/synth/job.py --out build/detector/v2 --train 55200 --val 6000

It plans the ids in chunks (training ids 0 .. TRAIN-1 rendered with
`--split train`, validation ids VAL_FIRST .. VAL_FIRST+VAL-1 with
`--split val`), orders them so that validation chunks are spread over the
run (the first chunk is a validation chunk, so a trainer started early has
a validation set), and keeps --shards Blender processes busy, one chunk each
(one Blender process per chunk: Blender grows by about 2 MB per stereo pair).

Checkpoints: every stereo pair is one label line, written after both of its
images (render.py); a rerun of the same command skips the pairs that have a
line, and chunks that are complete are not started at all.  So stopping the
job (Ctrl-C, kill, reboot) loses at most the pairs being rendered.

Progress: OUT/progress.txt (rewritten every --every seconds) and
OUT/logs/job.log (one line each time): pairs done per split, rate in pairs
per minute over the last 15 minutes and since the job started, ETA.  Each
Blender process logs its own 'synth:' lines to OUT/logs/render_SPLIT_FIRST.log.
`--status` (make detector-progress-v2, -v3) prints the pairs on disk now,
whether a job is running, and its last progress report.  A lock file
(OUT/job.lock) stops a second job on the same folder.
No Blender here (/usr/bin/python3 runs it)."""
import argparse
import fcntl
import json
import os
import signal
import subprocess
import sys
import threading
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
VAL_FIRST = 900000  # validation ids start here (training ids from 0)


def parse_args():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=os.path.join(ROOT, "build/detector/v2"),
                    help="job folder: data/ (images, labels), logs/, progress.txt")
    ap.add_argument("--train", type=int, default=55200, help="training stereo pairs")
    ap.add_argument("--val", type=int, default=6000, help="validation stereo pairs")
    ap.add_argument("--seed", type=int, default=21)
    ap.add_argument("--shards", type=int, default=2, help="Blender processes at a time")
    ap.add_argument("--chunk", type=int, default=400, help="stereo pairs per Blender process")
    ap.add_argument("--blender", default="blender")
    ap.add_argument("--mocap", default=os.path.join(ROOT, "../shared/data/mocap-train"))
    ap.add_argument("--nice", type=int, default=19, help="niceness of the Blender processes")
    ap.add_argument("--data-version", type=int, choices=(2, 3), default=2,
                    help="render.py --data-version: 2 for the v2 job, 3 for the v3 job")
    ap.add_argument("--every", type=float, default=60.0, help="seconds between progress reports")
    ap.add_argument("--status", action="store_true", help="print the progress and exit (renders nothing)")
    return ap.parse_args()


def done_ids(data):
    """Ids with a complete label line, per split."""
    done = {"train": set(), "val": set()}
    if not os.path.isdir(data):
        return done
    for fn in os.listdir(data):
        if fn.startswith("labels") and fn.endswith(".jsonl"):
            with open(os.path.join(data, fn)) as f:
                for line in f:
                    try:
                        r = json.loads(line)
                        done[r["split"]].add(r["id"])
                    except (ValueError, KeyError):
                        pass
    return done


def plan(a):
    """Chunks (split, first, count), validation spread over the run."""
    chunks = []
    for split, first, n in (("train", 0, a.train), ("val", VAL_FIRST, a.val)):
        cs = [(split, f, min(a.chunk, first + n - f)) for f in range(first, first + n, a.chunk)]
        for k, c in enumerate(cs):
            key = k / len(cs) if split == "val" else (k + 0.5) / len(cs)
            chunks.append((key, c))
    chunks.sort(key=lambda kc: kc[0])
    return [c for _, c in chunks]


def fmt_min(m):
    if m is None or m != m or m == float("inf"):
        return "unknown"
    return "%dh%02dm" % (int(m // 60), int(m % 60))


def head_lines(a, nt, nv, now):
    """The first two lines of a progress report: the job, and the pairs on
    disk per split."""
    return [
        "render job %s (data v%d, seed %d) at %s" % (
            a.out, a.data_version, a.seed, time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime(now))),
        "train %d / %d pairs (%.1f %%), val %d / %d pairs (%.1f %%), %d left" % (
            nt, a.train, 100.0 * nt / max(a.train, 1), nv, a.val, 100.0 * nv / max(a.val, 1),
            a.train + a.val - nt - nv),
    ]


class Progress:
    def __init__(self, a):
        self.a = a
        self.data = os.path.join(a.out, "data")
        self.t0 = time.time()
        d = done_ids(self.data)
        self.n0 = len(d["train"]) + len(d["val"])
        self.hist = [(self.t0, self.n0)]

    def report(self, running=()):
        a = self.a
        d = done_ids(self.data)
        nt, nv = len(d["train"]), len(d["val"])
        now = time.time()
        n = nt + nv
        self.hist.append((now, n))
        self.hist = [h for h in self.hist if now - h[0] <= 900] or [(now, n)]
        t1, n1 = self.hist[0]
        rate15 = (n - n1) / max(now - t1, 1e-6) * 60.0
        rate_all = (n - self.n0) / max(now - self.t0, 1e-6) * 60.0
        left = a.train + a.val - n
        rate = rate15 if rate15 > 0 else rate_all
        eta = left / rate if rate > 0 else None
        lines = head_lines(a, nt, nv, now) + [
            "rate %.1f pairs/min over the last %.0f min, %.1f since this run started (%s ago, %d pairs)" % (
                rate15, (now - t1) / 60.0, rate_all, fmt_min((now - self.t0) / 60.0), n - self.n0),
            "ETA %s%s" % (fmt_min(eta), (" (about %s)" % time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime(now + eta * 60)))
                          if eta else ""),
            "running: %s" % (", ".join("%s %d+%d" % c for c in running) or "nothing"),
        ]
        txt = "\n".join(lines) + "\n"
        tmp = os.path.join(a.out, "progress.txt.tmp")
        with open(tmp, "w") as f:
            f.write(txt)
        os.replace(tmp, os.path.join(a.out, "progress.txt"))
        with open(os.path.join(a.out, "logs", "job.log"), "a") as f:
            f.write(" | ".join(lines) + "\n")
        print(txt, end="", flush=True)
        return d


def job_running(out):
    """Whether a job holds out/job.lock (it keeps it locked while it runs)."""
    try:
        f = open(os.path.join(out, "job.lock"))
    except OSError:
        return False
    with f:
        try:
            fcntl.flock(f, fcntl.LOCK_SH | fcntl.LOCK_NB)
        except OSError:
            return True
        fcntl.flock(f, fcntl.LOCK_UN)
    return False


def print_status(a):
    """--status: the pairs on disk now, and the rate, ETA and chunks from
    the job's own last report (progress.txt): a separate process cannot
    measure a rate, and printed 0 pairs/min and "running: nothing" while the
    job rendered."""
    d = done_ids(os.path.join(a.out, "data"))
    print("\n".join(head_lines(a, len(d["train"]), len(d["val"]), time.time())))
    try:
        last = open(os.path.join(a.out, "progress.txt")).read().splitlines()
    except OSError:
        last = []
    report = "; its last report, at %s:" % last[0].rsplit(" at ", 1)[-1] if last else ""
    if job_running(a.out):
        print("job: running" + (report or "; no report yet"))
    else:
        print("job: not running (the same command without --status starts or resumes it)" + report)
    for line in last[2:]:
        print("  " + line)


def settings_clash(a):
    """Why resuming the job in a.out with these settings would mix two data
    sets (its job.json says another seed or data version), or None."""
    try:
        old = json.load(open(os.path.join(a.out, "job.json")))
    except (OSError, ValueError):
        return None
    for key, default in (("seed", None), ("data_version", 2)):
        was = old.get(key, default)
        if was is not None and was != getattr(a, key):
            return ("%s/job.json: this job was started with --%s %s, not %s; resume it with the same "
                    "settings, or give another --out" % (a.out, key.replace("_", "-"), was, getattr(a, key)))
    return None


def main():
    a = parse_args()
    a.out, a.mocap = os.path.abspath(a.out), os.path.abspath(a.mocap)
    data = os.path.join(a.out, "data")
    logs = os.path.join(a.out, "logs")
    if a.status:
        print_status(a)
        return 0
    clash = settings_clash(a)
    if clash:
        print("job: %s" % clash, file=sys.stderr)
        return 1
    os.makedirs(data, exist_ok=True)
    os.makedirs(logs, exist_ok=True)
    lockf = open(os.path.join(a.out, "job.lock"), "w")
    try:
        fcntl.flock(lockf, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        print("job: another job holds %s/job.lock; not starting" % a.out, file=sys.stderr)
        return 1
    lockf.write("%d\n" % os.getpid())
    lockf.flush()
    with open(os.path.join(a.out, "job.json"), "w") as f:
        json.dump({k: v for k, v in vars(a).items() if k != "status"}, f, indent=1)
    prog = Progress(a)
    done = prog.report()
    todo = [c for c in plan(a) if any(i not in done[c[0]] for i in range(c[1], c[1] + c[2]))]
    print("job: %d chunks of up to %d pairs to render, %d Blender processes" % (len(todo), a.chunk, a.shards),
          flush=True)
    lock = threading.Lock()
    running, procs, failed = set(), {}, []
    stop = threading.Event()

    def worker():
        while not stop.is_set():
            with lock:
                if not todo:
                    return
                c = todo.pop(0)
                running.add(c)
            split, first, count = c
            cmd = ["nice", "-n", str(a.nice), a.blender, "-b", "--factory-startup", "--python",
                   os.path.join(HERE, "render.py"), "--", "--out", data, "--mocap", a.mocap, "--seed", str(a.seed),
                   "--first", str(first), "--count", str(count), "--split", split,
                   "--data-version", str(a.data_version)]
            log = open(os.path.join(logs, "render_%s_%06d.log" % (split, first)), "a")
            log.write("# %s %s\n" % (time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime()), " ".join(cmd)))
            log.flush()
            p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, cwd=ROOT,
                                 start_new_session=True, text=True, errors="replace")
            with lock:
                procs[c] = p
            for line in p.stdout:
                if "synth:" in line or "Error" in line or "Traceback" in line or line.startswith("  File"):
                    log.write(line)
                    log.flush()
            rc = p.wait()
            log.write("# exit %d\n" % rc)
            log.close()
            with lock:
                procs.pop(c, None)
                running.discard(c)
                if rc != 0 and not stop.is_set():
                    failed.append(c)
                    print("job: chunk %s %d+%d failed (exit %d), see logs/render_%s_%06d.log" % (
                        split, first, count, rc, split, first), flush=True)

    def on_signal(sig, _frm):
        stop.set()
        with lock:
            for p in procs.values():
                try:
                    os.killpg(p.pid, signal.SIGTERM)
                except OSError:
                    pass
    signal.signal(signal.SIGTERM, on_signal)
    signal.signal(signal.SIGINT, on_signal)
    threads = [threading.Thread(target=worker, daemon=True) for _ in range(a.shards)]
    for t in threads:
        t.start()
    while any(t.is_alive() for t in threads):
        for t in threads:
            t.join(timeout=a.every / len(threads))
        with lock:
            run = sorted(running)
        prog.report(run)
    prog.report()
    if stop.is_set():
        print("job: stopped; run the same command again to resume", flush=True)
        return 1
    if failed:
        print("job: %d chunks failed; run the same command again to retry them" % len(failed), flush=True)
        return 1
    print("job: done", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
