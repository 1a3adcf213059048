"""mocap: a client of mocapd for lab scripts, in pure Python (standard library).

Speaks protocol versions 1 to 3 of docs/PROTOCOL.md over the daemon's
SOCK_SEQPACKET Unix socket, or over TCP to a daemon on another machine
(path "tcp://HOST:PORT"; the daemon's token from token=, $MOCAP_TOKEN or
the file $MOCAP_TOKEN_FILE).  One file: install it with `pip install
./python` or copy mocap.py next to a script.

Blocking (single-threaded: use one Client per thread):

    import mocap
    with mocap.Client() as c:                  # $MOCAP_SOCKET or /run/mocapd/mocapd.sock
        print(c.status())
        c.subscribe(mocap.ALL)                 # every frame; or mocap.LATEST
        for frame in c.frames(count=100):
            wrist = frame.joints["left_wrist"]  # or frame.joint("left_wrist"); frame.joints[0] too
            print(frame.seq, frame.missed, wrist.position)

asyncio (one client may serve many tasks at once):

    import asyncio, mocap.aio
    async def main():
        async with mocap.aio.connect() as c:    # or: c = await mocap.aio.connect()
            await c.subscribe(mocap.ALL)
            async for frame in c.frames(count=100):
                print(frame.seq, frame.joints["head_top"].position)
    asyncio.run(main())

Joint names come from the daemon's SKELETON message, which the client pairs
with each frame by its skeleton_id (asking the daemon for it if needed).

Errors: every failure is a mocap.Error (alias mocap.MocapError), of one
subclass per kind (NotRunning, AccessDenied, VersionMismatch, ProtocolError,
Disconnected, Timeout, PermissionDenied, Refused, Unavailable, CommandFailed,
ArgumentError, SystemCallError: the MOCAP_E_* codes of libmocap); .code is
the short name it always had ("not running", "permission", "invalid", ...)."""

import asyncio
import collections
import errno as _errno
import math
import mmap
import os
import socket
import struct
import sys
import time
import types
from collections import namedtuple

__version__ = "1.2.0"
__all__ = [
    "Client", "AsyncClient", "connect", "aio", "Frame", "Joint", "Joints", "JointDef", "Skeleton", "Camera",
    "Detector", "Status", "Latency", "StageTime", "Ring", "PoseBlock", "predict", "MocapError", "Error", "NotRunning", "AccessDenied", "VersionMismatch",
    "ProtocolError", "Disconnected", "Timeout", "PermissionDenied", "Refused", "Unavailable", "CommandFailed",
    "ArgumentError", "SystemCallError", "LATEST", "ALL", "SPACE_RIG", "SPACE_WORLD", "CMD_RELOAD",
    "CMD_RECORD_START", "CMD_RECORD_STOP", "CMD_ACTOR_SAVE", "CMD_RECORD_STATUS", "CMD_RECORD_LIST", "CMD_STEER", "default_socket", "now_ns",
]

PROTOCOL_VERSION = 3      # the highest spoken; 1 and 2 too (2 adds STATUS's detector block, 3 its latency)
PROTOCOL_MIN_VERSION = 1
MAGIC = 0x50434F4D
HEADER = struct.Struct("<HHIII")  # type, flags, size, request_id, reserved
MAX_MESSAGE = 65536
MAX_FDS = 16
DEFAULT_SOCKET = "/run/mocapd/mocapd.sock"

LATEST, ALL = 1, 2
SPACE_RIG, SPACE_WORLD = 0, 1
CMD_RELOAD, CMD_RECORD_START, CMD_RECORD_STOP, CMD_ACTOR_SAVE = 1, 2, 3, 4
CMD_RECORD_STATUS, CMD_RECORD_LIST = 5, 6
CMD_STEER = 7  # a [source] graph walk: "class NAME", "frame N", "direction DEG [speed M/S]", "none"
TRACK_STATES = {0: "ok", 1: "uncertain", 2: "lost", 3: "idle", 4: "initialising"}
CAMERA_STATES = {0: "ok", 1: "stalled", 2: "error", 3: "off"}
DETECTOR_STATES = {0: "off", 1: "running", 2: "failed"}

# Message types.
HELLO, SUBSCRIBE, UNSUBSCRIBE, GET_STATUS, GET_SKELETON, GET_RIG = 0x1, 0x2, 0x3, 0x4, 0x5, 0x6
CONTROL, GET_RINGS, KEYPOINTS, HEAD_POSE, PING, AUTH, GET_POSE_BLOCK = 0x7, 0x8, 0x9, 0xA, 0xB, 0xC, 0xD
WELCOME, ERROR, OK, SKELETON, FRAME, GAP = 0x8001, 0x8002, 0x8003, 0x8004, 0x8005, 0x8006
STATUS, RIG, CONTROL_RESULT, RINGS, PONG, POSE_BLOCK = 0x8007, 0x8008, 0x8009, 0x800A, 0x800B, 0x800C

# Server error codes (ERROR message) and the names Error.code uses.
SERVER_ERRORS = {1: "version", 2: "malformed", 3: "handshake", 4: "permission", 5: "invalid",
                 6: "unavailable", 7: "busy", 8: "too many clients", 9: "overload", 10: "shutdown",
                 11: "access"}

# libmocap's error codes (ipc/mocap.h), one exception class each.
E_NOT_RUNNING, E_ACCESS, E_VERSION, E_PROTOCOL, E_DISCONNECTED, E_TIMEOUT = -1, -2, -3, -4, -5, -6
E_PERMISSION, E_REFUSED, E_UNAVAILABLE, E_FAILED, E_ARG, E_SYSTEM = -7, -8, -9, -10, -11, -12


# --- errors ---

class MocapError(Exception):
    """Every failure of this module.  Also known as mocap.Error.

    .code: a short name, e.g. "not running", "permission", "invalid", "timeout"
    (for the daemon's refusals, the name of its ERROR code: SERVER_ERRORS);
    .server_code: the daemon's ERROR code, or None when the failure is local;
    .fatal: True when the daemon closed the connection after it;
    .errno: the libmocap code of the class (E_*, negative), as mocap_errcode() gives.

    Raised as one of its subclasses.  MocapError(code, message) and
    Subclass(message) (which takes the subclass's usual code) both work."""

    errno = None
    default_code = "error"

    def __init__(self, *args, server_code=None, fatal=False):
        if len(args) == 1:
            code, message = self.default_code, args[0]
        elif len(args) == 2:
            code, message = args
        else:
            raise TypeError("%s(message) or %s(code, message)" % (type(self).__name__, type(self).__name__))
        super().__init__(message)
        self.code = code
        self.message = message
        self.server_code = server_code
        self.fatal = fatal

    def __reduce__(self):  # pickles with its fields (multiprocessing)
        return (_rebuild_error, (type(self), self.code, self.message, self.server_code, self.fatal))


def _rebuild_error(cls, code, message, server_code, fatal):
    return cls(code, message, server_code=server_code, fatal=fatal)


Error = MocapError  # the name of this module's one exception class, before there were subclasses


class NotRunning(MocapError):
    """No daemon listens at the socket path (MOCAP_E_NOT_RUNNING)."""
    errno, default_code = E_NOT_RUNNING, "not running"


