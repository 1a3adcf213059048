"""mocap: a client of mocapd for lab scripts, in pure Python (standard library).

Speaks protocol versions 1 and 2 of docs/PROTOCOL.md over the daemon's
SOCK_SEQPACKET Unix socket.  Single-threaded: use one Client per thread.

    import mocap
    with mocap.Client() as c:                  # $MOCAP_SOCKET or /run/mocapd/mocapd.sock
        print(c.status())
        skel = c.skeleton()
        c.subscribe(mocap.ALL)                 # every frame; or mocap.LATEST
        for frame in c.frames(count=100):
            print(frame.seq, frame.missed, frame.joints[0].position)

Errors are raised as mocap.Error (with .code, one of the ERR_* names)."""

import os
import socket
import struct
import time
from collections import namedtuple

PROTOCOL_VERSION = 2      # the highest spoken; 1 too (2 adds STATUS's detector block)
PROTOCOL_MIN_VERSION = 1
MAGIC = 0x50434F4D
HEADER = struct.Struct("<HHIII")  # type, flags, size, request_id, reserved
MAX_MESSAGE = 65536
DEFAULT_SOCKET = "/run/mocapd/mocapd.sock"

LATEST, ALL = 1, 2
SPACE_RIG, SPACE_WORLD = 0, 1
CMD_RELOAD, CMD_RECORD_START, CMD_RECORD_STOP, CMD_ACTOR_SAVE = 1, 2, 3, 4
TRACK_STATES = {0: "ok", 1: "uncertain", 2: "lost", 3: "idle", 4: "initialising"}
CAMERA_STATES = {0: "ok", 1: "stalled", 2: "error", 3: "off"}

# Message types.
HELLO, SUBSCRIBE, UNSUBSCRIBE, GET_STATUS, GET_SKELETON, GET_RIG = 0x1, 0x2, 0x3, 0x4, 0x5, 0x6
CONTROL, GET_RINGS, KEYPOINTS, HEAD_POSE, PING = 0x7, 0x8, 0x9, 0xA, 0xB
WELCOME, ERROR, OK, SKELETON, FRAME, GAP = 0x8001, 0x8002, 0x8003, 0x8004, 0x8005, 0x8006
STATUS, RIG, CONTROL_RESULT, RINGS, PONG = 0x8007, 0x8008, 0x8009, 0x800A, 0x800B

# Server error codes (ERROR message) and the names Error.code uses.
SERVER_ERRORS = {1: "version", 2: "malformed", 3: "handshake", 4: "permission", 5: "invalid",
                 6: "unavailable", 7: "busy", 8: "too many clients", 9: "overload", 10: "shutdown"}

Joint = namedtuple("Joint", "position orientation confidence")
JointDef = namedtuple("JointDef", "name parent rest_offset")
Skeleton = namedtuple("Skeleton", "id rig_is_world joints")
Frame = namedtuple("Frame", "seq capture_ns publish_ns receive_ns missed skeleton_id state space joints")
Camera = namedtuple("Camera", "name state width height fps frames drops")
Detector = namedtuple("Detector", "state rate used_rate ms_mean ms_last ms_max views skipped used model message")
Status = namedtuple("Status", "server_time_ns uptime_ns frames_published frames_dropped client_drops "
                              "publish_fps track_ms_mean track_ms_max tracker_state recording clients device cameras "
                              "detector")
DETECTOR_STATES = {0: "off", 1: "running", 2: "failed"}
Ring = namedtuple("Ring", "camera fd size")


class Error(Exception):
    """A failure; .code is e.g. "not running", "permission", "version", "disconnected"."""

    def __init__(self, code, message):
        super().__init__(message)
        self.code = code


def default_socket():
    return os.environ.get("MOCAP_SOCKET") or DEFAULT_SOCKET


def now_ns():
    """CLOCK_MONOTONIC in nanoseconds, the daemon's clock."""
    return time.clock_gettime_ns(time.CLOCK_MONOTONIC)


class _Reader:
    """Reads fields of one message; any overrun or leftover is a protocol error."""

    def __init__(self, data, pos=HEADER.size):
        self.data, self.pos = data, pos

    def take(self, fmt):
        s = struct.Struct("<" + fmt)
        if self.pos + s.size > len(self.data):
            raise Error("protocol", "message from mocapd is truncated")
        v = s.unpack_from(self.data, self.pos)
        self.pos += s.size
        return v if len(v) > 1 else v[0]

    def string(self):
        n = self.take("H")
        if self.pos + n > len(self.data):
            raise Error("protocol", "string runs past the end of the message")
        s = self.data[self.pos:self.pos + n].decode("utf-8", "replace")
        self.pos += n
        return s

    def end(self):
        if self.pos != len(self.data):
            raise Error("protocol", "%d trailing bytes in a message from mocapd" % (len(self.data) - self.pos))


