"""The asyncio client of mocapd: await mocap.aio.connect(path, name)."""
import asyncio
import socket
import struct
import time

from ._codec import (_auth_body, _control_body, _head_pose_body, _header, _hello_body, _keypoints_body, _message,
                     _parse_control_result, _parse_rig, _parse_rings, _parse_skeleton, _parse_status,
                     _parse_welcome, _Reader, _server_error, _subscribe_body)
from ._data import now_ns
from ._errors import Disconnected, MocapError, ProtocolError, Timeout, Unavailable, _error
from ._protocol import (ALL, AUTH, CMD_ACTOR_SAVE, CMD_RELOAD, CONTROL, CONTROL_RESULT, ERROR, FRAME, GAP,
                        GET_RIG, GET_RINGS, GET_SKELETON, GET_STATUS, HEAD_POSE, HELLO, KEYPOINTS, LATEST,
                        MAX_FDS, MAX_MESSAGE, OK, PING, PONG, RIG, RINGS, SKELETON, SPACE_RIG, STATUS, SUBSCRIBE,
                        UNSUBSCRIBE, WELCOME)
from ._session import _Session
from ._transport import (_close_fds, _connect_error, _is_tcp, _new_socket, _RECV_FLAGS, _Stream,
                         _tcp_connect_error, _tcp_host_port, _tcp_socket, _tcp_token)

__all__ = ["connect", "Client", "AsyncClient"]


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


Client = AsyncClient  # mocap.aio.Client: the asyncio client under the name the blocking one has in mocap
