"""The latest-pose block from Python (Client.pose_block) against
mocap-testpub, and mocap.predict."""
import math
import time

import pytest

import mocap
from conftest import TCP_TOKEN


def test_read(daemon):
    with mocap.Client(daemon) as c, c.pose_block() as b:
        f = b.read()
        assert f is not None and f.seq > 0 and len(f.joints) == 18
        assert f.joints["pelvis"].position[2] == pytest.approx(3.0)  # named with the daemon's SKELETON
        assert f.space == "rig" and f.capture_ns < f.publish_ns <= f.receive_ns
        time.sleep(0.05)  # 200 frames/s: about 10 newer ones
        g = b.read()
        assert g.seq > f.seq
        # The block and a subscription see the same frames.
        c.subscribe(mocap.LATEST)
        s = c.read_frame(timeout=5)
        for _ in range(50):
            g = b.read()
            if g.seq >= s.seq:
                break
            time.sleep(0.005)
        assert g.seq >= s.seq


def test_predict(daemon):
    with mocap.Client(daemon) as c, c.pose_block() as b:
        newest = b.read()
        p = b.predict(newest.capture_ns + 20_000_000)
        assert p.capture_ns == newest.capture_ns + 20_000_000 or p.seq > newest.seq
        far = b.predict(b.read().capture_ns + 10**9)  # clamped at 100 ms
        assert far.capture_ns - b.read().capture_ns <= mocap.PREDICT_MAX_NS


def test_predict_exact():
    def frame(t_ns, x, angle):
        q = (math.cos(angle / 2), 0.0, 0.0, math.sin(angle / 2))
        return mocap.Frame(1, t_ns, t_ns, t_ns, 0, 1, "ok", "rig", mocap.Joints([mocap.Joint((x, 2 * x, 0.0), q, 1.0)]))
    a, b = frame(0, 1.0, 0.3), frame(20_000_000, 1.02, 0.32)
    p = mocap.predict(a, b, 60_000_000)
    assert p.joints[0].position == pytest.approx((1.06, 2.12, 0.0))
    w, _x, _y, z = p.joints[0].orientation
    assert 2 * math.atan2(z, w) == pytest.approx(0.36)
    assert mocap.predict(None, b, 60_000_000) is b
    assert mocap.predict(a, b, 10**9).capture_ns == 20_000_000 + mocap.PREDICT_MAX_NS


def test_not_over_tcp(tcp_daemon):
    with mocap.Client(tcp_daemon, token=TCP_TOKEN) as c:
        with pytest.raises(mocap.Unavailable, match="TCP"):
            c.pose_block()
