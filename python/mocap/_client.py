"""The blocking client, mocap.Client."""
import socket
import struct
import time

from ._codec import (_auth_body, _control_body, _head_pose_body, _header, _hello_body, _keypoints_body, _message,
                     _parse_control_result, _parse_rig, _parse_rings, _parse_skeleton, _parse_status,
                     _parse_welcome, _Reader, _server_error, _subscribe_body)
from ._data import now_ns
from ._errors import Disconnected, MocapError, ProtocolError, Timeout, Unavailable
from ._pose_block import PoseBlock
from ._protocol import (AUTH, CMD_ACTOR_SAVE, CMD_RELOAD, CONTROL, CONTROL_RESULT, ERROR, FRAME, GAP,
                        GET_POSE_BLOCK, GET_RIG, GET_RINGS, GET_SKELETON, GET_STATUS, HEAD_POSE, HELLO, KEYPOINTS,
                        LATEST, MAX_FDS, MAX_MESSAGE, OK, PING, PONG, POSE_BLOCK, RIG, RINGS, SKELETON, SPACE_RIG,
                        STATUS, SUBSCRIBE, UNSUBSCRIBE, WELCOME)
from ._session import _Session
from ._transport import (_close_fds, _connect_error, _is_tcp, _new_socket, _RECV_FLAGS, _Stream,
                         _tcp_connect_error, _tcp_host_port, _tcp_socket, _tcp_token)


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
