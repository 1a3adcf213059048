"""The protocol state that Client and AsyncClient share (_Session)."""
import collections

from ._codec import _parse_frame, _Reader
from ._data import default_socket
from ._errors import ArgumentError
from ._protocol import LATEST


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
