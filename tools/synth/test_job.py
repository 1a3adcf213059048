#!/usr/bin/python3
"""Tests of the render job's settings (`make check-train-tools`; no
Blender: a stand-in records its command).

    /usr/bin/python3 -m pytest -q tools/synth/test_job.py
"""
import fcntl
import json
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))


def run_job(out, *args, blender):
    return subprocess.run([sys.executable, os.path.join(HERE, "job.py"), "--out", str(out), "--train", "2",
                           "--val", "1", "--chunk", "2", "--shards", "1", "--every", "0.2", "--nice", "0",
                           "--blender", str(blender), *args], capture_output=True, text=True, timeout=60)


def stand_in(tmp_path):
    """A 'blender' that appends its arguments to calls.txt and renders nothing."""
    calls = tmp_path / "calls.txt"
    exe = tmp_path / "blender"
    exe.write_text("#!/bin/sh\necho \"$@\" >> %s\n" % calls)
    exe.chmod(0o755)
    return exe, calls


def test_data_version_reaches_the_renderer_and_is_kept(tmp_path):
    exe, calls = stand_in(tmp_path)
    out = tmp_path / "job"
    run_job(out, "--data-version", "3", blender=exe)
    lines = calls.read_text().splitlines()
    assert len(lines) == 2 and all(line.endswith("--data-version 3") for line in lines), lines
    assert json.load(open(str(out / "job.json")))["data_version"] == 3
    # resuming with another version or seed would mix two data sets: refused, named
    r = run_job(out, blender=exe)
    assert r.returncode == 1 and "started with --data-version 3, not 2" in r.stderr and "job.json" in r.stderr
    r = run_job(out, "--data-version", "3", "--seed", "4", blender=exe)
    assert r.returncode == 1 and "started with --seed 21, not 4" in r.stderr
    assert len(calls.read_text().splitlines()) == 2


def test_a_job_from_before_data_versions_is_version_2(tmp_path):
    exe, calls = stand_in(tmp_path)
    out = tmp_path / "job"
    out.mkdir()
    json.dump({"seed": 21, "train": 2}, open(str(out / "job.json"), "w"))
    r = run_job(out, "--data-version", "3", blender=exe)
    assert r.returncode == 1 and "--data-version 2, not 3" in r.stderr
    run_job(out, blender=exe)
    assert all(line.endswith("--data-version 2") for line in calls.read_text().splitlines())


def test_status_tells_a_running_job_and_its_last_report(tmp_path):
    exe, _ = stand_in(tmp_path)
    out = tmp_path / "job"
    run_job(out, blender=exe)  # renders nothing, reports, ends
    r = run_job(out, "--status", blender=exe)
    assert r.returncode == 0, r.stderr
    assert "train 0 / 2 pairs" in r.stdout and "job: not running" in r.stdout, r.stdout
    assert "last report, at" in r.stdout and "  ETA" in r.stdout, r.stdout
    # a job that runs holds job.lock: --status says so (it printed "running:
    # nothing" and 0 pairs/min while a job rendered)
    with open(str(out / "job.lock"), "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        r = run_job(out, "--status", blender=exe)
    assert "job: running; its last report, at" in r.stdout, r.stdout
