"""Both clients over TCP (tcp://HOST:PORT) against mocap-testpub's TCP
listener: the token (argument, $MOCAP_TOKEN, $MOCAP_TOKEN_FILE; a wrong
one is refused), the same frames as on the Unix socket, requests, and what
TCP cannot carry (camera rings)."""
import asyncio
import os

import pytest

import mocap
from conftest import TCP_TOKEN


def test_no_token(tcp_daemon, monkeypatch):
    monkeypatch.delenv(mocap.TOKEN_ENV, raising=False)
    monkeypatch.delenv(mocap.TOKEN_FILE_ENV, raising=False)
    with pytest.raises(mocap.AccessDenied, match="MOCAP_TOKEN"):
        mocap.Client(tcp_daemon)


def test_wrong_token(tcp_daemon):
    with pytest.raises(mocap.AccessDenied, match="wrong token") as e:
        mocap.Client(tcp_daemon, token="not-the-daemon-token")
    assert e.value.server_code == 11 and e.value.fatal

    async def main():
        with pytest.raises(mocap.AccessDenied, match="wrong token"):
            await mocap.aio.connect(tcp_daemon, token="not-the-daemon-token")
    asyncio.run(main())


def test_bad_address():
    with pytest.raises(mocap.ArgumentError, match="tcp://HOST:PORT"):
        mocap.Client("tcp://127.0.0.1", token=TCP_TOKEN)
    with pytest.raises(mocap.NotRunning):
        mocap.Client("tcp://127.0.0.1:1", token=TCP_TOKEN)


def test_token_from_environment(tcp_daemon, monkeypatch, tmp_path):
    monkeypatch.setenv(mocap.TOKEN_ENV, TCP_TOKEN)
    with mocap.Client(tcp_daemon) as c:
        assert c.version == 3 and c.ping() < 1.0
    monkeypatch.delenv(mocap.TOKEN_ENV)
    f = tmp_path / "token"
    f.write_text(TCP_TOKEN + "\n")
    monkeypatch.setenv(mocap.TOKEN_FILE_ENV, str(f))
    with mocap.Client(tcp_daemon) as c:
        assert c.status().device == "synthetic"


def test_requests(tcp_daemon):
    with mocap.Client(tcp_daemon, "py-tcp", token=TCP_TOKEN) as c:
        assert (c.version, c.privileged, c.daemon_version) == (3, False, "mocap-testpub")
        sk = c.skeleton()
        assert sk.names[0] == "pelvis" and len(sk.joints) == 18
        assert '"testpub"' in c.rig()
        with pytest.raises(mocap.PermissionDenied, match="TCP"):
            c.reload()
        # Refused over TCP whatever the privilege, with one answer.
        with pytest.raises(mocap.Unavailable, match="TCP"):
            c.rings()


def test_same_frames_as_unix(daemon, tcp_daemon):
    # Subscribed on both transports at once: every frame the Unix client
    # gets, the TCP client gets too, with the same content.
    with mocap.Client(daemon) as u, mocap.Client(tcp_daemon, token=TCP_TOKEN) as t:
        t.subscribe(mocap.ALL, queue_len=512)
        u.subscribe(mocap.ALL, queue_len=512)
        fu = list(u.frames(count=60, timeout=5))
        by_seq = {}
        while len(by_seq) < 400 and not all(f.seq in by_seq for f in fu):
            f = t.read_frame(timeout=5)
            assert f is not None
            by_seq[f.seq] = f
        assert len(fu) == 60
        for f in fu:
            g = by_seq[f.seq]
            assert (g.capture_ns, g.publish_ns, g.state, g.space) == (f.capture_ns, f.publish_ns, f.state, f.space)
            assert [tuple(j) for j in g.joints] == [tuple(j) for j in f.joints]
            assert g.joints.names == f.joints.names


def test_aio(tcp_daemon):
    async def main():
        async with mocap.aio.connect(tcp_daemon, "py-aio-tcp", token=TCP_TOKEN) as c:
            assert c.version == 3 and not c.privileged
            await c.subscribe(mocap.ALL, queue_len=64)
            frames = [f async for f in c.frames(count=100, timeout=5)]
            assert len(frames) == 100
            assert all(b.seq == a.seq + 1 + b.missed for a, b in zip(frames, frames[1:]))
            results = await asyncio.gather(*[c.status() for _ in range(5)], c.skeleton(), c.ping())
            assert all(isinstance(r, mocap.Status) for r in results[:5])
    asyncio.run(asyncio.wait_for(main(), 60))


def test_aio_slow_reader(tcp_daemon):
    # ALL mode, a reader slower than the daemon: reading pauses at
    # max_queued frames, messages already buffered are filed after the
    # pause, and every lost frame is counted.
    async def main():
        async with mocap.aio.connect(tcp_daemon, max_queued=8, token=TCP_TOKEN) as c:
            await c.subscribe(mocap.ALL, queue_len=16)
            first = await c.read_frame(timeout=5)
            await asyncio.sleep(1.0)
            frames = [first] + [f async for f in c.frames(count=300, timeout=5)]
            assert len(frames) == 301
            assert all(b.seq == a.seq + 1 + b.missed for a, b in zip(frames, frames[1:]))
    asyncio.run(asyncio.wait_for(main(), 60))


def test_mocapctl(mocapctl, tcp_daemon):
    import json
    import subprocess
    env = dict(os.environ, MOCAP_TOKEN=TCP_TOKEN)
    r = subprocess.run([mocapctl, "--socket", tcp_daemon, "status", "--json"], env=env, capture_output=True,
                       text=True, timeout=30)
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout)["device"] == "synthetic"
    env["MOCAP_TOKEN"] = "not-the-daemon-token"
    r = subprocess.run([mocapctl, "--socket", tcp_daemon, "ping"], env=env, capture_output=True, text=True,
                       timeout=30)
    assert r.returncode == 4 and "wrong token" in r.stderr
