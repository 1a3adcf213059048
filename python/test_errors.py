"""One exception class per libmocap error code (MOCAP_E_* in ipc/mocap.h), all
subclasses of mocap.Error, each raised where libmocap returns its code."""
import asyncio
import errno
import grp
import os
import pwd
import re
import shutil
import socket
import subprocess
import sys
import tempfile

import pytest

import mocap
from conftest import HERE, ROOT

CLASSES = [mocap.NotRunning, mocap.AccessDenied, mocap.VersionMismatch, mocap.ProtocolError, mocap.Disconnected,
           mocap.Timeout, mocap.PermissionDenied, mocap.Refused, mocap.Unavailable, mocap.CommandFailed,
           mocap.ArgumentError, mocap.SystemCallError]


def connect_aio(path):
    async def main():
        (await mocap.aio.connect(path)).close()
    asyncio.run(main())


def test_one_class_per_c_error_code():
    with open(os.path.join(ROOT, "ipc", "mocap.h")) as f:
        codes = {name: int(value) for name, value in re.findall(r"#define MOCAP_E_(\w+)\s+(-\d+)", f.read())}
    assert len(codes) == 12
    assert sorted(c.errno for c in CLASSES) == sorted(codes.values())
    for name, value in codes.items():
        assert getattr(mocap, "E_" + name) == value
    assert len(set(CLASSES)) == len(CLASSES)
    for cls in CLASSES:
        assert issubclass(cls, mocap.Error) and cls.__doc__
    assert mocap.Error is mocap.MocapError
    assert issubclass(mocap.ArgumentError, ValueError)


def test_constructors():
    e = mocap.Error("not running", "daemon not running at x")  # as before 1.1
    assert (e.code, str(e), e.server_code, e.fatal) == ("not running", "daemon not running at x", None, False)
    e = mocap.Timeout("no reply")
    assert (e.code, str(e), e.errno) == ("timeout", "no reply", mocap.E_TIMEOUT)
    with pytest.raises(TypeError):
        mocap.Error()
    import pickle
    e = pickle.loads(pickle.dumps(mocap.Refused("busy", "retry later", server_code=7, fatal=False)))
    assert (type(e), e.code, str(e), e.server_code, e.fatal) == (mocap.Refused, "busy", "retry later", 7, False)


# The daemon's ERROR codes, the class and code they give (as libmocap maps them).
SERVER_ERRORS = [
    (1, mocap.VersionMismatch, "version"), (2, mocap.ProtocolError, "malformed"),
    (3, mocap.ProtocolError, "handshake"), (4, mocap.PermissionDenied, "permission"),
    (5, mocap.Refused, "invalid"), (6, mocap.Unavailable, "unavailable"), (7, mocap.Refused, "busy"),
    (8, mocap.Refused, "too many clients"), (9, mocap.Refused, "overload"), (10, mocap.Disconnected, "shutdown"),
    (99, mocap.Refused, "refused"),
]


def refusing(code):
    def script(conn):
        conn.handshake()
        rid = conn.expect(mocap.CONTROL)
        conn.error(code, "refused with %d" % code, rid, request=mocap.CONTROL)
        conn.recv()
    return script


@pytest.mark.parametrize("code,cls,name", SERVER_ERRORS)
def test_server_errors(fake_daemon, code, cls, name):
    with mocap.Client(fake_daemon(refusing(code))) as c:
        with pytest.raises(cls) as e:
            c.reload()
    assert (e.value.code, e.value.server_code, str(e.value)) == (name, code, "refused with %d" % code)


@pytest.mark.parametrize("code,cls,name", SERVER_ERRORS)
def test_server_errors_aio(fake_daemon, code, cls, name):
    async def main(path):
        async with mocap.aio.connect(path) as c:
            with pytest.raises(cls) as e:
                await c.reload()
            return e.value
    err = asyncio.run(main(fake_daemon(refusing(code))))
    assert (err.code, err.server_code) == (name, code)


def shutting_down(conn):
    conn.handshake()
    conn.subscribed(conn.expect(mocap.SUBSCRIBE))
    conn.error(10, "mocapd is stopping", fatal=True)


def test_shutdown(fake_daemon):
    with mocap.Client(fake_daemon(shutting_down)) as c:
        c.subscribe(mocap.ALL)
        with pytest.raises(mocap.Disconnected) as e:
            c.read_frame(timeout=5)
    assert (e.value.code, e.value.fatal) == ("shutdown", True)
    assert str(e.value) == "mocapd closed the connection: mocapd is stopping"


def test_shutdown_aio(fake_daemon):
    async def main(path):
        async with mocap.aio.connect(path) as c:
            await c.subscribe(mocap.ALL)
            with pytest.raises(mocap.Disconnected, match="mocapd is stopping"):
                await c.read_frame(timeout=5)
            with pytest.raises(mocap.Disconnected, match="mocapd is stopping"):  # and from then on
                await c.status()
    asyncio.run(main(fake_daemon(shutting_down)))