class AccessDenied(MocapError):
    """The socket exists but this user may not connect to it (MOCAP_E_ACCESS)."""
    errno, default_code = E_ACCESS, "access"


class VersionMismatch(MocapError):
    """The daemon speaks another protocol version (MOCAP_E_VERSION)."""
    errno, default_code = E_VERSION, "version"


class ProtocolError(MocapError):
    """The daemon sent something this module does not understand, or said we did (MOCAP_E_PROTOCOL)."""
    errno, default_code = E_PROTOCOL, "protocol"


class Disconnected(MocapError):
    """The connection is closed: the daemon stopped or closed us, or close() was called (MOCAP_E_DISCONNECTED)."""
    errno, default_code = E_DISCONNECTED, "disconnected"


class Timeout(MocapError):
    """No reply in time (the client's timeout) (MOCAP_E_TIMEOUT)."""
    errno, default_code = E_TIMEOUT, "timeout"


class PermissionDenied(MocapError):
    """The request needs the daemon's user or group (MOCAP_E_PERMISSION)."""
    errno, default_code = E_PERMISSION, "permission"


class Refused(MocapError):
    """The daemon refused the request; the message says why (MOCAP_E_REFUSED)."""
    errno, default_code = E_REFUSED, "refused"


class Unavailable(MocapError):
    """Nothing to answer yet: no skeleton, no rig (MOCAP_E_UNAVAILABLE)."""
    errno, default_code = E_UNAVAILABLE, "unavailable"


class CommandFailed(MocapError):
    """A control command ran and failed (MOCAP_E_FAILED)."""
    errno, default_code = E_FAILED, "failed"


class ArgumentError(MocapError, ValueError):
    """A bad argument, or a call at the wrong time (MOCAP_E_ARG)."""
    errno, default_code = E_ARG, "argument"


class SystemCallError(MocapError):
    """A system call failed: out of descriptors, memory, ... (MOCAP_E_SYSTEM)."""
    errno, default_code = E_SYSTEM, "system"


# Error.code -> class; the daemon's codes are mapped as libmocap maps them.
_ERROR_CLASSES = {
    "not running": NotRunning, "access": AccessDenied, "version": VersionMismatch, "protocol": ProtocolError,
    "malformed": ProtocolError, "handshake": ProtocolError, "disconnected": Disconnected,
    "shutdown": Disconnected, "timeout": Timeout, "permission": PermissionDenied, "unavailable": Unavailable,
    "failed": CommandFailed, "argument": ArgumentError, "system": SystemCallError,
}


def _error(code, message, server_code=None, fatal=False):
    """The exception for code (an Error.code name): refusals not listed are Refused."""
    return _ERROR_CLASSES.get(code, Refused)(code, message, server_code=server_code, fatal=fatal)


def _server_error(data, answer=False):
    """The exception an ERROR message stands for (answer: it answers a request of ours)."""
    r = _Reader(data)
    code, _req, fatal = r.take("IHH")
    msg = r.string()
    prefix = "mocapd closed the connection: " if fatal and not answer else ""
    return _error(SERVER_ERRORS.get(code, "refused"), prefix + msg, server_code=code, fatal=bool(fatal))


# --- data ---

Joint = namedtuple("Joint", "position orientation confidence")
JointDef = namedtuple("JointDef", "name parent rest_offset")
Camera = namedtuple("Camera", "name state width height fps frames drops")
Detector = namedtuple("Detector", "state rate used_rate ms_mean ms_last ms_max views skipped used model message")
Status = namedtuple("Status", "server_time_ns uptime_ns frames_published frames_dropped client_drops "
                              "publish_fps track_ms_mean track_ms_max tracker_state recording clients device cameras "
                              "detector latency")
# Where a frame set's time goes in the daemon (protocol version 3): per
# stage (LATENCY_STAGES) a StageTime of ms, over the newest `window` sets.
LATENCY_STAGES = ("ready", "wait", "decode", "track", "publish", "total")
StageTime = namedtuple("StageTime", "p50 p99 max")
Latency = namedtuple("Latency", "window ready wait decode track publish total skipped_behind skipped_stale incomplete")
Ring = namedtuple("Ring", "camera fd size")


class Skeleton(namedtuple("Skeleton", "id rig_is_world joints")):
    """The daemon's skeleton definition: joints is a list of JointDef (name, parent index, rest offset)."""

    @property
    def names(self):
        return [j.name for j in self.joints]

    def joint_index(self, name):
        """The index of the joint called name (KeyError if there is none)."""
        index = self.__dict__.get("_index")
        if index is None:
            index = self.__dict__["_index"] = {j.name: i for i, j in enumerate(self.joints)}
        return index[name]

    def joint(self, key):
        """The JointDef of a joint, by name or index."""
        return self.joints[self.joint_index(key) if isinstance(key, str) else key]


class Joints(list):
    """A frame's joints: a list (joints[0]) that can also be read by name
    (joints["left_wrist"], "left_wrist" in joints, joints.get(name),
    joints.items(), joints.as_dict()).  The names come from .skeleton, the
    SKELETON the frame follows, or are unknown (None) when the daemon had
    none to give."""

    __slots__ = ("skeleton", "_index")

    def __init__(self, joints=(), skeleton=None):
        super().__init__(joints)
        self._name(skeleton)

    def _name(self, skeleton):
        if skeleton is not None and len(skeleton.joints) == len(self):
            self.skeleton = skeleton
            self._index = {j.name: i for i, j in enumerate(skeleton.joints)}
        else:
            self.skeleton, self._index = None, None

    def __getitem__(self, key):
        if isinstance(key, str):
            return list.__getitem__(self, self.index_of(key))
        return list.__getitem__(self, key)

    def __contains__(self, key):
        if isinstance(key, str):
            return self._index is not None and key in self._index
        return list.__contains__(self, key)

    def index_of(self, name):
        """The index of the joint called name; KeyError if there is none or the names are unknown."""
        if self._index is None:
            raise KeyError("%r: joint names unknown (no SKELETON from mocapd for this frame)" % (name,))
        try:
            return self._index[name]
        except KeyError:
            raise KeyError("%r: no such joint in skeleton %d" % (name, self.skeleton.id)) from None

    def get(self, name, default=None):
        return list.__getitem__(self, self._index[name]) if name in self else default

    @property
    def names(self):
        """The joint names in order, or None when unknown."""
        return None if self.skeleton is None else self.skeleton.names

    def items(self):
        """(name, Joint) pairs; empty when the names are unknown."""
        return list(zip(self.names or (), self))

    def as_dict(self):
        return dict(self.items())

    def __reduce__(self):
        return (Joints, (list(self), self.skeleton))


class Frame(namedtuple("Frame", "seq capture_ns publish_ns receive_ns missed skeleton_id state space joints")):
    """One skeleton pose.  joints: a Joints list, also readable by name."""

    __slots__ = ()

    def joint(self, key):
        """A Joint by name ("left_wrist") or index."""
        return self.joints[key]

    @property
    def skeleton(self):
        """The Skeleton the joints follow, or None when unknown."""
        return getattr(self.joints, "skeleton", None)


def default_socket():
    return os.environ.get("MOCAP_SOCKET") or DEFAULT_SOCKET


