"""swarmrt shared-memory messages as ctypes structures.

GENERATED from the Rust types by swarmrt_protocol::layout; do not edit
(SWARMRT_UPDATE_BINDINGS=1 cargo test -p swarmrt-protocol --test bindings rewrites it).
See docs/robot-interface.md.
"""

import ctypes

PROTOCOL_VERSION = 5
"""Every message's `version`."""
MAX_PAYLOAD = 128
"""Bytes in a radio frame's payload."""
MAX_OUTBOX = 8
"""Frames in one command's outbox."""
MAX_INBOX = 32
"""Frames in one observation's inbox."""
MAX_LIDAR_RAYS = 64
"""Lidar rays."""
MAX_NEIGHBOURS = 32
"""Neighbours seen by range-and-bearing."""
MAX_REPORT = 256
"""Bytes of a command's report (notes)."""
BROADCAST = 4294967295
"""Destination of a broadcast frame."""
OPAQUE_TAG = 255
"""First payload byte of an opaque frame (raw bytes for robots of one kind)."""
KIND_HELLO = 1
"""Command kind: the robot's ports exist."""
KIND_ACT = 2
"""Command kind: the decision for `tick`."""
KIND_REACT = 3
"""Command kind: a reaction within `tick` to a propagation round (built-in robots only so far)."""
STATE_ACTIVE = 0
"""Observation state: moving and sensing."""
STATE_DOWN = 1
"""Observation state: knocked down; answer, the command is ignored."""
STATE_DEAD = 2
"""Observation state: its process is gone."""
STATE_FROZEN = 3
"""Observation state: frozen; do not answer."""
STATE_RESTARTING = 4
"""Observation state: restarting; do not answer."""
EVENT_COMMAND = 1
"""Event id a robot notifies on the command event after each command."""
EVENT_CONTROL = 2
"""Event id reserved for the world's own wake-ups."""


class Frame(ctypes.Structure):
    """One radio frame: sender, destination (or BROADCAST), payload. 152 bytes."""

    _fields_ = [
        ("src", ctypes.c_uint32),
        ("dst", ctypes.c_uint32),
        ("sent_tick", ctypes.c_uint64),
        ("len", ctypes.c_uint16),
        ("payload", ctypes.c_uint8 * 128),
        ("_pad0", ctypes.c_uint8 * 6),
    ]

    @staticmethod
    def type_name() -> str:
        """The name iceoryx2 compares when a port opens the service."""
        return "swarmrt::Frame"


class Neighbour(ctypes.Structure):
    """A robot seen by the range-and-bearing sensor. 24 bytes."""

    _fields_ = [
        ("id", ctypes.c_uint32),
        ("_pad0", ctypes.c_uint8 * 4),
        ("range", ctypes.c_double),
        ("bearing", ctypes.c_double),
    ]

    @staticmethod
    def type_name() -> str:
        """The name iceoryx2 compares when a port opens the service."""
        return "swarmrt::Neighbour"


class Observation(ctypes.Structure):
    """Everything one robot senses at one tick (one slot of the observation sample). 6224 bytes."""

    _fields_ = [
        ("version", ctypes.c_uint32),
        ("robot", ctypes.c_uint32),
        ("tick", ctypes.c_uint64),
        ("state", ctypes.c_uint8),
        ("reached", ctypes.c_uint8),
        ("goal_visible", ctypes.c_uint8),
        ("_pad0", ctypes.c_uint8 * 1),
        ("lidar_len", ctypes.c_uint16),
        ("neighbours_len", ctypes.c_uint16),
        ("inbox_len", ctypes.c_uint16),
        ("_pad1", ctypes.c_uint8 * 6),
        ("x", ctypes.c_double),
        ("y", ctypes.c_double),
        ("theta", ctypes.c_double),
        ("z", ctypes.c_double),
        ("goal_range", ctypes.c_double),
        ("goal_bearing", ctypes.c_double),
        ("lidar", ctypes.c_double * 64),
        ("neighbours", Neighbour * 32),
        ("inbox", Frame * 32),
    ]

    @staticmethod
    def type_name() -> str:
        """The name iceoryx2 compares when a port opens the service."""
        return "swarmrt::Observation"


class ObservationHeader(ctypes.Structure):
    """User header of the observation sample: the tick and whether the run is over. 16 bytes."""

    _fields_ = [
        ("version", ctypes.c_uint32),
        ("shutdown", ctypes.c_uint32),
        ("tick", ctypes.c_uint64),
    ]

    @staticmethod
    def type_name() -> str:
        """The name iceoryx2 compares when a port opens the service."""
        return "swarmrt::ObservationHeader"


class Command(ctypes.Structure):
    """A robot's answer to one observation (Hello first, then one Act per tick). 1552 bytes."""

    _fields_ = [
        ("version", ctypes.c_uint32),
        ("robot", ctypes.c_uint32),
        ("tick", ctypes.c_uint64),
        ("kind", ctypes.c_uint32),
        ("pid", ctypes.c_uint32),
        ("v", ctypes.c_double),
        ("omega", ctypes.c_double),
        ("vx", ctypes.c_double),
        ("vy", ctypes.c_double),
        ("vz", ctypes.c_double),
        ("lidar_on", ctypes.c_uint8),
        ("_pad0", ctypes.c_uint8 * 1),
        ("outbox_len", ctypes.c_uint16),
        ("in_tick", ctypes.c_uint16),
        ("_pad1", ctypes.c_uint8 * 2),
        ("outbox", Frame * 8),
        ("report_len", ctypes.c_uint16),
        ("report", ctypes.c_uint8 * 256),
        ("_pad2", ctypes.c_uint8 * 6),
    ]

    @staticmethod
    def type_name() -> str:
        """The name iceoryx2 compares when a port opens the service."""
        return "swarmrt::Command"


LAYOUT = {
    "Frame": 152,
    "Neighbour": 24,
    "Observation": 6224,
    "ObservationHeader": 16,
    "Command": 1552,
}
"""Size in bytes of each struct, as Rust lays it out."""
