"""pytest fixtures for the tests of the Python client.

The programs the tests run come from the environment, as `make
check-ipc-python` passes them, or else from ./build of the repository:

    MOCAP_TESTPUB   BUILD/ipc/mocap-testpub (the server library with a synthetic skeleton)
    MOCAPCTL        BUILD/bin/mocapctl
    MOCAP_EXAMPLES  BUILD/examples (the C examples; the recorder is run)

A variable that is set must name something that exists (else the tests that
need it fail); a default that does not exist skips them.

    /usr/bin/python3 -m pytest -q python/
"""
import os
import socket
import struct
import subprocess
import sys
import tempfile
import threading

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)  # the mocap package beside this file, not an installed one

import mocap  # noqa: E402


def _program(var, default, kind="file"):
    given = os.environ.get(var)
    path = os.path.abspath(given or os.path.join(ROOT, default))
    ok = os.path.isdir(path) if kind == "dir" else os.access(path, os.X_OK)
    if ok:
        return path
    if given:
        pytest.fail("%s=%s: not found" % (var, given))
    pytest.skip("%s not built (make, or set %s)" % (default, var))


@pytest.fixture(scope="session")
def mocapctl():
    return _program("MOCAPCTL", "build/bin/mocapctl")


@pytest.fixture(scope="session")
def examples():
    return _program("MOCAP_EXAMPLES", "build/examples", "dir")


TCP_TOKEN = "python-test-token-0123456789"


@pytest.fixture(scope="session")
def testpub():
    """(socket path, tcp://127.0.0.1:PORT) of a mocap-testpub publishing 200 frames/s on
    both, with TCP_TOKEN for TCP, for the whole session."""
    program = _program("MOCAP_TESTPUB", "build/ipc/mocap-testpub")
    with tempfile.TemporaryDirectory(prefix="mocap-py-") as d:
        path = os.path.join(d, "mocapd.sock")
        pub = subprocess.Popen([program, "--socket", path, "--rate", "200", "--tcp", "127.0.0.1:0",
                                "--token", TCP_TOKEN], stdout=subprocess.PIPE, text=True)
        try:
            line = pub.stdout.readline().strip()
            if not line.startswith("ready tcp="):
                pytest.fail("mocap-testpub did not start: %r" % line)
            yield path, "tcp://127.0.0.1:%s" % line.split("=", 1)[1]
        finally:
            pub.terminate()
            pub.wait(timeout=10)
            pub.stdout.close()


@pytest.fixture(scope="session")
def daemon(testpub):
    """The socket path of the session's mocap-testpub."""
    return testpub[0]


@pytest.fixture(scope="session")
def tcp_daemon(testpub):
    """The tcp:// address of the session's mocap-testpub (token TCP_TOKEN)."""
    return testpub[1]


# --- a scripted daemon, for what mocap-testpub cannot show ---

class FakeConnection:
    """One client connection of a FakeDaemon, with helpers for the protocol."""

    def __init__(self, sock):
        self.sock = sock

    def recv(self):
        """(type, request_id, body) of the client's next message, or None when it closed."""
        data = self.sock.recv(65536)
        if not data:
            return None
        type_, _f, _size, rid, _r = mocap.HEADER.unpack_from(data)
        return type_, rid, data[mocap.HEADER.size:]

    def send(self, type_, body=b"", rid=0):
        self.sock.send(mocap.HEADER.pack(type_, 0, mocap.HEADER.size + len(body), rid, 0) + body)

    def handshake(self, privileged=True):
        type_, rid, _body = self.recv()
        assert type_ == mocap.HELLO
        self.send(mocap.WELCOME, struct.pack("<IHHIIQ", mocap.MAGIC, 2, int(privileged), 65536, 4242, 0)
                  + str16("fake-mocapd"), rid)

    def expect(self, type_):
        m = self.recv()
        assert m is not None and m[0] == type_, m
        return m[1]

    def error(self, code, message, rid=0, fatal=False, request=0):
        self.send(mocap.ERROR, struct.pack("<IHH", code, request, int(fatal)) + str16(message), rid)

    def subscribed(self, rid, queue_len=256):
        self.send(mocap.OK, struct.pack("<HHI", 0, 0, queue_len), rid)

    def skeleton(self, sid, names, rid=0):
        body = struct.pack("<IHBB", sid, len(names), 1, 0)
        body += b"".join(struct.pack("<iI3d", i - 1, 0, 0.0, 0.1 * i, 0.0) for i in range(len(names)))
        body += b"".join(str16(n) for n in names)
        self.send(mocap.SKELETON, body, rid)

    def frame(self, seq, sid, njoints):
        """A frame whose joint j has position (j, seq, sid)."""
        body = struct.pack("<QQQIHBB", seq, 1000 + seq, 2000 + seq, sid, njoints, 0, 0)
        body += b"".join(struct.pack("<7dfI", j, seq, sid, 1, 0, 0, 0, 1.0, 0) for j in range(njoints))
        self.send(mocap.FRAME, body)


def str16(s):
    b = s.encode()
    return struct.pack("<H", len(b)) + b


class FakeDaemon:
    """Listens on a temporary socket; script(FakeConnection) serves the first client, in a thread."""

    def __init__(self, directory, script):
        self.path = os.path.join(directory, "fake.sock")
        self.listener = socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        self.listener.bind(self.path)
        self.listener.listen(4)
        self.failure = None
        self.thread = threading.Thread(target=self._serve, args=(script,), daemon=True)
        self.thread.start()

    def _serve(self, script):
        try:
            conn, _ = self.listener.accept()
        except OSError:
            return
        with conn:
            try:
                script(FakeConnection(conn))
            except Exception as e:  # reported by close()
                self.failure = e

    def close(self):
        self.listener.close()
        self.thread.join(timeout=10)
        if self.failure is not None:
            raise self.failure


@pytest.fixture
def fake_daemon():
    """fake_daemon(script) -> socket path of a FakeDaemon running script."""
    started = []
    # A short directory: socket paths have at most 107 bytes.
    with tempfile.TemporaryDirectory(prefix="mocap-fake-") as d:
        def start(script):
            started.append(FakeDaemon(tempfile.mkdtemp(dir=d), script))
            return started[-1].path
        yield start
        for f in started:
            f.close()