def now_ns():
    """CLOCK_MONOTONIC in nanoseconds, the daemon's clock."""
    return time.clock_gettime_ns(time.CLOCK_MONOTONIC)


# --- encoding and decoding, shared by Client and AsyncClient ---

class _Reader:
    """Reads fields of one message; any overrun or leftover is a protocol error."""

    def __init__(self, data, pos=HEADER.size):
        self.data, self.pos = data, pos

    def take(self, fmt):
        s = struct.Struct("<" + fmt)
        if self.pos + s.size > len(self.data):
            raise ProtocolError("protocol", "message from mocapd is truncated")
        v = s.unpack_from(self.data, self.pos)
        self.pos += s.size
        return v if len(v) > 1 else v[0]

    def string(self):
        n = self.take("H")
        if self.pos + n > len(self.data):
            raise ProtocolError("protocol", "string runs past the end of the message")
        s = self.data[self.pos:self.pos + n].decode("utf-8", "replace")
        self.pos += n
        return s

    def end(self):
        if self.pos != len(self.data):
            raise ProtocolError("protocol", "%d trailing bytes in a message from mocapd" % (len(self.data) - self.pos))


def _str16(s):
    b = s.encode("utf-8")
    if len(b) > 0xFFFF:
        raise ArgumentError("argument", "string too long")
    return struct.pack("<H", len(b)) + b


def _message(type_, body, request_id):
    return HEADER.pack(type_, 0, HEADER.size + len(body), request_id, 0) + body


def _header(data, path):
    """(type, request_id) of a received datagram, checked."""
    if not data:
        raise Disconnected("disconnected", "mocapd closed the connection (%s)" % path)
    if len(data) < HEADER.size:
        raise ProtocolError("protocol", "message from mocapd shorter than a header")
    type_, _flags, size, rid, _res = HEADER.unpack_from(data)
    if size != len(data):
        raise ProtocolError("protocol", "size field %d, datagram %d bytes" % (size, len(data)))
    return type_, rid


# --- TCP: a daemon on another machine ([network] in its config) ---

TCP_SCHEME = "tcp://"
TOKEN_ENV, TOKEN_FILE_ENV = "MOCAP_TOKEN", "MOCAP_TOKEN_FILE"
TCP_PREFIX = struct.Struct("<I")  # each message on the stream follows its length


def _is_tcp(path):
    return path.startswith(TCP_SCHEME)


def _tcp_host_port(address):
    host, sep, port = address[len(TCP_SCHEME):].rpartition(":")
    if host.startswith("[") and host.endswith("]"):
        host = host[1:-1]
    if not sep or not host or not port.isdigit() or int(port) > 65535:
        raise ArgumentError("argument", "%s: expected tcp://HOST:PORT" % address)
    return host, int(port)


def _tcp_token(token):
    """The token: the argument, else $MOCAP_TOKEN, else the first line of $MOCAP_TOKEN_FILE."""
    token = token or os.environ.get(TOKEN_ENV)
    if token:
        return token
    path = os.environ.get(TOKEN_FILE_ENV)
    if not path:
        raise AccessDenied("access", "a TCP connection needs the daemon's token: give token= or set %s or %s"
                           % (TOKEN_ENV, TOKEN_FILE_ENV))
    try:
        with open(path, encoding="utf-8") as f:
            token = f.readline().strip("\r\n")
    except OSError as e:
        raise ArgumentError("argument", "%s=%s: %s" % (TOKEN_FILE_ENV, path, e.strerror or e)) from None
    if not token:
        raise ArgumentError("argument", "%s=%s: the file is empty" % (TOKEN_FILE_ENV, path))
    return token


def _tcp_socket(family):
    sock = socket.socket(family, socket.SOCK_STREAM)
    sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_KEEPALIVE, 1)
    return sock


def _tcp_connect_error(address, e):
    if isinstance(e, ConnectionRefusedError):
        return NotRunning("not running", "daemon not running at %s (nobody listens there; is [network] listen "
                          "set?)" % address)
    if isinstance(e, socket.timeout):
        return Timeout("timeout", "cannot connect to %s: timed out" % address)
    return NotRunning("not running", "cannot connect to %s: %s" % (address, getattr(e, "strerror", None) or e))


class _Stream:
    """Messages out of a TCP byte stream: each is a u32 length, then the message."""

    def __init__(self):
        self._buf = bytearray()

    def feed(self, data):
        self._buf += data

    def take(self):
        """The next whole message, or None."""
        if len(self._buf) < TCP_PREFIX.size:
            return None
        (n,) = TCP_PREFIX.unpack_from(self._buf)
        if n < HEADER.size or n > MAX_MESSAGE:
            raise ProtocolError("protocol", "mocapd sent a bad TCP length prefix (%d)" % n)
        end = TCP_PREFIX.size + n
        if len(self._buf) < end:
            return None
        data = bytes(self._buf[TCP_PREFIX.size:end])
        del self._buf[:end]
        return data

    def next_from(self, sock):
        """The next message as (data, []), reading sock as long as it gives bytes (within its
        timeout); None when no whole message came, (b"", []) at the stream's end."""
        while True:
            data = self.take()
            if data is not None:
                return data, []
            chunk = _recv_chunk(sock)
            if chunk is None:
                return None
            if not chunk:
                return b"", []  # _header says the daemon closed the connection
            self.feed(chunk)

    def has_message(self):
        return len(self._buf) >= TCP_PREFIX.size and \
            len(self._buf) >= TCP_PREFIX.size + TCP_PREFIX.unpack_from(self._buf)[0]

    @staticmethod
    def frame(message):
        return TCP_PREFIX.pack(len(message)) + message


def _recv_chunk(sock):
    """TCP: the bytes that came, None when none came in time, b"" at the stream's end."""
    try:
        return sock.recv(MAX_MESSAGE)
    except (socket.timeout, BlockingIOError):
        return None
    except OSError as e:
        raise Disconnected("disconnected", "connection to mocapd lost: %s" % (e.strerror or e)) from None


def _auth_body(token):
    if len(token.encode("utf-8")) > 255:
        raise ArgumentError("argument", "the token is longer than 255 bytes")
    return _str16(token)


def _new_socket():
    try:
        return socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET)
    except OSError as e:
        raise SystemCallError("system", "socket: %s" % (e.strerror or e)) from None


def _connect_error(path, e):
    """The exception for a failed connect() to path."""
    if isinstance(e, FileNotFoundError):
        return NotRunning("not running", "daemon not running at %s (no socket there; is mocapd started?)" % path)
    if isinstance(e, ConnectionRefusedError):
        return NotRunning("not running", "daemon not running at %s (the socket is left over, nobody listens)" % path)
    if isinstance(e, PermissionError):
        return AccessDenied("access", "permission denied connecting to %s: your user needs to be in the daemon's "
                            "group" % path)
    if e.errno == _errno.EPROTOTYPE:
        return ProtocolError("protocol", "%s is not a mocapd socket (wrong socket type)" % path)
    if e.errno in (_errno.ENOTDIR, _errno.ENOTSOCK):
        return NotRunning("not running", "daemon not running at %s (%s)" % (path, e.strerror))
    if e.errno in (_errno.EMFILE, _errno.ENFILE, _errno.ENOMEM, _errno.ENOBUFS):
        return SystemCallError("system", "cannot connect to %s: %s" % (path, e.strerror))
    if "too long" in str(e):
        return ArgumentError("argument", "socket path too long: %s" % path)
    return NotRunning("not running", "cannot connect to %s: %s" % (path, e.strerror or e))