def closing(conn):
    conn.handshake()
    conn.expect(mocap.GET_STATUS)


def test_disconnected(fake_daemon):
    with mocap.Client(fake_daemon(closing)) as c:
        with pytest.raises(mocap.Disconnected, match="closed the connection"):
            c.status()


def test_disconnected_aio(fake_daemon):
    async def main(path):
        c = await mocap.aio.connect(path)
        with pytest.raises(mocap.Disconnected, match="closed the connection"):
            await c.status()
        c.close()
        with pytest.raises(mocap.Disconnected, match="closed"):
            await c.ping()
    asyncio.run(main(fake_daemon(closing)))


def silent(conn):
    conn.handshake()
    conn.expect(mocap.PING)
    conn.recv()


def test_timeout(fake_daemon):
    with mocap.Client(fake_daemon(silent), timeout=0.2) as c:
        with pytest.raises(mocap.Timeout, match="no reply"):
            c.ping()


def test_timeout_aio(fake_daemon):
    async def main(path):
        async with mocap.aio.connect(path, timeout=0.2) as c:
            with pytest.raises(mocap.Timeout, match="no reply"):
                await c.ping()
    asyncio.run(main(fake_daemon(silent)))


def garbage(conn):
    conn.handshake()
    conn.expect(mocap.GET_RIG)
    conn.sock.send(mocap.HEADER.pack(mocap.RIG, 0, 99, 2, 0))  # size field 99, datagram 16 bytes
    conn.recv()


def test_protocol_error(fake_daemon):
    with mocap.Client(fake_daemon(garbage)) as c:
        with pytest.raises(mocap.ProtocolError, match="size field 99"):
            c.rig()


def test_protocol_error_aio(fake_daemon):
    async def main(path):
        async with mocap.aio.connect(path) as c:
            with pytest.raises(mocap.ProtocolError, match="size field 99"):
                await c.rig()
    asyncio.run(main(fake_daemon(garbage)))


def test_wrong_socket_type(tmp_path):
    path = str(tmp_path / "stream.sock")
    with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as s:
        s.bind(path)
        s.listen(1)
        with pytest.raises(mocap.ProtocolError, match="not a mocapd socket"):
            mocap.Client(path)
        with pytest.raises(mocap.ProtocolError, match="not a mocapd socket"):
            connect_aio(path)


def test_not_running(tmp_path):
    path = str(tmp_path / "nobody.sock")
    with pytest.raises(mocap.NotRunning, match="no socket there"):
        mocap.Client(path)
    with pytest.raises(mocap.NotRunning, match="no socket there"):
        connect_aio(path)
    with socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET) as s:
        s.bind(path)  # left over: nobody listens
    with pytest.raises(mocap.NotRunning, match="left over"):
        mocap.Client(path)
    with pytest.raises(mocap.NotRunning, match="left over"):
        connect_aio(path)


ACCESS_CHECK = """
import asyncio, sys, mocap
try:
    mocap.Client(sys.argv[1])
except mocap.AccessDenied as e:
    print("blocking:", e)
async def main():
    try:
        await mocap.aio.connect(sys.argv[1])
    except mocap.AccessDenied as e:
        print("asyncio:", e)
asyncio.run(main())
"""


def test_access_denied():
    # The socket's mode keeps us out.  Root may connect to any socket: as
    # root, the check runs as nobody (setpriv).
    prefix = []
    if os.geteuid() == 0:
        if not shutil.which("setpriv"):
            pytest.skip("root, and no setpriv to run as another user")
        prefix = ["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups"]
    with tempfile.TemporaryDirectory(prefix="mocap-access-") as d, \
            socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET) as s:
        os.chmod(d, 0o755)
        path = os.path.join(d, "closed.sock")
        s.bind(path)
        s.listen(1)
        os.chmod(path, 0)
        r = subprocess.run(prefix + [sys.executable, "-B", "-c", ACCESS_CHECK, path], capture_output=True,
                           text=True, timeout=60, env=dict(os.environ, PYTHONPATH=HERE))
    assert r.returncode == 0, r.stderr
    # Mode 0: the group may not connect either, so the message names the
    # owner rather than a group to join (as libmocap's, test_ipc_access).
    owner, group = pwd.getpwuid(os.getuid())[0], grp.getgrgid(os.getgid())[0]
    assert r.stdout.splitlines() == ["%s: permission denied connecting to %s: the socket belongs to user %s, group "
                                     "%s, with mode 0000: only its owner may connect (the daemon's [socket] mode "
                                     "sets it)" % (kind, path, owner, group) for kind in ("blocking", "asyncio")]


