"""The sockets under both clients: the daemon's Unix socket (connect errors
as libmocap words them) and TCP to a daemon on another machine (address,
token, and the length-prefixed message stream)."""
import errno as _errno
import grp
import os
import pwd
import stat
import socket
import struct

from ._errors import (AccessDenied, ArgumentError, Disconnected, NotRunning, ProtocolError, SystemCallError,
                      Timeout)
from ._protocol import HEADER, MAX_MESSAGE


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


def _new_socket():
    try:
        return socket.socket(socket.AF_UNIX, socket.SOCK_SEQPACKET)
    except OSError as e:
        raise SystemCallError("system", "socket: %s" % (e.strerror or e)) from None


def _access_message(path):
    """Why path refused this user, as libmocap says it (ipc/client/access.c): the socket's group and mode, or
    its folder's when the folder keeps the user out, and how to join that group."""
    what = "the socket"
    try:
        st = os.stat(path)
    except OSError:
        folder = os.path.dirname(path) or "/"
        what = "its folder %s" % folder
        try:
            st = os.stat(folder)
        except OSError:
            return "permission denied connecting to %s: your user needs to be in the daemon's group" % path
    group, owner = _id_name(grp.getgrgid, st.st_gid), _id_name(pwd.getpwuid, st.st_uid)
    mode = stat.S_IMODE(st.st_mode)
    # Without group access, joining the group would not help.
    group_may = st.st_mode & (stat.S_IXGRP if stat.S_ISDIR(st.st_mode) else stat.S_IWGRP)
    if group_may:
        return ("permission denied connecting to %s: %s belongs to group %s (mode %04o) and your user is not in "
                "it: sudo usermod -aG %s $USER, then log in again (or newgrp %s in one shell)"
                % (path, what, group, mode, group, group))
    return ("permission denied connecting to %s: %s belongs to user %s, group %s, with mode %04o: only its owner "
            "may connect (the daemon's [socket] mode sets it)" % (path, what, owner, group, mode))


def _id_name(lookup, n):
    try:
        return lookup(n)[0]
    except KeyError:
        return str(n)


def _connect_error(path, e):
    """The exception for a failed connect() to path."""
    if isinstance(e, FileNotFoundError):
        return NotRunning("not running", "daemon not running at %s (no socket there; is mocapd started?)" % path)
    if isinstance(e, ConnectionRefusedError):
        return NotRunning("not running", "daemon not running at %s (the socket is left over, nobody listens)" % path)
    if isinstance(e, PermissionError):
        return AccessDenied("access", _access_message(path))
    if e.errno == _errno.EPROTOTYPE:
        return ProtocolError("protocol", "%s is not a mocapd socket (wrong socket type)" % path)
    if e.errno in (_errno.ENOTDIR, _errno.ENOTSOCK):
        return NotRunning("not running", "daemon not running at %s (%s)" % (path, e.strerror))
    if e.errno in (_errno.EMFILE, _errno.ENFILE, _errno.ENOMEM, _errno.ENOBUFS):
        return SystemCallError("system", "cannot connect to %s: %s" % (path, e.strerror))
    if "too long" in str(e):
        return ArgumentError("argument", "socket path too long: %s" % path)
    return NotRunning("not running", "cannot connect to %s: %s" % (path, e.strerror or e))


def _close_fds(fds):
    for fd in fds:
        os.close(fd)


_RECV_FLAGS = getattr(socket, "MSG_CMSG_CLOEXEC", 0)
