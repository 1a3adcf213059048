"""Tests of the Python module and of mocapctl against mocap-testpub (the
server library with a synthetic skeleton).  Usage:

    python3 python/test_mocap.py BUILD/ipc/mocap-testpub BUILD/bin/mocapctl [BUILD/examples]
"""
import json
import os
import socket
import struct
import subprocess
import sys
import tempfile
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import mocap  # noqa: E402

TESTPUB = MOCAPCTL = EXAMPLES = None


class WithPublisher(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.dir = tempfile.TemporaryDirectory(prefix="mocap-py-")
        cls.path = os.path.join(cls.dir.name, "mocapd.sock")
        cls.pub = subprocess.Popen([TESTPUB, "--socket", cls.path, "--rate", "200"], stdout=subprocess.PIPE, text=True)
        line = cls.pub.stdout.readline().strip()
        if line != "ready":
            cls.pub.kill()
            raise RuntimeError("mocap-testpub did not start: %r" % line)

    @classmethod
    def tearDownClass(cls):
        cls.pub.terminate()
        cls.pub.wait(timeout=10)
        cls.pub.stdout.close()
        cls.dir.cleanup()

    def test_requests(self):
        with mocap.Client(self.path, "py-test") as c:
            self.assertTrue(c.privileged)
            self.assertEqual(c.daemon_version, "mocap-testpub")
            st = c.status()
            self.assertEqual(st.tracker_state, "ok")
            self.assertEqual(st.device, "synthetic")
            self.assertEqual([cam.name for cam in st.cameras], ["cam0"])
            self.assertEqual(st.cameras[0].width, 640)
            self.assertGreaterEqual(st.clients, 1)
            self.assertEqual(c.version, 2)
            d = st.detector
            self.assertEqual((d.state, d.rate, d.ms_mean, d.ms_last, d.ms_max), ("running", 30, 1.25, 1.5, 2.5))
            self.assertEqual((d.views, d.skipped, d.used, d.used_rate), (300, 3, 290, 29))
            self.assertEqual((d.model, d.message), ("synthetic.onnx", ""))
            sk = c.skeleton()
            names = [j.name for j in sk.joints]
            self.assertEqual(len(names), 18)
            self.assertEqual(names[0], "pelvis")
            self.assertEqual(sk.joints[names.index("left_elbow")].parent, names.index("left_shoulder"))
            self.assertIn('"testpub"', c.rig())
            self.assertEqual(c.reload(), "reloaded (test publisher)")
            with self.assertRaises(mocap.Error) as e:
                c.control(mocap.CMD_RECORD_START, "/tmp/x")
            self.assertEqual(e.exception.code, "failed")
            self.assertIn("not supported", str(e.exception))
            self.assertLess(c.ping(), 1.0)
            self.assertEqual(c.rings(), [])

    def test_all_frames(self):
        with mocap.Client(self.path) as c:
            self.assertEqual(c.subscribe(mocap.ALL, queue_len=64), 64)
            frames = list(c.frames(count=50, timeout=5))
            self.assertEqual(len(frames), 50)
            for a, b in zip(frames, frames[1:]):
                self.assertEqual(b.seq, a.seq + 1 + b.missed)
            f = frames[-1]
            self.assertEqual(len(f.joints), 18)
            self.assertEqual(f.space, "rig")
            self.assertAlmostEqual(f.joints[0].position[2], 3.0)
            self.assertAlmostEqual(sum(q * q for q in f.joints[5].orientation), 1.0, places=9)
            self.assertTrue(f.capture_ns < f.publish_ns <= f.receive_ns)

    def test_latest(self):
        with mocap.Client(self.path) as c:
            c.subscribe(mocap.LATEST)
            first = c.read_frame(timeout=5)
            import time
            time.sleep(0.2)  # about 40 frames are published meanwhile
            newest = c.read_frame(timeout=5)
            self.assertGreater(newest.seq, first.seq + 10)
            self.assertLess(mocap.now_ns() - newest.publish_ns, 50_000_000)

    def test_keypoints_refused(self):
        with mocap.Client(self.path) as c:
            c.send_keypoints(mocap.now_ns(), 5, [(0, 1.0, 2.0, 0.5)])  # the rig has 1 camera
            with self.assertRaises(mocap.Error) as e:
                c.ping()
            self.assertEqual(e.exception.code, "invalid")
            self.assertIn("the rig has 1 cameras", str(e.exception))
            c.send_keypoints(mocap.now_ns(), 0, [(0, 1.0, 2.0, 0.5)])
            c.send_head_pose(mocap.now_ns(), (0, 1.6, 0), (1, 0, 0, 0))
            c.ping()

    def test_version_1(self):
        # A version 1 client gets version 1's STATUS: no detector block.
        saved = mocap.PROTOCOL_VERSION
        mocap.PROTOCOL_VERSION = 1
        try:
            with mocap.Client(self.path, "py-v1") as c:
                self.assertEqual(c.version, 1)
                st = c.status()
                self.assertIsNone(st.detector)
                self.assertEqual(st.device, "synthetic")
        finally:
            mocap.PROTOCOL_VERSION = saved

    def test_version_mismatch(self):
        s = socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        s.connect(self.path)
        body = struct.pack("<IHH", mocap.MAGIC, 7, 9) + struct.pack("<H", 0)
        s.send(mocap.HEADER.pack(mocap.HELLO, 0, 16 + len(body), 1, 0) + body)
        data = s.recv(65536)
        typ, _f, size, rid, _r = mocap.HEADER.unpack_from(data)
        self.assertEqual((typ, rid, size), (mocap.ERROR, 1, len(data)))
        code, req, fatal, n = struct.unpack_from("<IHHH", data, 16)
        self.assertEqual((code, req, fatal), (1, mocap.HELLO, 1))
        self.assertIn("speaks 1..2", data[26:26 + n].decode())
        self.assertEqual(s.recv(65536), b"")  # then disconnected
        s.close()

    def test_recorder_example(self):
        if not EXAMPLES:
            self.skipTest("no examples directory given")
        with tempfile.TemporaryDirectory() as d:
            out = os.path.join(d, "take.csv")
            r = subprocess.run([os.path.join(EXAMPLES, "recorder"), out, "20", self.path], capture_output=True,
                               text=True, timeout=30)
            self.assertEqual(r.returncode, 0, r.stderr)
            with open(out) as f:
                rows = f.read().splitlines()
            self.assertEqual(len(rows), 21)
            self.assertIn("left_wrist_x", rows[0].split(","))
            seqs = [int(row.split(",")[0]) for row in rows[1:]]
            missed = [int(row.split(",")[3]) for row in rows[1:]]
            self.assertEqual([b - a - m for a, b, m in zip(seqs, seqs[1:], missed[1:])], [1] * 19)

    def test_mocapctl(self):
        run = lambda *a: subprocess.run([MOCAPCTL, "--socket", self.path] + list(a), capture_output=True, text=True,
                                        timeout=30)
        r = run("status")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("tracker:    ok", r.stdout)
        self.assertIn("detector:   running, 30.0 views/s, 1.25 ms per view (last 1.50, max 2.50)", r.stdout)
        self.assertIn("cam0", r.stdout)
        r = run("watch", "--json", "--count", "3", "--all")
        self.assertEqual(r.returncode, 0, r.stderr)
        lines = [json.loads(line) for line in r.stdout.splitlines()]
        self.assertEqual(len(lines), 3)
        self.assertEqual(len(lines[0]["joints"]), 18)
        self.assertIn("left_wrist", lines[0]["joints"])
        self.assertEqual(len(lines[0]["joints"]["neck"]["orientation"]), 4)
        self.assertEqual(lines[1]["seq"], lines[0]["seq"] + 1 + lines[1]["missed"])
        r = run("watch", "--count", "1")
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("head_top", r.stdout)
        r = run("rig")
        self.assertEqual(json.loads(r.stdout)["name"], "testpub")
        r = run("reload")
        self.assertEqual((r.returncode, r.stdout.strip()), (0, "reloaded (test publisher)"))
        r = run("record", "start", "/tmp/take")
        self.assertEqual(r.returncode, 1)
        self.assertIn("not supported", r.stderr)
        r = run("bogus")
        self.assertEqual(r.returncode, 2)
        r = run("watch", "--count", "zero")
        self.assertEqual(r.returncode, 2)
        env = dict(os.environ, MOCAP_SOCKET=self.path)
        r = subprocess.run([MOCAPCTL, "skeleton"], capture_output=True, text=True, env=env, timeout=30)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("left_elbow", r.stdout)


class WithoutDaemon(unittest.TestCase):
    def test_not_running(self):
        path = "/nonexistent-mocap-dir/mocapd.sock"
        with self.assertRaises(mocap.Error) as e:
            mocap.Client(path)
        self.assertEqual(e.exception.code, "not running")
        self.assertIn("daemon not running at " + path, str(e.exception))
        r = subprocess.run([MOCAPCTL, "--socket", path, "status"], capture_output=True, text=True, timeout=30)
        self.assertEqual(r.returncode, 3)
        self.assertIn("daemon not running at " + path, r.stderr)


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit("usage: test_mocap.py MOCAP-TESTPUB MOCAPCTL [EXAMPLES-DIR]")
    TESTPUB, MOCAPCTL = os.path.abspath(sys.argv[1]), os.path.abspath(sys.argv[2])
    EXAMPLES = os.path.abspath(sys.argv[3]) if len(sys.argv) > 3 else None
    unittest.main(argv=sys.argv[:1], verbosity=1)