def test_access_denied_names_the_group():
    # The socket's group may connect: the message names it and how to join.
    prefix = []
    if os.geteuid() == 0:
        if not shutil.which("setpriv"):
            pytest.skip("root, and no setpriv to run as another user")
        prefix = ["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups"]
    with tempfile.TemporaryDirectory(prefix="mocap-access-") as d, \
            socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET) as s:
        os.chmod(d, 0o755)
        path = os.path.join(d, "mocapd.sock")
        s.bind(path)
        s.listen(1)
        os.chmod(path, 0o660)
        group = grp.getgrgid(os.stat(path).st_gid)[0]
        r = subprocess.run(prefix + [sys.executable, "-B", "-c", ACCESS_CHECK, path], capture_output=True,
                           text=True, timeout=60, env=dict(os.environ, PYTHONPATH=HERE))
    if not prefix and group in [grp.getgrgid(g)[0] for g in os.getgroups()]:
        pytest.skip("this user is in the socket's group")
    assert r.returncode == 0, r.stderr
    assert r.stdout.splitlines() == ["%s: permission denied connecting to %s: the socket belongs to group %s (mode "
                                     "0660) and your user is not in it: sudo usermod -aG %s $USER, then log in "
                                     "again (or newgrp %s in one shell)" % (kind, path, group, group, group)
                                     for kind in ("blocking", "asyncio")]


def test_version_mismatch(daemon, monkeypatch):
    monkeypatch.setattr(mocap._codec, "PROTOCOL_MIN_VERSION", 7)  # where HELLO is built
    monkeypatch.setattr(mocap._codec, "PROTOCOL_VERSION", 9)
    with pytest.raises(mocap.VersionMismatch, match="speaks 1..3") as e:
        mocap.Client(daemon)
    assert (e.value.code, e.value.server_code, e.value.fatal) == ("version", 1, True)
    with pytest.raises(mocap.VersionMismatch, match="speaks 1..3"):
        connect_aio(daemon)


def test_permission(fake_daemon):
    def script(conn):
        conn.handshake(privileged=False)
        rid = conn.expect(mocap.GET_RINGS)
        conn.error(4, "GET_RINGS needs the daemon's group", rid, request=mocap.GET_RINGS)
        conn.recv()
    with mocap.Client(fake_daemon(script)) as c:
        assert not c.privileged
        with pytest.raises(mocap.PermissionDenied, match="daemon's group"):
            c.rings()


def test_refused_and_failed(daemon):
    with mocap.Client(daemon) as c:
        with pytest.raises(mocap.CommandFailed, match="not supported"):
            c.control(mocap.CMD_RECORD_START, "/tmp/x")
        c.send_keypoints(mocap.now_ns(), 0, [(99, 1.0, 2.0, 0.5)])  # no joint 99
        with pytest.raises(mocap.Refused) as e:
            c.ping()
        assert e.value.code == "invalid"
        c.ping()  # the connection goes on


def test_unavailable(fake_daemon):
    def script(conn):
        conn.handshake()
        rid = conn.expect(mocap.GET_SKELETON)
        conn.error(6, "no skeleton yet", rid, request=mocap.GET_SKELETON)
        conn.recv()
    with mocap.Client(fake_daemon(script)) as c:
        with pytest.raises(mocap.Unavailable, match="no skeleton yet"):
            c.skeleton()


def test_argument(daemon):
    with mocap.Client(daemon) as c:
        with pytest.raises(mocap.ArgumentError, match="not subscribed"):
            c.read_frame(timeout=1)
        with pytest.raises(mocap.ArgumentError, match="mode"):
            c.subscribe(9)
        with pytest.raises(ValueError):  # ArgumentError is a ValueError too
            c.send_keypoints(mocap.now_ns(), 0, [(0, 1.0, 2.0)])
        with pytest.raises(mocap.ArgumentError, match="head pose"):
            c.send_head_pose(mocap.now_ns(), (0, 1), (1, 0, 0, 0))
        c.ping()
    with pytest.raises(mocap.ArgumentError, match="too long"):
        mocap.Client("/tmp/" + "x" * 200)

    async def main():
        async with mocap.aio.connect(daemon) as c:
            with pytest.raises(mocap.ArgumentError, match="not subscribed"):
                await c.read_frame(timeout=1)
    asyncio.run(main())


def test_system(monkeypatch):
    def no_descriptors(*a, **k):
        raise OSError(errno.EMFILE, os.strerror(errno.EMFILE))
    monkeypatch.setattr(socket, "socket", no_descriptors)
    with pytest.raises(mocap.SystemCallError, match="Too many open files") as e:
        mocap.Client("/run/mocapd/mocapd.sock")
    assert e.value.errno == mocap.E_SYSTEM
