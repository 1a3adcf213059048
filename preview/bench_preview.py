#!/usr/bin/python3
"""bench-preview: what one open preview page costs mocapd's tracking.

mocapd tracks the bundled clip (tests/data/ego_demo, files driver, both
cameras at 15 fps, looping) with mocap-preview connected throughout.  Each
round has four phases:

  without   no page open: mocap-preview only follows the skeleton and the
            status;
  stream    one open event stream read by curl, which draws nothing: what
            mocap-preview itself costs when the page is shown on another
            machine (it encodes the camera views as for a page);
  browser   one open page in headless Chromium on this machine (it decodes
            and shows the views and draws the 3D view);
  idle      the same page in a Chromium run at idle priority (chrt --idle
            0, SCHED_IDLE), as docs/PREVIEW.md suggests for a browser on
            the tracking machine (nice 10 did not help: the tracker on
            OpenCL waits for its slowest worker thread, and a niced
            browser still preempts them).

Each second `mocapctl status --json` gives the daemon's mean tracking time
over that second; a phase's figure is their mean weighted by the frames
tracked.  Each condition is compared with the "without" phase of its own
round (the median of the rounds is the result), so that a load elsewhere
on the machine that comes and goes weighs on both sides.  Also printed:
the CPU time of mocap-preview and of the browser (all its processes) per
second of phase.  Everything runs in this process's session, so that
priorities count against the daemon's (the kernel's autogroups would
otherwise give each session an equal share whatever its nice value).

usage: preview/bench_preview.py BUILD [--rounds N] [--seconds S]
(run from the repository root; `make bench-preview` does).
"""
import argparse
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

HZ = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid):
    """utime + stime of one process, seconds (0 if it is gone)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / HZ
    except OSError:
        return 0.0


def tree(pid):
    """pid and every descendant."""
    children = {}
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as f:
                    ppid = int(f.read().rsplit(")", 1)[1].split()[1])
                children.setdefault(ppid, []).append(int(d))
            except OSError:
                pass
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        todo.extend(children.get(p, []))
    return out


def status(build, sock):
    r = subprocess.run([f"{build}/bin/mocapctl", "--socket", sock, "status", "--json"],
                       capture_output=True, text=True, timeout=10)
    return json.loads(r.stdout) if r.returncode == 0 else None


def wait_for(pred, timeout, what):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if pred():
            return
        time.sleep(0.2)
    sys.exit(f"bench-preview: {what} (timed out)")


def cpu_model():
    with open("/proc/cpuinfo") as f:
        for line in f:
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    return "unknown"


def main():
    sys.stdout.reconfigure(line_buffering=True)  # each phase as it ends, also into a pipe
    ap = argparse.ArgumentParser()
    ap.add_argument("build")
    ap.add_argument("--rounds", type=int, default=4, help="rounds of the four phases")
    ap.add_argument("--seconds", type=int, default=15, help="seconds measured per phase")
    a = ap.parse_args()
    build, repo = os.path.abspath(a.build), os.getcwd()
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if not chromium:
        print("bench-preview: chromium is not installed, skipped")
        return
    tmp = tempfile.mkdtemp(prefix="bench-preview-")
    sock = f"{tmp}/mocapd.sock"
    conf = f"""[daemon]
