"""The blocking client and mocapctl against mocap-testpub (the server library
with a synthetic skeleton of 18 joints, 200 frames/s).  Run by pytest
(fixtures in conftest.py)."""
import json
import os
import socket
import struct
import subprocess
import tempfile
import time

import pytest

import mocap


def test_requests(daemon):
    with mocap.Client(daemon, "py-test") as c:
        assert c.privileged
        assert c.daemon_version == "mocap-testpub"
        st = c.status()
        assert st.tracker_state == "ok"
        assert st.device == "synthetic"
        assert [cam.name for cam in st.cameras] == ["cam0"]
        assert st.cameras[0].width == 640
        assert st.clients >= 1
        assert c.version == 3
        d = st.detector
        assert (d.state, d.rate, d.ms_mean, d.ms_last, d.ms_max) == ("running", 30, 1.25, 1.5, 2.5)
        assert (d.views, d.skipped, d.used, d.used_rate) == (300, 3, 290, 29)
        assert (d.model, d.message) == ("synthetic.onnx", "")
        lat = st.latency
        assert lat.window == 600 and lat.ready == (1, 1, 1) and lat.decode.p50 == 3 and lat.publish.max == 5
        assert lat.total == (6, 12.5, 6) and (lat.skipped_behind, lat.skipped_stale, lat.incomplete) == (4, 2, 1)
        sk = c.skeleton()
        names = [j.name for j in sk.joints]
        assert len(names) == 18
        assert names[0] == "pelvis"
        assert sk.joints[names.index("left_elbow")].parent == names.index("left_shoulder")
        assert sk.names == names
        assert sk.joint_index("left_elbow") == names.index("left_elbow")
        assert sk.joint("left_elbow").parent == names.index("left_shoulder")
        assert '"testpub"' in c.rig()
        assert c.reload() == "reloaded (test publisher)"
        with pytest.raises(mocap.Error) as e:
            c.control(mocap.CMD_RECORD_START, "/tmp/x")
        assert e.value.code == "failed"
        assert isinstance(e.value, mocap.CommandFailed)
        assert "not supported" in str(e.value)
        assert c.ping() < 1.0
        assert c.rings() == []


def test_all_frames(daemon):
    with mocap.Client(daemon) as c:
        assert c.subscribe(mocap.ALL, queue_len=64) == 64
        frames = list(c.frames(count=50, timeout=5))
        assert len(frames) == 50
        for a, b in zip(frames, frames[1:]):
            assert b.seq == a.seq + 1 + b.missed
        f = frames[-1]
        assert len(f.joints) == 18
        assert f.space == "rig"
        assert f.joints[0].position[2] == pytest.approx(3.0)
        assert sum(q * q for q in f.joints[5].orientation) == pytest.approx(1.0, abs=1e-9)
        assert f.capture_ns < f.publish_ns <= f.receive_ns


def test_joints_by_name(daemon):
    with mocap.Client(daemon) as c:
        names = c.skeleton().names
        c.subscribe(mocap.ALL)
        f = c.read_frame(timeout=5)
        # The list form is unchanged ...
        assert isinstance(f.joints, list) and len(f.joints) == 18
        assert list(f.joints)[3] is f.joints[3]
        assert f.joints[-1] is f.joints[17] and f.joints[1:3] == [f.joints[1], f.joints[2]]
        assert f.joints[0] in f.joints
        pos, orientation, confidence = f.joints[0]
        # ... and names work, paired with the SKELETON by the client.
        i = names.index("left_wrist")
        assert f.joints["left_wrist"] is f.joints[i]
        assert f.joint("left_wrist") is f.joints[i] and f.joint(i) is f.joints[i]
        assert f.joints.index_of("left_wrist") == i
        assert "left_wrist" in f.joints and "tail" not in f.joints
        assert f.joints.names == names
        assert f.skeleton.id == f.skeleton_id
        assert [n for n, _ in f.joints.items()] == names
        assert f.joints.as_dict()["head_top"] is f.joint("head_top")
        assert f.joints.get("tail") is None and f.joints.get("neck") is f.joint("neck")
        with pytest.raises(KeyError, match="tail"):
            f.joints["tail"]
        # Every frame is named, in LATEST mode too.
        c.subscribe(mocap.LATEST)
        assert c.read_frame(timeout=5).joint("pelvis").position[2] == pytest.approx(3.0)


def test_latest(daemon):
    with mocap.Client(daemon) as c:
        c.subscribe(mocap.LATEST)
        first = c.read_frame(timeout=5)
        time.sleep(0.2)  # about 40 frames are published meanwhile
        newest = c.read_frame(timeout=5)
        assert newest.seq > first.seq + 10
        assert mocap.now_ns() - newest.publish_ns < 500_000_000  # the newest there (loose: a loaded machine)


