"""What the client hands out: frames and their joints (readable by name),
skeleton definitions, status, rings; and the clocks and socket path they use."""
import os
import time
from collections import namedtuple

from ._protocol import DEFAULT_SOCKET


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