plugin_dir = {build}/drivers
[camera left]
driver = files
rig_camera = left
loop = true
rate = 15
path = {repo}/tests/data/ego_demo/left
[camera right]
driver = files
rig_camera = right
loop = true
rate = 15
path = {repo}/tests/data/ego_demo/right
[tracker]
rig = {repo}/config/rigs/ego_stereo.json
model = {repo}/config/models/default.json
init_joints = {repo}/tests/data/ego_demo/gt.json
[socket]
path = {sock}
"""
    with open(f"{tmp}/t.conf", "w") as f:
        f.write(conf)
    procs = []
    try:
        daemon = subprocess.Popen([f"{build}/bin/mocapd", "-c", f"{tmp}/t.conf"],
                                  stdout=subprocess.DEVNULL, stderr=open(f"{tmp}/mocapd.txt", "w"))
        procs.append(daemon)
        wait_for(lambda: os.path.exists(sock) and (status(build, sock) or {}).get("tracker_state") == "ok", 120,
                 "mocapd did not start tracking")
        out = open(f"{tmp}/preview.txt", "w+")
        preview = subprocess.Popen([f"{build}/bin/mocap-preview", "--socket", sock, "--listen", "127.0.0.1:0",
                                    "--www", "preview/www", "--model", "config/models/default.json",
                                    "--token-file", f"{tmp}/token"], stdout=out, stderr=subprocess.STDOUT)
        procs.append(preview)

        def log():
            out.seek(0)
            return out.read()
        wait_for(lambda: "serving http://127.0.0.1:" in log(), 20, "mocap-preview did not start")
        port = int(log().split("serving http://127.0.0.1:")[1].split("/")[0])
        time.sleep(3)
        print(f"bench-preview: {cpu_model()}, {os.cpu_count()} CPUs; mocapd on tests/data/ego_demo (2 cameras, "
              f"15 fps, 256x256 MJPEG); {a.rounds} rounds of 4 phases of {a.seconds} s")
        conds = ["without", "stream", "browser", "idle"]
        results = {k: [] for k in conds}
        for i in range(len(conds) * a.rounds):
            cond = conds[i % len(conds)]
            client = None
            opened = log().count("a page opened")
            if cond == "stream":
                client = subprocess.Popen(["curl", "-sN", f"http://127.0.0.1:{port}/events"],
                                          stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            elif cond in ("browser", "idle"):
                client = subprocess.Popen(
                    (["chrt", "--idle", "0"] if cond == "idle" else []) + [
                        chromium, "--headless=new", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
                        f"--user-data-dir={tmp}/chromium", "--no-first-run", "--disable-extensions",
                        "--disable-background-networking", "--window-size=1400,900", "--remote-debugging-port=0",
                        f"http://127.0.0.1:{port}/"],
                    stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            if client:
                procs.append(client)
                wait_for(lambda: log().count("a page opened") > opened, 60, "the page did not open")
                time.sleep(3)  # the page loaded and drawing
            c0 = cpu_seconds(preview.pid)
            b0 = sum(cpu_seconds(p) for p in tree(client.pid)) if client else 0
            samples = []
            t0 = time.monotonic()
            while time.monotonic() - t0 < a.seconds:
                time.sleep(1)
                s = status(build, sock)
                if s and s.get("publish_fps", 0) > 0:
                    samples.append((s["track_ms_mean"], s["publish_fps"]))
            dt = time.monotonic() - t0
            pcpu = (cpu_seconds(preview.pid) - c0) / dt
            bcpu = (sum(cpu_seconds(p) for p in tree(client.pid)) - b0) / dt if client else 0
            w = sum(f for _, f in samples)
            mean = sum(ms * f for ms, f in samples) / w if w else float("nan")
            fps = w / len(samples) if samples else 0
            results[cond].append(mean)
            print(f"round {i // len(conds) + 1} {cond:8s}: tracking {mean:6.1f} ms mean, {fps:4.1f} fps tracked; "
                  f"mocap-preview {100 * pcpu:4.1f}% of a CPU, the page's client {100 * bcpu:5.1f}%")
            if client:
                pids = tree(client.pid)
                for p in reversed(pids):  # the browser's helpers too, by their pids
                    try:
                        os.kill(p, signal.SIGTERM)
                    except OSError:
                        pass
                client.wait(timeout=20)
                procs.remove(client)
                wait_for(lambda: log().count("a page closed") >= log().count("a page opened"), 20,
                         "the page did not close")
                time.sleep(2)
        base = results["without"]
        line = []
        for cond in conds[1:]:
            rel = sorted(100 * (x - b) / b for x, b in zip(results[cond], base))
            med = rel[len(rel) // 2] if len(rel) % 2 else (rel[len(rel) // 2 - 1] + rel[len(rel) // 2]) / 2
            line.append(f"{cond} {med:+.1f}% (rounds: {', '.join(f'{r:+.0f}' for r in rel)})")
        print(f"RESULT bench-preview: tracking {sum(base) / len(base):.1f} ms without a page; median change per round: "
              + "; ".join(line))
    finally:
        for p in reversed(procs):
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
                try:
                    p.wait(timeout=20)
                except subprocess.TimeoutExpired:
                    p.kill()
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