def _hello_body(name):
    return struct.pack("<IHH", MAGIC, PROTOCOL_MIN_VERSION, PROTOCOL_VERSION) + _str16(name[:63])


def _subscribe_body(mode, space, queue_len):
    if mode not in (LATEST, ALL):
        raise ArgumentError("argument", "subscribe: mode must be mocap.LATEST or mocap.ALL")
    if space not in (SPACE_RIG, SPACE_WORLD):
        raise ArgumentError("argument", "subscribe: space must be mocap.SPACE_RIG or mocap.SPACE_WORLD")
    if not 0 <= queue_len <= 0xFFFFFFFF:
        raise ArgumentError("argument", "subscribe: queue_len out of range")
    return struct.pack("<BBHI", mode, space, 0, queue_len)


def _keypoints_body(capture_ns, camera, keypoints):
    if not 0 <= camera <= 0xFFFF:
        raise ArgumentError("argument", "keypoints: camera %d out of range" % camera)
    try:
        body = struct.pack("<QHHI", capture_ns, camera, len(keypoints), 0)
        return body + b"".join(struct.pack("<HHfff", j, 0, u, v, c) for j, u, v, c in keypoints)
    except (struct.error, TypeError, ValueError) as e:
        raise ArgumentError("argument", "keypoints: %s" % e) from None


def _head_pose_body(timestamp_ns, position, orientation_wxyz):
    try:
        return struct.pack("<Q3d4d", timestamp_ns, *position, *orientation_wxyz)
    except (struct.error, TypeError) as e:
        raise ArgumentError("argument", "head pose: %s" % e) from None


def _control_body(command, argument):
    return struct.pack("<I", command) + _str16(argument)


def _parse_welcome(r):
    _magic, version, flags, _max, pid, _t = r.take("IHHIIQ")
    return version, bool(flags & 1), pid, r.string()


def _parse_skeleton(data):
    r = _Reader(data)
    sid, nj, world, _ = r.take("IHBB")
    table = [r.take("iI3d") for _ in range(nj)]
    names = [r.string() for _ in range(nj)]
    r.end()
    return Skeleton(sid, bool(world), [JointDef(n, t[0], t[2:5]) for n, t in zip(names, table)])


_JOINT = struct.Struct("<7dfI")


def _parse_frame(data, missed, skeletons):
    r = _Reader(data)
    seq, cap, pub, sid, nj, state, space = r.take("QQQIHBB")
    if r.pos + nj * _JOINT.size != len(data):
        raise ProtocolError("protocol", "FRAME of %d joints is %d bytes" % (nj, len(data)))
    joints = Joints([Joint(v[0:3], v[3:7], v[7]) for v in _JOINT.iter_unpack(data[r.pos:])], skeletons.get(sid))
    return Frame(seq, cap, pub, now_ns(), missed, sid, TRACK_STATES.get(state, str(state)),
                 "world" if space == SPACE_WORLD else "rig", joints)


def _parse_status(r):
    now, start, pub, dropped, cdrops = r.take("QQQQQ")
    fps, tmean, tmax = r.take("3d")
    state, rec, ncams, nclients = r.take("BBHI")
    cams = [r.take("dQQIIII") for _ in range(ncams)]
    device = r.string()
    names = [r.string() for _ in range(ncams)]
    detector = None  # a version 1 daemon: unknown
    if r.pos < len(r.data):
        dstate, _res = r.take("II")
        figures = r.take("5d")
        counts = r.take("3Q")
        detector = Detector(DETECTOR_STATES.get(dstate, str(dstate)), *figures, *counts, r.string(), r.string())
    latency = None  # a version 1 or 2 daemon: unknown
    if r.pos < len(r.data):
        window, _res = r.take("II")
        stages = [StageTime(*r.take("3d")) for _ in LATENCY_STAGES]
        latency = Latency(window, *stages, *r.take("3Q"))
    r.end()
    cameras = [Camera(n, CAMERA_STATES.get(c[3], str(c[3])), c[4], c[5], c[0], c[1], c[2])
               for n, c in zip(names, cams)]
    return Status(now, max(0, now - start), pub, dropped, cdrops, fps, tmean, tmax,
                  TRACK_STATES.get(state, str(state)), bool(rec), nclients, device, cameras, detector, latency)


def _parse_rig(r):
    _ncams, length = r.take("II")
    text = r.data[r.pos:r.pos + length]
    r.pos += length
    r.end()
    return text.decode("utf-8", "replace")


def _parse_control_result(r):
    _cmd, result = r.take("Ii")
    msg = r.string()
    if result != 0:
        raise CommandFailed("failed", msg)
    return msg


def _parse_rings(r, fds):
    count = r.take("HHI")[0]
    try:
        sizes = [r.take("QQ")[0] for _ in range(count)]
        names = [r.string() for _ in range(count)]
        if len(fds) != count:
            raise ProtocolError("protocol", "RINGS lists %d rings but came with %d descriptors" % (count, len(fds)))
    except MocapError:
        _close_fds(fds)
        raise
    return [Ring(n, fd, s) for n, fd, s in zip(names, fds, sizes)]


# --- the latest-pose block (docs/PROTOCOL.md, "Latest-pose block") ---

POSE_BLOCK_MAGIC, POSE_BLOCK_SIZE, POSE_BLOCK_SLOTS = 0x4B4C4250, 33088, 4
PREDICT_MAX_NS, PREDICT_MAX_GAP_NS = 100_000_000, 200_000_000
_SLOT_HEAD = struct.Struct("<QQQIHBB")
_BLOCK_JOINT = struct.Struct("<3d4dfI")


class PoseBlock:
    """The daemon's latest-pose block, mapped read-only: the newest poses
    without a socket round trip.  From Client.pose_block(); close() it.
    (Waiting for the next pose on the block's futex is libmocap's:
    mocap_pose_block_wait; here, poll read() or subscribe.)"""

    def __init__(self, fd, size, skeleton_of):
        try:
            if size != POSE_BLOCK_SIZE:
                raise ProtocolError("protocol", "pose block of %d bytes, expected %d" % (size, POSE_BLOCK_SIZE))
            self._mm = mmap.mmap(fd, size, mmap.MAP_SHARED, mmap.PROT_READ)
        finally:
            os.close(fd)
        magic, version = struct.unpack_from("<II", self._mm, 0)
        if (magic, version) != (POSE_BLOCK_MAGIC, 1):
            self._mm.close()
            raise ProtocolError("protocol", "the daemon's pose block has another layout (version %d)" % version)
        self._skeleton_of = skeleton_of

    def close(self):
        self._mm.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def _slots(self, count):
        """The `count` newest slots' bytes, newest first, read under the seqlock."""
        mm = self._mm
        for _ in range(100000):
            lock = struct.unpack_from("<I", mm, 8)[0]
            if lock & 1:
                continue
            written = struct.unpack_from("<Q", mm, 16)[0]
            out = []
            for i in range(min(count, written)):
                at = 64 + ((written - 1 - i) % POSE_BLOCK_SLOTS) * 8256
                njoints = min(struct.unpack_from("<H", mm, at + 28)[0], 128)
                out.append(mm[at:at + 64 + 64 * njoints])
            if struct.unpack_from("<I", mm, 8)[0] == lock:
                return out
        raise Timeout("timeout", "the pose block stayed busy")

    def _frame(self, data):
        seq, capture, publish, sid, njoints, state, space = _SLOT_HEAD.unpack_from(data, 0)
        joints = [Joint(tuple(v[0:3]), tuple(v[3:7]), v[7])
                  for v in (_BLOCK_JOINT.unpack_from(data, 64 + 64 * j) for j in range(njoints))]
        return Frame(seq, capture, publish, now_ns(), 0, sid, TRACK_STATES.get(state, str(state)),
                     "world" if space else "rig", Joints(joints, self._skeleton_of(sid)))

    def read(self):
        """The newest pose as a Frame, or None before the first."""
        slots = self._slots(1)
        return self._frame(slots[0]) if slots else None

    def predict(self, t_ns):
        """The newest pose predicted to t_ns (see predict()), or None before the first."""
        slots = [self._frame(s) for s in self._slots(2)]
        if not slots:
            return None
        return predict(slots[1] if len(slots) > 1 else None, slots[0], t_ns)