def _str16(s):
    b = s.encode("utf-8")
    if len(b) > 0xFFFF:
        raise Error("argument", "string too long")
    return struct.pack("<H", len(b)) + b


class Client:
    def __init__(self, path=None, name="python", timeout=10.0):
        self.path = path or default_socket()
        self.timeout = timeout
        self._next_id = 1
        self._frames = []          # frames read while waiting for a reply
        self._missed = 0           # gap counts not yet attached to a frame
        self._mode = 0
        self._skeleton = None
        self._sock = socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        try:
            self._sock.connect(self.path)
        except FileNotFoundError:
            self._sock.close()
            raise Error("not running", "daemon not running at %s (no socket there; is mocapd started?)" % self.path)
        except ConnectionRefusedError:
            self._sock.close()
            raise Error("not running", "daemon not running at %s (the socket is left over, nobody listens)" % self.path)
        except PermissionError:
            self._sock.close()
            raise Error("access", "permission denied connecting to %s: your user needs to be in the daemon's group"
                        % self.path)
        except OSError as e:
            self._sock.close()
            raise Error("not running", "cannot connect to %s: %s" % (self.path, e.strerror))
        body = struct.pack("<IHH", MAGIC, PROTOCOL_MIN_VERSION, PROTOCOL_VERSION) + _str16(name[:63])
        r = self._request(HELLO, body, WELCOME)
        magic, self.version, flags, _max, self.server_pid, _t = r.take("IHHIIQ")
        self.daemon_version = r.string()
        self.privileged = bool(flags & 1)

    def close(self):
        self._sock.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # --- transport ---

    def _send(self, type_, body=b"", request_id=0):
        msg = HEADER.pack(type_, 0, HEADER.size + len(body), request_id, 0) + body
        try:
            self._sock.sendall(msg)
        except OSError as e:
            raise Error("disconnected", "sending to mocapd: %s" % e.strerror)

    def _recv(self, timeout):
        """One message (type, request_id, bytes, fds), or None on timeout."""
        self._sock.settimeout(timeout)
        try:
            data, fds, flags, _addr = socket.recv_fds(self._sock, MAX_MESSAGE, 16)
        except (socket.timeout, BlockingIOError):
            return None
        except OSError as e:
            raise Error("disconnected", "connection to mocapd lost: %s" % e.strerror)
        if not data:
            raise Error("disconnected", "mocapd closed the connection (%s)" % self.path)
        if len(data) < HEADER.size:
            raise Error("protocol", "message from mocapd shorter than a header")
        type_, _flags, size, rid, _res = HEADER.unpack_from(data)
        if size != len(data):
            raise Error("protocol", "size field %d, datagram %d bytes" % (size, len(data)))
        return type_, rid, data, fds

    def _file(self, type_, rid, data, fds):
        """Files an unsolicited message; returns True if it was one."""
        if type_ == FRAME:
            if self._mode:
                frame = self._parse_frame(data)
                if self._mode == LATEST:
                    self._frames = [frame]
                else:
                    self._frames.append(frame)
            return True
        if type_ == GAP:
            first, count = _Reader(data).take("QQ")
            self._missed += count
            return True
        if type_ == SKELETON and rid == 0:
            self._skeleton = self._parse_skeleton(data)
            return True
        if type_ == ERROR:  # unsolicited, or a refusal of a keypoint batch or head pose
            r = _Reader(data)
            code, _req, fatal = r.take("IHH")
            msg = r.string()
            raise Error(SERVER_ERRORS.get(code, "refused"), ("mocapd closed the connection: " if fatal else "") + msg)
        for fd in fds:
            os.close(fd)
        return False

    def _request(self, type_, body, want, fds_out=None):
        rid = self._next_id
        self._next_id = (self._next_id % 0xFFFFFFFF) + 1
        self._send(type_, body, rid)
        deadline = time.monotonic() + self.timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise Error("timeout", "no reply from mocapd within %.1f s" % self.timeout)
            m = self._recv(left)
            if m is None:
                continue
            mtype, mrid, data, fds = m
            if mrid != rid:
                self._file(mtype, mrid, data, fds)
                continue
            if mtype == ERROR:
                r = _Reader(data)
                code, _req, _fatal = r.take("IHH")
                raise Error(SERVER_ERRORS.get(code, "refused"), r.string())
            if mtype != want:
                raise Error("protocol", "unexpected reply 0x%04x" % mtype)
            if fds_out is not None:
                fds_out.extend(fds)
            else:
                for fd in fds:
                    os.close(fd)
            return _Reader(data)

    # --- parsing ---

    def _parse_frame(self, data):
        r = _Reader(data)
        seq, cap, pub, sid, nj, state, space = r.take("QQQIHBB")
        joints = []
        for _ in range(nj):
            v = r.take("7dfI")
            joints.append(Joint(v[0:3], v[3:7], v[7]))
        r.end()
        missed, self._missed = self._missed, 0
        return Frame(seq, cap, pub, now_ns(), missed, sid, TRACK_STATES.get(state, str(state)),
                     "world" if space == SPACE_WORLD else "rig", joints)

    @staticmethod
    def _parse_skeleton(data):
        r = _Reader(data)
        sid, nj, world, _ = r.take("IHBB")
        table = [r.take("iI3d") for _ in range(nj)]
        names = [r.string() for _ in range(nj)]
        r.end()
        return Skeleton(sid, bool(world), [JointDef(n, t[0], t[2:5]) for n, t in zip(names, table)])

    # --- API ---

    def subscribe(self, mode=LATEST, space=SPACE_RIG, queue_len=0):
        """LATEST: only the newest frame (VR); ALL: every frame, gaps counted in Frame.missed."""
        self._mode = 0
        self._frames = []
        self._missed = 0
        r = self._request(SUBSCRIBE, struct.pack("<BBHI", mode, space, 0, queue_len), OK)
        self._mode = mode
        return r.take("HHI")[2]

    def unsubscribe(self):
        self._mode = 0
        self._frames = []
        self._request(UNSUBSCRIBE, b"", OK)

    def read_frame(self, timeout=None):
        """The next frame, or None after timeout seconds (None: wait forever)."""
        if not self._mode and not self._frames:
            raise Error("argument", "not subscribed (call subscribe first)")
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
        frame = self._frames.pop(0)
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
        r = self._request(GET_SKELETON, b"", SKELETON)
        return self._parse_skeleton(r.data)

    def status(self):
        r = self._request(GET_STATUS, b"", STATUS)
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
        r.end()
        cameras = [Camera(n, CAMERA_STATES.get(c[3], str(c[3])), c[4], c[5], c[0], c[1], c[2])
                   for n, c in zip(names, cams)]
        return Status(now, max(0, now - start), pub, dropped, cdrops, fps, tmean, tmax,
                      TRACK_STATES.get(state, str(state)), bool(rec), nclients, device, cameras, detector)

    def rig(self):
        """The rig in use, as JSON text."""
        r = self._request(GET_RIG, b"", RIG)
        _ncams, length = r.take("II")
        text = r.data[r.pos:r.pos + length]
        r.pos += length
        r.end()
        return text.decode("utf-8", "replace")

    def control(self, command, argument=""):
        """Runs CMD_RELOAD / CMD_RECORD_START / CMD_RECORD_STOP / CMD_ACTOR_SAVE; returns the daemon's message."""
        r = self._request(CONTROL, struct.pack("<I", command) + _str16(argument), CONTROL_RESULT)
        _cmd, result = r.take("Ii")
        msg = r.string()
        if result != 0:
            raise Error("failed", msg)
        return msg

    def reload(self):
        return self.control(CMD_RELOAD)

    def save_actor(self, name):
        """Saves the calibrated actor as [tracker] actor_dir/NAME.json; returns the daemon's message."""
        return self.control(CMD_ACTOR_SAVE, name)

    def rings(self):
        """Read-only camera ring descriptors (close them when done)."""
        fds = []
        r = self._request(GET_RINGS, b"", RINGS, fds)
        count = r.take("HHI")[0]
        sizes = [r.take("QQ")[0] for _ in range(count)]
        names = [r.string() for _ in range(count)]
        if len(fds) != count:
            for fd in fds:
                os.close(fd)
            raise Error("protocol", "RINGS lists %d rings but came with %d descriptors" % (count, len(fds)))
        return [Ring(n, fd, s) for n, fd, s in zip(names, fds, sizes)]

    def send_keypoints(self, capture_ns, camera, keypoints):
        """keypoints: [(joint, u, v, confidence), ...]; not acknowledged."""
        body = struct.pack("<QHHI", capture_ns, camera, len(keypoints), 0)
        body += b"".join(struct.pack("<HHfff", j, 0, u, v, c) for j, u, v, c in keypoints)
        self._send(KEYPOINTS, body, self._take_id())

    def send_head_pose(self, timestamp_ns, position, orientation_wxyz):
        """world_from_rig at timestamp_ns; not acknowledged."""
        self._send(HEAD_POSE, struct.pack("<Q3d4d", timestamp_ns, *position, *orientation_wxyz), self._take_id())

    def ping(self):
        """Round trip in seconds."""
        t = time.monotonic()
        self._request(PING, struct.pack("<Q", now_ns()), PONG)
        return time.monotonic() - t

    def _take_id(self):
        rid = self._next_id
        self._next_id = (self._next_id % 0xFFFFFFFF) + 1
        return rid
