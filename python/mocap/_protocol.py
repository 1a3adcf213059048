"""The protocol's numbers (docs/PROTOCOL.md): versions, header, limits,
subscription modes, CONTROL commands, state names and message types."""
import struct

PROTOCOL_VERSION = 3      # the highest spoken; 1 and 2 too (2 adds STATUS's detector block, 3 its latency)
PROTOCOL_MIN_VERSION = 1
MAGIC = 0x50434F4D
HEADER = struct.Struct("<HHIII")  # type, flags, size, request_id, reserved
MAX_MESSAGE = 65536
MAX_FDS = 16
DEFAULT_SOCKET = "/run/mocapd/mocapd.sock"

LATEST, ALL = 1, 2
SPACE_RIG, SPACE_WORLD = 0, 1
CMD_RELOAD, CMD_RECORD_START, CMD_RECORD_STOP, CMD_ACTOR_SAVE = 1, 2, 3, 4
CMD_RECORD_STATUS, CMD_RECORD_LIST = 5, 6
CMD_STEER = 7  # a [source] graph walk: "class NAME", "frame N", "direction DEG [speed M/S]", "none"
TRACK_STATES = {0: "ok", 1: "uncertain", 2: "lost", 3: "idle", 4: "initialising"}
CAMERA_STATES = {0: "ok", 1: "stalled", 2: "error", 3: "off", 4: "failed"}
DETECTOR_STATES = {0: "off", 1: "running", 2: "failed"}

# Message types.
HELLO, SUBSCRIBE, UNSUBSCRIBE, GET_STATUS, GET_SKELETON, GET_RIG = 0x1, 0x2, 0x3, 0x4, 0x5, 0x6
CONTROL, GET_RINGS, KEYPOINTS, HEAD_POSE, PING, AUTH, GET_POSE_BLOCK = 0x7, 0x8, 0x9, 0xA, 0xB, 0xC, 0xD
WELCOME, ERROR, OK, SKELETON, FRAME, GAP = 0x8001, 0x8002, 0x8003, 0x8004, 0x8005, 0x8006
STATUS, RIG, CONTROL_RESULT, RINGS, PONG, POSE_BLOCK = 0x8007, 0x8008, 0x8009, 0x800A, 0x800B, 0x800C