def _quat_mul(a, b):
    return (a[0] * b[0] - a[1] * b[1] - a[2] * b[2] - a[3] * b[3],
            a[0] * b[1] + a[1] * b[0] + a[2] * b[3] - a[3] * b[2],
            a[0] * b[2] - a[1] * b[3] + a[2] * b[0] + a[3] * b[1],
            a[0] * b[3] + a[1] * b[2] - a[2] * b[1] + a[3] * b[0])


def _rotate_on(older, newer, s):
    """newer turned on by s times the rotation from older to newer (w, x, y, z)."""
    d = _quat_mul(newer, (older[0], -older[1], -older[2], -older[3]))
    if d[0] < 0:
        d = tuple(-x for x in d)
    v = math.sqrt(d[1] ** 2 + d[2] ** 2 + d[3] ** 2)
    half = math.atan2(v, d[0]) * s
    k = math.sin(half) / v if v > 1e-12 else s
    q = _quat_mul((math.cos(half), d[1] * k, d[2] * k, d[3] * k), newer)
    n = math.sqrt(sum(x * x for x in q)) or 1.0
    return tuple(x / n for x in q)


def predict(older, newer, t_ns):
    """newer extrapolated to t_ns from the motion between older and newer, as
    libmocap's mocap_predict: constant velocity on positions, constant angular
    velocity on orientations, at most PREDICT_MAX_NS ahead (clamped), from frames of
    the same skeleton at most PREDICT_MAX_GAP_NS apart (else newer as it is)."""
    if (older is None or older.skeleton_id != newer.skeleton_id or len(older.joints) != len(newer.joints)
            or older.space != newer.space or not 0 < newer.capture_ns - older.capture_ns <= PREDICT_MAX_GAP_NS):
        return newer
    ahead = max(-PREDICT_MAX_NS, min(PREDICT_MAX_NS, t_ns - newer.capture_ns))
    s = ahead / (newer.capture_ns - older.capture_ns)
    joints = [Joint(tuple(b + (b - a) * s for a, b in zip(jo.position, jn.position)),
                    _rotate_on(jo.orientation, jn.orientation, s), jn.confidence)
              for jo, jn in zip(older.joints, newer.joints)]
    return newer._replace(capture_ns=newer.capture_ns + ahead, joints=Joints(joints, newer.joints.skeleton))


def _close_fds(fds):
    for fd in fds:
        os.close(fd)


_RECV_FLAGS = getattr(socket, "MSG_CMSG_CLOEXEC", 0)


class _Session:
    """The protocol state both clients keep: request ids, the subscription,
    frames received and not yet read, gaps, and the skeleton definitions
    that name the frames' joints."""

    SKELETONS_KEPT = 8
    MAX_BACKLOG = 4096  # frames received and not read; beyond, the oldest go (counted in missed)

    def _init_session(self, path, timeout):
        self.path = path or default_socket()
        self.timeout = timeout
        self.version = None
        self.privileged = False
        self.server_pid = None
        self.daemon_version = None
        self._next_id = 1
        self._frames = collections.deque()   # frames received, not yet read
        self._missed = 0                      # gap counts not yet attached to a frame
        self._mode = 0
        self._skeletons = {}                  # skeleton_id -> Skeleton, newest last
        self._asked = set()                   # skeleton ids asked for with GET_SKELETON

    def _take_id(self):
        rid = self._next_id
        self._next_id = (self._next_id % 0xFFFFFFFF) + 1
        return rid

    def _reset_frames(self, mode):
        self._mode = mode
        self._frames.clear()
        self._missed = 0

    def _keep_skeleton(self, sk):
        self._skeletons.pop(sk.id, None)
        self._skeletons[sk.id] = sk
        while len(self._skeletons) > self.SKELETONS_KEPT:
            del self._skeletons[next(iter(self._skeletons))]
        # Frames that came before their definition get their names now.
        for f in self._frames:
            if f.skeleton_id == sk.id and f.joints.skeleton is None:
                f.joints._name(sk)

    def _file_frame(self, data):
        if not self._mode:
            return
        frame = _parse_frame(data, self._missed, self._skeletons)
        self._missed = 0
        if self._mode == LATEST:
            self._frames.clear()
        elif self._frames and len(self._frames) >= self.MAX_BACKLOG:  # an application that never reads them
            old = self._frames.popleft()
            if self._frames:
                self._frames[0] = self._frames[0]._replace(missed=self._frames[0].missed + old.missed + 1)
            else:
                frame = frame._replace(missed=frame.missed + old.missed + 1)
        self._frames.append(frame)

    def _file_gap(self, data):
        _first, count = _Reader(data).take("QQ")
        self._missed += count

    def _needs_skeleton(self, frame):
        """True when the client should ask the daemon for the frame's skeleton definition."""
        return frame.joints.skeleton is None and frame.skeleton_id not in self._asked

    def _name_frame(self, frame, sk):
        self._asked.add(frame.skeleton_id)
        if sk is not None and sk.id == frame.skeleton_id:
            frame.joints._name(sk)

    def _check_subscribed(self):
        if not self._mode and not self._frames:
            raise ArgumentError("argument", "not subscribed (call subscribe first)")


# --- the blocking client ---

