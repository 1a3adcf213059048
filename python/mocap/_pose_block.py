"""The daemon's latest-pose block (docs/PROTOCOL_SHM.md), mapped read-only,
and the prediction of a pose to a later time that it and subscribers use."""
import math
import mmap
import os
import struct

from ._data import Frame, Joint, Joints, now_ns
from ._errors import ProtocolError, Timeout
from ._protocol import TRACK_STATES

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
