"""mocap: a client of mocapd for lab scripts, in pure Python (standard library).

Speaks protocol versions 1 to 3 of docs/PROTOCOL.md over the daemon's
SOCK_SEQPACKET Unix socket, or over TCP to a daemon on another machine
(path "tcp://HOST:PORT"; the daemon's token from token=, $MOCAP_TOKEN or
the file $MOCAP_TOKEN_FILE).  Install it with `pip install ./python`, or
copy the folder python/mocap next to a script.

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

# The package's modules, one concern each: _protocol (the protocol's
# numbers), _errors, _data (frames, skeletons, status), _codec (messages
# in and out), _transport (Unix and TCP sockets), _session (the state both
# clients keep), _client (Client), aio (AsyncClient, connect), _pose_block
# (PoseBlock, predict).  Everything public is imported here, so that
# `import mocap; mocap.X` works as it did when this was one module.
from ._protocol import (ALL, AUTH, CAMERA_STATES, CMD_ACTOR_SAVE, CMD_RECORD_LIST, CMD_RECORD_START,
                        CMD_RECORD_STATUS, CMD_RECORD_STOP, CMD_RELOAD, CMD_STEER, CONTROL, CONTROL_RESULT,
                        DEFAULT_SOCKET, DETECTOR_STATES, ERROR, FRAME, GAP, GET_POSE_BLOCK, GET_RIG,
                        GET_RINGS, GET_SKELETON, GET_STATUS, HEADER, HEAD_POSE, HELLO, KEYPOINTS, LATEST,
                        MAGIC, MAX_FDS, MAX_MESSAGE, OK, PING, PONG, POSE_BLOCK, PROTOCOL_MIN_VERSION,
                        PROTOCOL_VERSION, RIG, RINGS, SKELETON, SPACE_RIG, SPACE_WORLD, STATUS, SUBSCRIBE,
                        TRACK_STATES, UNSUBSCRIBE, WELCOME)
from ._errors import (AccessDenied, ArgumentError, CommandFailed, Disconnected, E_ACCESS, E_ARG,
                      E_DISCONNECTED, E_FAILED, E_NOT_RUNNING, E_PERMISSION, E_PROTOCOL, E_REFUSED, E_SYSTEM,
                      E_TIMEOUT, E_UNAVAILABLE, E_VERSION, Error, MocapError, NotRunning, PermissionDenied,
                      ProtocolError, Refused, SERVER_ERRORS, SystemCallError, Timeout, Unavailable,
                      VersionMismatch)
from ._data import (Camera, Detector, Frame, Joint, JointDef, Joints, LATENCY_STAGES, Latency, Ring, Skeleton,
                    StageTime, Status, default_socket, now_ns)
from ._transport import TCP_PREFIX, TCP_SCHEME, TOKEN_ENV, TOKEN_FILE_ENV
from ._pose_block import (POSE_BLOCK_MAGIC, POSE_BLOCK_SIZE, POSE_BLOCK_SLOTS, PREDICT_MAX_GAP_NS,
                          PREDICT_MAX_NS, PoseBlock, predict)
from ._client import Client
from .aio import AsyncClient, connect
from . import aio  # mocap.aio; `import mocap.aio` works too

__version__ = "1.2.0"
__all__ = [
    "Client", "AsyncClient", "connect", "aio", "Frame", "Joint", "Joints", "JointDef", "Skeleton", "Camera",
    "Detector", "Status", "Latency", "StageTime", "Ring", "PoseBlock", "predict", "MocapError", "Error", "NotRunning", "AccessDenied", "VersionMismatch",
    "ProtocolError", "Disconnected", "Timeout", "PermissionDenied", "Refused", "Unavailable", "CommandFailed",
    "ArgumentError", "SystemCallError", "LATEST", "ALL", "SPACE_RIG", "SPACE_WORLD", "CMD_RELOAD",
    "CMD_RECORD_START", "CMD_RECORD_STOP", "CMD_ACTOR_SAVE", "CMD_RECORD_STATUS", "CMD_RECORD_LIST", "CMD_STEER", "default_socket", "now_ns",
]

# The public classes and functions say they are mocap's (repr, pickle,
# help()), as they did when they were defined in one module.
for _name in __all__:
    _obj = globals()[_name]
    if isinstance(_obj, type) or callable(_obj):
        _obj.__module__ = __name__
del _name, _obj