class Client(_Session):
    """A connection to mocapd.  Blocking; use one Client per thread."""

    def __init__(self, path=None, name="python", timeout=10.0, token=None):
        self._init_session(path, timeout)
        self._stream = None
        if _is_tcp(self.path):
            self._connect_tcp(token)
        else:
            self._sock = _new_socket()
            try:
                self._sock.connect(self.path)
            except OSError as e:
                self._sock.close()
                raise _connect_error(self.path, e) from None
        try:
            if self._stream is not None:
                self._request(AUTH, _auth_body(self._token), OK)
            r = self._request(HELLO, _hello_body(name), WELCOME)
            self.version, self.privileged, self.server_pid, self.daemon_version = _parse_welcome(r)
        except BaseException:
            self._sock.close()
            raise

    def close(self):
        self._sock.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def _connect_tcp(self, token):
        self._token = _tcp_token(token)
        host, port = _tcp_host_port(self.path)
        try:
            family = socket.getaddrinfo(host, port, type=socket.SOCK_STREAM)[0][0]
            self._sock = _tcp_socket(family)
        except OSError as e:
            raise _tcp_connect_error(self.path, e) from None
        try:
            self._sock.settimeout(self.timeout)
            self._sock.connect((host, port))
        except OSError as e:
            self._sock.close()
            raise _tcp_connect_error(self.path, e) from None
        self._stream = _Stream()

    # --- transport ---

    def _send(self, type_, body=b"", request_id=0):
        message = _message(type_, body, request_id)
        if self._stream is not None:
            message = _Stream.frame(message)
        try:
            self._sock.settimeout(self.timeout)
            self._sock.sendall(message)
        except socket.timeout:
            raise Timeout("timeout", "mocapd does not read our messages") from None
        except OSError as e:
            raise Disconnected("disconnected", "sending to mocapd: %s" % (e.strerror or e)) from None

    def _recv_stream(self, timeout):
        """TCP: the next whole message and no fds, or None on timeout."""
        self._sock.settimeout(timeout)
        return self._stream.next_from(self._sock)

    def _recv(self, timeout):
        """One message (type, request_id, bytes, fds), or None on timeout."""
        if self._stream is not None:
            got = self._recv_stream(timeout)
            if got is None:
                return None
            data, fds = got
        else:
            self._sock.settimeout(timeout)
            try:
                data, fds, _flags, _addr = socket.recv_fds(self._sock, MAX_MESSAGE, MAX_FDS, _RECV_FLAGS)
            except (socket.timeout, BlockingIOError):
                return None
            except OSError as e:
                raise Disconnected("disconnected", "connection to mocapd lost: %s" % (e.strerror or e)) from None
        try:
            type_, rid = _header(data, self.path)
        except MocapError:
            _close_fds(fds)
            raise
        return type_, rid, data, fds

    def _file(self, type_, rid, data, fds):
        """Files a message that answers no request in progress."""
        _close_fds(fds)
        if type_ == FRAME:
            self._file_frame(data)
        elif type_ == GAP:
            self._file_gap(data)
        elif type_ == SKELETON:
            self._keep_skeleton(_parse_skeleton(data))
        elif type_ == ERROR:  # unsolicited, or a refusal of a keypoint batch or head pose
            raise _server_error(data)

    def _request(self, type_, body, want, fds_out=None):
        rid = self._take_id()
        self._send(type_, body, rid)
        deadline = time.monotonic() + self.timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise Timeout("timeout", "no reply from mocapd within %.1f s" % self.timeout)
            m = self._recv(left)
            if m is None:
                continue
            mtype, mrid, data, fds = m
            if mrid != rid:
                self._file(mtype, mrid, data, fds)
                continue
            if mtype == ERROR:
                _close_fds(fds)
                raise _server_error(data, answer=True)  # a plain answer, even when fatal
            if mtype != want:
                _close_fds(fds)
                raise ProtocolError("protocol", "unexpected reply 0x%04x" % mtype)
            if fds_out is not None:
                fds_out.extend(fds)
            else:
                _close_fds(fds)
            return _Reader(data)

    # --- API ---

    def subscribe(self, mode=LATEST, space=SPACE_RIG, queue_len=0):
        """LATEST: only the newest frame (VR); ALL: every frame, gaps counted in Frame.missed.
        Returns the daemon's queue length in effect."""
        body = _subscribe_body(mode, space, queue_len)
        self._reset_frames(0)
        r = self._request(SUBSCRIBE, body, OK)
        self._reset_frames(mode)
        return r.take("HHI")[2]

    def unsubscribe(self):
        self._reset_frames(0)
        self._request(UNSUBSCRIBE, b"", OK)

    def read_frame(self, timeout=None):
        """The next frame, or None after timeout seconds (None: wait forever)."""
        self._check_subscribed()
        deadline = None if timeout is None else time.monotonic() + timeout
        if self._mode == LATEST:
            # Take in everything already there, to return the newest frame.
            while True:
                m = self._recv(0.0)
                if m is None:
                    break
                self._file(*m)
        while not self._frames:
            left = None if deadline is None else max(0.0, deadline - time.monotonic())
            m = self._recv(left)
            if m is None:
                return None
            self._file(*m)
        frame = self._frames.popleft()
        if self._needs_skeleton(frame):
            try:
                sk = self.skeleton()
            except Unavailable:
                sk = None
            self._name_frame(frame, sk)
        return frame

    def frames(self, count=None, timeout=None):
        """Iterates over frames (count of them, or until a read times out)."""
        n = 0
        while count is None or n < count:
            f = self.read_frame(timeout)
            if f is None:
                return
            yield f
            n += 1

    def fileno(self):
        """For select/poll: readable when a frame or a reply has arrived."""
        return self._sock.fileno()

    def skeleton(self):
        """The daemon's skeleton definition (a Skeleton)."""
        sk = _parse_skeleton(self._request(GET_SKELETON, b"", SKELETON).data)
        self._keep_skeleton(sk)
        return sk

    def status(self):
        return _parse_status(self._request(GET_STATUS, b"", STATUS))

    def rig(self):
        """The rig in use, as JSON text."""
        return _parse_rig(self._request(GET_RIG, b"", RIG))

    def control(self, command, argument=""):
        """Runs CMD_RELOAD / CMD_RECORD_START / CMD_RECORD_STOP / CMD_ACTOR_SAVE / CMD_RECORD_STATUS /
        CMD_RECORD_LIST / CMD_STEER; returns the daemon's message.
        Raises CommandFailed when the command ran and failed."""
        return _parse_control_result(self._request(CONTROL, _control_body(command, argument), CONTROL_RESULT))

    def reload(self):
        return self.control(CMD_RELOAD)

    def save_actor(self, name):
        """Saves the calibrated actor as [tracker] actor_dir/NAME.json; returns the daemon's message."""
        return self.control(CMD_ACTOR_SAVE, name)

    def rings(self):
        """Read-only camera ring descriptors (close them when done)."""
        fds = []
        r = self._request(GET_RINGS, b"", RINGS, fds)
        return _parse_rings(r, fds)

    def pose_block(self):
        """The daemon's latest-pose block, mapped read-only (a PoseBlock; protocol
        version 3, not over TCP).  Frames it gives name their joints with this
        client's skeleton definitions."""
        if (self.version or 0) < 3:
            raise Unavailable("unavailable", "the daemon speaks protocol version %s; the pose block needs 3"
                              % self.version)
        fds = []
        r = self._request(GET_POSE_BLOCK, b"", POSE_BLOCK, fds)
        if len(fds) != 1:
            _close_fds(fds)
            raise ProtocolError("protocol", "POSE_BLOCK came with %d descriptors, expected 1" % len(fds))
        _version, _res, size = r.take("IIQ")
        return PoseBlock(fds[0], size, self._block_skeleton)

    def _block_skeleton(self, skeleton_id):
        sk = self._skeletons.get(skeleton_id)
        if sk is None and skeleton_id not in self._asked:
            self._asked.add(skeleton_id)
            try:
                sk = self.skeleton()
            except Unavailable:
                return None
        return sk if sk is not None and sk.id == skeleton_id else None

    def send_keypoints(self, capture_ns, camera, keypoints):
        """keypoints: [(joint, u, v, confidence), ...]; not acknowledged (a refusal is raised by a later call)."""
        self._send(KEYPOINTS, _keypoints_body(capture_ns, camera, keypoints), self._take_id())

    def send_head_pose(self, timestamp_ns, position, orientation_wxyz):
        """world_from_rig at timestamp_ns; not acknowledged."""
        self._send(HEAD_POSE, _head_pose_body(timestamp_ns, position, orientation_wxyz), self._take_id())

    def ping(self):
        """Round trip in seconds."""
        t = time.monotonic()
        self._request(PING, struct.pack("<Q", now_ns()), PONG)
        return time.monotonic() - t


