"""mocap's exceptions: MocapError and one subclass per libmocap error code
(MOCAP_E_*), and the daemon's ERROR codes mapped onto them as libmocap maps them."""

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