def test_keypoints_refused(daemon):
    with mocap.Client(daemon) as c:
        c.send_keypoints(mocap.now_ns(), 5, [(0, 1.0, 2.0, 0.5)])  # the rig has 1 camera
        with pytest.raises(mocap.Error) as e:
            c.ping()
        assert e.value.code == "invalid"
        assert isinstance(e.value, mocap.Refused) and e.value.server_code == 5 and not e.value.fatal
        assert "the rig has 1 cameras" in str(e.value)
        c.send_keypoints(mocap.now_ns(), 0, [(0, 1.0, 2.0, 0.5)])
        c.send_head_pose(mocap.now_ns(), (0, 1.6, 0), (1, 0, 0, 0))
        c.ping()


def test_version_1(daemon, monkeypatch):
    # A version 1 client gets version 1's STATUS: no detector block.
    monkeypatch.setattr(mocap._codec, "PROTOCOL_VERSION", 1)  # where HELLO is built
    with mocap.Client(daemon, "py-v1") as c:
        assert c.version == 1
        st = c.status()
        assert st.detector is None and st.latency is None
        assert st.device == "synthetic"


def test_version_mismatch_raw(daemon):
    s = socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET)
    s.connect(daemon)
    body = struct.pack("<IHH", mocap.MAGIC, 7, 9) + struct.pack("<H", 0)
    s.send(mocap.HEADER.pack(mocap.HELLO, 0, 16 + len(body), 1, 0) + body)
    data = s.recv(65536)
    typ, _f, size, rid, _r = mocap.HEADER.unpack_from(data)
    assert (typ, rid, size) == (mocap.ERROR, 1, len(data))
    code, req, fatal, n = struct.unpack_from("<IHHH", data, 16)
    assert (code, req, fatal) == (1, mocap.HELLO, 1)
    assert "speaks 1..3" in data[26:26 + n].decode()
    assert s.recv(65536) == b""  # then disconnected
    s.close()


def test_recorder_example(daemon, examples):
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "take.csv")
        r = subprocess.run([os.path.join(examples, "recorder"), out, "20", daemon], capture_output=True,
                           text=True, timeout=30)
        assert r.returncode == 0, r.stderr
        with open(out) as f:
            rows = f.read().splitlines()
        assert len(rows) == 21
        assert "left_wrist_x" in rows[0].split(",")
        seqs = [int(row.split(",")[0]) for row in rows[1:]]
        missed = [int(row.split(",")[3]) for row in rows[1:]]
        assert [b - a - m for a, b, m in zip(seqs, seqs[1:], missed[1:])] == [1] * 19


def test_mocapctl(daemon, mocapctl):
    def run(*a):
        return subprocess.run([mocapctl, "--socket", daemon] + list(a), capture_output=True, text=True, timeout=30)
    r = run("status")
    assert r.returncode == 0, r.stderr
    assert "tracker:    ok" in r.stdout
    assert "detector:   running, 30.0 views/s, 1.25 ms per view (last 1.50, max 2.50)" in r.stdout
    assert "cam0" in r.stdout
    r = run("watch", "--json", "--count", "3", "--all")
    assert r.returncode == 0, r.stderr
    lines = [json.loads(line) for line in r.stdout.splitlines()]
    assert len(lines) == 3
    assert len(lines[0]["joints"]) == 18
    assert "left_wrist" in lines[0]["joints"]
    assert len(lines[0]["joints"]["neck"]["orientation"]) == 4
    assert lines[1]["seq"] == lines[0]["seq"] + 1 + lines[1]["missed"]
    r = run("watch", "--count", "1")
    assert r.returncode == 0, r.stderr
    assert "head_top" in r.stdout
    r = run("rig")
    assert json.loads(r.stdout)["name"] == "testpub"
    r = run("reload")
    assert (r.returncode, r.stdout.strip()) == (0, "reloaded (test publisher)")
    r = run("record", "start", "/tmp/take")
    assert r.returncode == 1
    assert "not supported" in r.stderr
    assert run("bogus").returncode == 2
    assert run("watch", "--count", "zero").returncode == 2
    env = dict(os.environ, MOCAP_SOCKET=daemon)
    r = subprocess.run([mocapctl, "skeleton"], capture_output=True, text=True, env=env, timeout=30)
    assert r.returncode == 0, r.stderr
    assert "left_elbow" in r.stdout


def test_not_running(mocapctl):
    path = "/nonexistent-mocap-dir/mocapd.sock"
    with pytest.raises(mocap.Error) as e:
        mocap.Client(path)
    assert e.value.code == "not running"
    assert isinstance(e.value, mocap.NotRunning)
    assert "daemon not running at " + path in str(e.value)
    r = subprocess.run([mocapctl, "--socket", path, "status"], capture_output=True, text=True, timeout=30)
    assert r.returncode == 3
    assert "daemon not running at " + path in r.stderr


def test_default_socket(daemon, monkeypatch):
    monkeypatch.setenv("MOCAP_SOCKET", daemon)
    assert mocap.default_socket() == daemon
    with mocap.Client() as c:
        assert c.path == daemon