# --- the asyncio client ---

class AsyncClient(_Session):
    """A connection to mocapd for asyncio: create it with `await mocap.aio.connect(...)`.

    Every method that talks to the daemon is a coroutine; any number of
    tasks may use one client at once (replies find their request by id).
    The socket is read by the event loop (loop.add_reader), so frames
    arrive while the application awaits something else; in ALL mode the
    client stops reading when max_queued frames wait unread and no request
    is in flight, so that the daemon's queue, not this process, holds the
    backlog (and counts what it drops in Frame.missed)."""

    def __init__(self, path=None, name="python", timeout=10.0, max_queued=None, token=None):
        self._init_session(path, timeout)
        self._name = name
        self._token = token
        self._stream = None           # TCP: messages out of the byte stream
        self._sock = None
        self._loop = None
        self._reading = False
        self._waiters = {}            # request id -> future of (type, data, fds)
        self._wakeup = None           # set when a frame or an error arrives
        self._send_lock = None
        self._dead = None             # the error that ended the connection
        self._pending = None          # a non-fatal refusal of something not acknowledged
        self._queue_limit = 256
        self.max_queued = max_queued  # None: the daemon's queue length, at least 64

    async def _open(self):
        self._loop = asyncio.get_running_loop()
        self._wakeup = asyncio.Event()
        self._send_lock = asyncio.Lock()
        if _is_tcp(self.path):
            sock = await self._connect_tcp()
        else:
            sock = _new_socket()
            sock.setblocking(False)
            try:
                await self._loop.sock_connect(sock, self.path)
            except OSError as e:
                sock.close()
                raise _connect_error(self.path, e) from None
            except BaseException:
                sock.close()
                raise
        self._sock = sock
        self._resume()
        try:
            if self._stream is not None:
                await self._ask(AUTH, _auth_body(self._token), OK)
            r = await self._ask(HELLO, _hello_body(self._name), WELCOME)
            self.version, self.privileged, self.server_pid, self.daemon_version = _parse_welcome(r)
        except BaseException:
            self.close()
            raise
        return self

    async def _connect_tcp(self):
        self._token = _tcp_token(self._token)
        host, port = _tcp_host_port(self.path)
        try:
            family, _type, _proto, _name, addr = (await self._loop.getaddrinfo(host, port,
                                                                               type=socket.SOCK_STREAM))[0]
            sock = _tcp_socket(family)
        except OSError as e:
            raise _tcp_connect_error(self.path, e) from None
        sock.setblocking(False)
        try:
            await asyncio.wait_for(self._loop.sock_connect(sock, addr), self.timeout)
        except (OSError, asyncio.TimeoutError) as e:
            sock.close()
            raise _tcp_connect_error(self.path, socket.timeout() if isinstance(e, asyncio.TimeoutError) else e) \
                from None
        except BaseException:
            sock.close()
            raise
        self._stream = _Stream()
        return sock

    def close(self):
        """Closes the connection; requests and reads in progress raise Disconnected."""
        if self._sock is None:
            return
        self._pause()
        self._die(Disconnected("disconnected", "the connection was closed (close())"))
        self._sock.close()
        self._sock = None

    async def aclose(self):
        self.close()

    async def __aenter__(self):
        return self

    async def __aexit__(self, *exc):
        self.close()

    def fileno(self):
        return self._sock.fileno() if self._sock is not None else -1

    # --- transport ---

    def _resume(self):
        if not self._reading and self._sock is not None and self._dead is None:
            self._loop.add_reader(self._sock.fileno(), self._on_readable)
            self._reading = True
            if self._stream is not None and self._stream.has_message():
                self._loop.call_soon(self._on_readable)  # received before the pause

    def _pause(self):
        if self._reading:
            self._loop.remove_reader(self._sock.fileno())
            self._reading = False

    def _die(self, err):
        if self._dead is None:
            self._dead = err
        self._pause()
        for fut, _on_reply in self._waiters.values():
            if not fut.done():
                fut.set_exception(self._dead_error())
        self._waiters.clear()
        self._wakeup.set()

    def _raise_pending(self):
        """A refusal of keypoints or a head pose sent before, if one came."""
        if self._pending is not None:
            err, self._pending = self._pending, None
            raise err

    def _dead_error(self):
        """A new exception like the one that ended the connection (one per caller)."""
        return _error(self._dead.code, str(self._dead), self._dead.server_code, self._dead.fatal)

    def _raise_if_dead(self):
        if self._dead is not None:
            raise self._dead_error()

    def _receive(self):
        """The next message (data, fds) from the socket, or None when nothing
        is there; the connection's end raises."""
        if self._stream is not None:
            return self._stream.next_from(self._sock)
        try:
            data, fds, _flags, _addr = socket.recv_fds(self._sock, MAX_MESSAGE, MAX_FDS, _RECV_FLAGS)
        except BlockingIOError:
            return None
        except OSError as e:
            raise Disconnected("disconnected", "connection to mocapd lost: %s" % (e.strerror or e)) from None
        return data, fds

    def _on_readable(self):
        """Reads what is there (up to a burst), filing each message."""
        for _ in range(64):
            if self._sock is None or self._dead is not None or not self._reading:
                return
            try:
                got = self._receive()
                if got is None:
                    return
                self._dispatch(*got)
            except MocapError as e:
                self._die(e)
                return
            # ALL mode: stop reading while enough frames wait and no reply is awaited,
            # so that the daemon's queue holds the backlog (and counts what it drops).
            if self._mode == ALL and len(self._frames) >= (self.max_queued or self._queue_limit) \
                    and not self._waiters:
                self._pause()
                return
        if self._stream is not None and self._stream.has_message():
            self._loop.call_soon(self._on_readable)  # the burst ended with messages buffered

    def _dispatch(self, data, fds):
        try:
            type_, rid = _header(data, self.path)
        except MocapError:
            _close_fds(fds)
            raise
        waiter = self._waiters.get(rid) if rid and type_ not in (FRAME, GAP) else None
        if waiter is not None and not waiter[0].done():
            del self._waiters[rid]
            if waiter[1] is not None:
                waiter[1](type_)
            waiter[0].set_result((type_, data, fds))
            if type_ == ERROR and _Reader(data).take("IHH")[2]:  # fatal: the daemon closes us
                self._die(_server_error(data))
            return
        _close_fds(fds)
        if type_ == FRAME:
            self._file_frame(data)
            self._wakeup.set()
        elif type_ == GAP:
            self._file_gap(data)
        elif type_ == SKELETON:
            self._keep_skeleton(_parse_skeleton(data))
        elif type_ == ERROR:
            err = _server_error(data)
            if err.fatal:
                self._die(err)
            else:  # raised by the next send_keypoints, send_head_pose or ping
                self._pending = err

    async def _send(self, type_, body, request_id):
        self._raise_if_dead()
        if self._sock is None:
            raise Disconnected("disconnected", "the connection was closed (close())")
        try:
            message = _message(type_, body, request_id)
            if self._stream is not None:
                message = _Stream.frame(message)
            async with self._send_lock:
                await asyncio.wait_for(self._loop.sock_sendall(self._sock, message), self.timeout)
        except asyncio.TimeoutError:
            raise Timeout("timeout", "mocapd does not read our messages") from None
        except OSError as e:
            err = Disconnected("disconnected", "sending to mocapd: %s" % (e.strerror or e))
            self._die(err)
            raise err from None

    async def _request(self, type_, body, want, keep_fds=False, on_reply=None):
        """Sends a request and waits for its reply.  on_reply(type) runs as soon
        as the reply is read, before any message after it is filed."""
        rid = self._take_id()
        fut = self._loop.create_future()
        self._waiters[rid] = (fut, on_reply)
        try:
            await self._send(type_, body, rid)
            self._resume()
            try:
                mtype, data, fds = await asyncio.wait_for(fut, self.timeout)
            except asyncio.TimeoutError:
                raise Timeout("timeout", "no reply from mocapd within %.1f s" % self.timeout) from None
        finally:
            self._waiters.pop(rid, None)
        if mtype == ERROR:
            _close_fds(fds)
            raise _server_error(data, answer=True)
        if mtype != want:
            _close_fds(fds)
            raise ProtocolError("protocol", "unexpected reply 0x%04x" % mtype)
        if not keep_fds:
            _close_fds(fds)
            fds = []
        return _Reader(data), fds

    async def _ask(self, type_, body, want, on_reply=None):
        return (await self._request(type_, body, want, on_reply=on_reply))[0]

    # --- API ---

    async def subscribe(self, mode=LATEST, space=SPACE_RIG, queue_len=0):
        """LATEST: only the newest frame (VR); ALL: every frame, gaps counted in Frame.missed.
        Returns the daemon's queue length in effect."""
        body = _subscribe_body(mode, space, queue_len)
        self._reset_frames(0)

        def on_reply(type_):  # frames may follow OK in the same burst of reads
            if type_ == OK:
                self._reset_frames(mode)
        r = await self._ask(SUBSCRIBE, body, OK, on_reply)
        n = r.take("HHI")[2]
        self._queue_limit = max(64, n)
        return n

    async def unsubscribe(self):
        self._reset_frames(0)
        await self._ask(UNSUBSCRIBE, b"", OK)

    async def read_frame(self, timeout=None):
        """The next frame, or None after timeout seconds (None: wait forever)."""
        self._check_subscribed()
        deadline = None if timeout is None else self._loop.time() + timeout
        if self._mode == LATEST:
            self._on_readable()  # take in what is already there, to return the newest
        while not self._frames:
            self._raise_if_dead()
            self._wakeup.clear()
            self._resume()
            if deadline is None:
                await self._wakeup.wait()
                continue
            left = deadline - self._loop.time()
            if left <= 0:
                return None
            try:
                await asyncio.wait_for(self._wakeup.wait(), left)
            except asyncio.TimeoutError:
                pass
        frame = self._frames.popleft()
        self._resume()
        if self._needs_skeleton(frame):
            try:
                sk = await self.skeleton()
            except Unavailable:
                sk = None
            self._name_frame(frame, sk)
        return frame

    async def frames(self, count=None, timeout=None):
        """Async iterator over frames (count of them, or until a read times out)."""
        n = 0
        while count is None or n < count:
            f = await self.read_frame(timeout)
            if f is None:
                return
            yield f
            n += 1

    async def skeleton(self):
        """The daemon's skeleton definition (a Skeleton)."""
        sk = _parse_skeleton((await self._ask(GET_SKELETON, b"", SKELETON)).data)
        self._keep_skeleton(sk)
        return sk

    async def status(self):
        return _parse_status(await self._ask(GET_STATUS, b"", STATUS))

    async def rig(self):
        """The rig in use, as JSON text."""
        return _parse_rig(await self._ask(GET_RIG, b"", RIG))

    async def control(self, command, argument=""):
        """Runs a CMD_* command; returns the daemon's message.  Raises CommandFailed when it failed."""
        return _parse_control_result(await self._ask(CONTROL, _control_body(command, argument), CONTROL_RESULT))

    async def reload(self):
        return await self.control(CMD_RELOAD)

    async def save_actor(self, name):
        return await self.control(CMD_ACTOR_SAVE, name)

    async def rings(self):
        """Read-only camera ring descriptors (close them when done)."""
        r, fds = await self._request(GET_RINGS, b"", RINGS, keep_fds=True)
        return _parse_rings(r, fds)

    async def send_keypoints(self, capture_ns, camera, keypoints):
        """keypoints: [(joint, u, v, confidence), ...]; not acknowledged: when the daemon
        refuses a batch, the next send_keypoints, send_head_pose or ping raises it."""
        body = _keypoints_body(capture_ns, camera, keypoints)
        self._raise_pending()
        await self._send(KEYPOINTS, body, self._take_id())

    async def send_head_pose(self, timestamp_ns, position, orientation_wxyz):
        """world_from_rig at timestamp_ns; not acknowledged (see send_keypoints)."""
        self._raise_pending()
        await self._send(HEAD_POSE, _head_pose_body(timestamp_ns, position, orientation_wxyz), self._take_id())

    async def ping(self):
        """Round trip in seconds."""
        self._raise_pending()
        t = time.monotonic()
        await self._ask(PING, struct.pack("<Q", now_ns()), PONG)
        self._raise_pending()  # a refusal sent before the PONG
        return time.monotonic() - t


class _Connecting:
    """What connect() returns: await it for the client, or use it in `async with`."""

    def __init__(self, *args):
        self._args = args
        self._client = None

    def __await__(self):
        return AsyncClient(*self._args)._open().__await__()

    async def __aenter__(self):
        self._client = await self
        return self._client

    async def __aexit__(self, *exc):
        self._client.close()


def connect(path=None, name="python", timeout=10.0, max_queued=None, token=None):
    """Connects an AsyncClient: `c = await mocap.aio.connect()`, or
    `async with mocap.aio.connect() as c: ...` (closed at the end).
    path may be "tcp://HOST:PORT" (token: the daemon's, else $MOCAP_TOKEN
    or $MOCAP_TOKEN_FILE)."""
    return _Connecting(path, name, timeout, max_queued, token)


# mocap.aio: the asyncio API under its own name, importable as a submodule
# (`import mocap.aio`) while this stays one file, as os.path is.
aio = types.ModuleType(__name__ + ".aio", "The asyncio client of mocapd: await mocap.aio.connect(path, name).")
aio.connect = connect
aio.Client = aio.AsyncClient = AsyncClient
aio.__all__ = ["connect", "Client", "AsyncClient"]
sys.modules[aio.__name__] = aio
