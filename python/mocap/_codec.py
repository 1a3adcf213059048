"""Encoding and decoding of the messages, shared by Client and AsyncClient:
message bodies out, replies and frames in (docs/PROTOCOL.md gives the layouts)."""
import struct

from ._data import (Camera, Detector, Frame, Joint, JointDef, Joints, Latency, LATENCY_STAGES, Ring, Skeleton,
                    StageTime, Status, now_ns)
from ._errors import SERVER_ERRORS, ArgumentError, CommandFailed, MocapError, ProtocolError, Disconnected, _error
from ._protocol import (ALL, CAMERA_STATES, DETECTOR_STATES, HEADER, LATEST, MAGIC, PROTOCOL_MIN_VERSION,
                        PROTOCOL_VERSION, SPACE_RIG, SPACE_WORLD, TRACK_STATES)
from ._transport import _close_fds


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


def _server_error(data, answer=False):
    """The exception an ERROR message stands for (answer: it answers a request of ours)."""
    r = _Reader(data)
    code, _req, fatal = r.take("IHH")
    msg = r.string()
    prefix = "mocapd closed the connection: " if fatal and not answer else ""
    return _error(SERVER_ERRORS.get(code, "refused"), prefix + msg, server_code=code, fatal=bool(fatal))


def _auth_body(token):
    if len(token.encode("utf-8")) > 255:
        raise ArgumentError("argument", "the token is longer than 255 bytes")
    return _str16(token)


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
