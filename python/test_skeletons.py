"""Pairing frames with their SKELETON, against a scripted daemon (conftest.py's
FakeDaemon): a definition that changes mid-stream, one that the client must
ask for, and none at all.  Each case for the blocking and the asyncio client."""
import asyncio
import pickle

import pytest

import mocap


def read_frames(path, n, mode=mocap.ALL):
    with mocap.Client(path, timeout=5) as c:
        c.subscribe(mode)
        return [c.read_frame(timeout=5) for _ in range(n)]


def aio_read_frames(path, n, mode=mocap.ALL):
    async def main():
        async with mocap.aio.connect(path, timeout=5) as c:
            await c.subscribe(mode)
            return [await c.read_frame(timeout=5) for _ in range(n)]
    return asyncio.run(main())


both = pytest.mark.parametrize("read", [read_frames, aio_read_frames], ids=["blocking", "asyncio"])


def serve_until_closed(conn, answers={}):
    """Answers requests by type with answers[type](conn, rid) until the client closes."""
    while True:
        m = conn.recv()
        if m is None:
            return
        answers[m[0]](conn, m[1])


@both
def test_skeleton_changes(fake_daemon, read):
    def script(conn):
        conn.handshake()
        conn.subscribed(conn.expect(mocap.SUBSCRIBE))
        conn.skeleton(1, ["pelvis", "neck"])
        conn.frame(10, 1, 2)
        conn.skeleton(2, ["pelvis", "spine", "neck"])  # e.g. after a reload: before the first frame using it
        conn.frame(11, 2, 3)
        serve_until_closed(conn)
    f1, f2 = read(fake_daemon(script), 2)
    assert (f1.skeleton.id, f2.skeleton.id) == (1, 2)
    assert f1.joints["neck"].position == (1.0, 10.0, 1.0)
    assert f2.joints["neck"].position == (2.0, 11.0, 2.0)
    assert f2.joint("spine") is f2.joints[1]
    assert "spine" not in f1.joints


@both
def test_skeleton_asked_for(fake_daemon, read):
    # A frame whose definition the client has not seen: it asks for it, once.
    asked = []

    def get_skeleton(conn, rid):
        asked.append(rid)
        conn.skeleton(7, ["pelvis", "left_wrist"], rid)

    def script(conn):
        conn.handshake()
        conn.subscribed(conn.expect(mocap.SUBSCRIBE))
        conn.frame(1, 7, 2)
        conn.frame(2, 7, 2)
        serve_until_closed(conn, {mocap.GET_SKELETON: get_skeleton})
    frames = read(fake_daemon(script), 2)
    assert [f.joint("left_wrist").position for f in frames] == [(1.0, 1.0, 7.0), (1.0, 2.0, 7.0)]
    assert len(asked) == 1


@both
def test_no_skeleton(fake_daemon, read):
    # No definition to be had: the frames keep their list form, names are unknown.
    asked = []

    def get_skeleton(conn, rid):
        asked.append(rid)
        conn.error(6, "no skeleton loaded", rid, request=mocap.GET_SKELETON)

    def script(conn):
        conn.handshake()
        conn.subscribed(conn.expect(mocap.SUBSCRIBE))
        for seq in range(3):
            conn.frame(seq, 3, 2)
        serve_until_closed(conn, {mocap.GET_SKELETON: get_skeleton})
    frames = read(fake_daemon(script), 3)
    f = frames[-1]
    assert f.joints[1].position == (1.0, 2.0, 3.0)
    assert f.skeleton is None and f.joints.names is None and f.joints.items() == []
    assert "pelvis" not in f.joints and f.joints.get("pelvis") is None
    with pytest.raises(KeyError, match="joint names unknown"):
        f.joint("pelvis")
    assert len(asked) == 1


@both
def test_skeleton_of_other_size(fake_daemon, read):
    # A definition that does not match the frame is not used to name it.
    def get_skeleton(conn, rid):
        conn.skeleton(4, ["pelvis", "neck", "head_top"], rid)

    def script(conn):
        conn.handshake()
        conn.subscribed(conn.expect(mocap.SUBSCRIBE))
        conn.skeleton(4, ["pelvis", "neck", "head_top"])
        conn.frame(1, 4, 2)
        serve_until_closed(conn, {mocap.GET_SKELETON: get_skeleton})
    f, = read(fake_daemon(script), 1)
    assert f.skeleton is None and len(f.joints) == 2


@both
def test_skeleton_change_in_latest_mode(fake_daemon, read):
    def script(conn):
        conn.handshake()
        conn.subscribed(conn.expect(mocap.SUBSCRIBE))
        conn.skeleton(1, ["a"])
        conn.skeleton(2, ["b"])
        conn.frame(5, 2, 1)
        serve_until_closed(conn)
    f, = read(fake_daemon(script), 1, mocap.LATEST)
    assert f.joints.names == ["b"] and f.joints["b"].position == (0.0, 5.0, 2.0)


def test_frame_pickles(fake_daemon):
    def script(conn):
        conn.handshake()
        conn.subscribed(conn.expect(mocap.SUBSCRIBE))
        conn.skeleton(1, ["pelvis", "neck"])
        conn.frame(10, 1, 2)
        serve_until_closed(conn)
    f, = read_frames(fake_daemon(script), 1)
    g = pickle.loads(pickle.dumps(f))
    assert g == f and g.joints["neck"] == f.joints["neck"] and g.skeleton == f.skeleton


@pytest.mark.parametrize("aio", [False, True], ids=["blocking", "asyncio"])
def test_backlog_cap(fake_daemon, aio):
    # Frames read while a request waits for its reply and never read by the
    # application: beyond MAX_BACKLOG the oldest go, counted in missed.
    def script(conn):
        conn.handshake()
        conn.subscribed(conn.expect(mocap.SUBSCRIBE))
        conn.skeleton(1, ["pelvis"])
        rid = conn.expect(mocap.PING)
        for seq in range(10):
            conn.frame(seq, 1, 1)
        conn.send(mocap.PONG, b"\0" * 8, rid)
        serve_until_closed(conn)
    path = fake_daemon(script)
    if aio:
        async def main():
            async with mocap.aio.connect(path) as c:
                c.MAX_BACKLOG = 5
                await c.subscribe(mocap.ALL)
                await c.ping()
                return [await c.read_frame(timeout=5) for _ in range(5)]
        frames = asyncio.run(main())
    else:
        with mocap.Client(path) as c:
            c.MAX_BACKLOG = 5
            c.subscribe(mocap.ALL)
            c.ping()
            frames = [c.read_frame(timeout=5) for _ in range(5)]
    assert [(f.seq, f.missed) for f in frames] == [(5, 5), (6, 0), (7, 0), (8, 0), (9, 0)]
