"""The asyncio client (mocap.aio) against mocap-testpub.  Each test runs its
own event loop with asyncio.run (no pytest plugin needed)."""
import asyncio
import sys
import time

import pytest

import mocap
import mocap.aio
from mocap.aio import connect


def run(coro):
    return asyncio.run(asyncio.wait_for(coro, 60))


def test_module():
    assert mocap.aio.connect is mocap.connect
    assert mocap.aio.Client is mocap.AsyncClient
    assert sys.modules["mocap.aio"] is mocap.aio


def test_requests(daemon):
    async def main():
        async with connect(daemon, "py-aio") as c:
            assert isinstance(c, mocap.AsyncClient)
            assert (c.version, c.privileged, c.daemon_version) == (3, True, "mocap-testpub")
            st = await c.status()
            assert st.device == "synthetic" and st.detector.state == "running"
            sk = await c.skeleton()
            assert sk.names[0] == "pelvis" and len(sk.joints) == 18
            assert '"testpub"' in await c.rig()
            assert await c.reload() == "reloaded (test publisher)"
            with pytest.raises(mocap.CommandFailed, match="not supported"):
                await c.control(mocap.CMD_RECORD_START, "/tmp/x")
            assert await c.ping() < 1.0
            assert await c.rings() == []
            # Requests from many tasks at once, each answered to its own.
            results = await asyncio.gather(*[c.status() for _ in range(10)], c.rig(), c.skeleton(), c.ping())
            assert all(isinstance(r, mocap.Status) for r in results[:10])
            assert isinstance(results[10], str) and results[11] == sk
    run(main())


def test_await_connect(daemon):
    async def main():
        c = await connect(daemon)
        try:
            assert c.version == 3
        finally:
            await c.aclose()
        with pytest.raises(mocap.Disconnected):
            await c.status()
    run(main())


def test_all_frames(daemon):
    async def main():
        async with connect(daemon) as c:
            assert await c.subscribe(mocap.ALL, queue_len=64) == 64
            frames = [f async for f in c.frames(count=50, timeout=5)]
            assert len(frames) == 50
            for a, b in zip(frames, frames[1:]):
                assert b.seq == a.seq + 1 + b.missed
            f = frames[-1]
            assert len(f.joints) == 18 and f.space == "rig"
            assert f.joints[0].position[2] == pytest.approx(3.0)
            assert f.joints["pelvis"] is f.joints[0] and f.joint("left_wrist") is f.joints["left_wrist"]
            assert f.capture_ns < f.publish_ns <= f.receive_ns
    run(main())


def test_frames_while_requesting(daemon):
    # Frames keep coming in order while other tasks make requests.
    async def main():
        async with connect(daemon) as c:
            await c.subscribe(mocap.ALL)

            async def ask():
                for _ in range(20):
                    await c.status()
                    await c.ping()
            asker = asyncio.create_task(ask())
            frames = [f async for f in c.frames(count=100, timeout=5)]
            await asker
            assert len(frames) == 100
            assert all(b.seq == a.seq + 1 + b.missed for a, b in zip(frames, frames[1:]))
    run(main())


def test_slow_reader(daemon):
    # ALL mode with a reader slower than the daemon: the client stops reading
    # at max_queued frames, so the backlog stays with the daemon, and
    # nothing is lost without being counted.
    async def main():
        async with connect(daemon, max_queued=8) as c:
            await c.subscribe(mocap.ALL, queue_len=16)
            first = await c.read_frame(timeout=5)
            await asyncio.sleep(1.5)  # 300 frames: more than the daemon's queue and the socket hold
            assert len(c._frames) <= 8
            frames = [first] + [f async for f in c.frames(count=300, timeout=5)]
            assert all(b.seq == a.seq + 1 + b.missed for a, b in zip(frames, frames[1:]))
            assert sum(f.missed for f in frames) > 0
    run(main())


def test_latest(daemon):
    async def main():
        async with connect(daemon) as c:
            await c.subscribe(mocap.LATEST)
            first = await c.read_frame(timeout=5)
            time.sleep(0.2)  # blocks the loop: about 40 frames wait in the socket
            newest = await c.read_frame(timeout=5)
            assert newest.seq > first.seq + 10
            assert mocap.now_ns() - newest.publish_ns < 500_000_000  # the newest there (loose: a loaded machine)
            assert "head_top" in newest.joints
    run(main())


def test_read_timeout(fake_daemon):
    def script(conn):  # subscribed, but no frames come
        conn.handshake()
        conn.subscribed(conn.expect(mocap.SUBSCRIBE))
        conn.send(mocap.OK, b"\0" * 8, conn.expect(mocap.UNSUBSCRIBE))
        conn.recv()

    async def main(path):
        async with connect(path) as c:
            await c.subscribe(mocap.ALL)
            t = time.monotonic()
            assert await c.read_frame(timeout=0.3) is None
            assert 0.25 < time.monotonic() - t < 2
            assert [f async for f in c.frames(timeout=0.1)] == []
            await c.unsubscribe()
            with pytest.raises(mocap.ArgumentError, match="not subscribed"):
                await c.read_frame(timeout=0.1)
    run(main(fake_daemon(script)))


def test_keypoints_refused(daemon):
    async def main():
        async with connect(daemon) as c:
            await c.send_keypoints(mocap.now_ns(), 5, [(0, 1.0, 2.0, 0.5)])  # the rig has 1 camera
            with pytest.raises(mocap.Refused) as e:
                await c.ping()
            assert e.value.code == "invalid" and "the rig has 1 cameras" in str(e.value)
            await c.send_keypoints(mocap.now_ns(), 0, [(0, 1.0, 2.0, 0.5)])
            await c.send_head_pose(mocap.now_ns(), (0, 1.6, 0), (1, 0, 0, 0))
            await c.ping()
    run(main())


def test_version_1(daemon, monkeypatch):
    monkeypatch.setattr(mocap._codec, "PROTOCOL_VERSION", 1)  # where HELLO is built

    async def main():
        async with connect(daemon, "py-aio-v1") as c:
            assert c.version == 1
            st = await c.status()
            assert st.detector is None and st.device == "synthetic"
    run(main())


def test_many_clients(daemon):
    # Several clients in one loop, each with its own stream.
    async def one(i):
        async with connect(daemon, "py-aio-%d" % i) as c:
            await c.subscribe(mocap.ALL)
            return [f.seq async for f in c.frames(count=20, timeout=5)]
    async def main():
        return await asyncio.gather(*[one(i) for i in range(4)])
    for seqs in run(main()):
        assert len(seqs) == 20 and seqs == sorted(seqs)
