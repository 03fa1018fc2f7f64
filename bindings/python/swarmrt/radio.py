"""Radio payloads as the Rust robots write them: postcard, by hand.

A frame's payload is either a postcard-encoded `RadioMsg` (agent/src/behaviours/mod.rs: one
variant per behaviour, then the consensus layer's; its first byte is the variant's fixed wire
tag, `GOTO`, ..., `CONSENSUS`, from the generated `_tags.py`) or an *opaque* frame, whose
first byte is `OPAQUE_TAG` and whose rest is raw bytes for robots of one kind. The world
refuses a command carrying a frame that is neither (it counts it in `rejected`), so a Python
robot that talks to Rust robots must write exactly the bytes postcard writes; the helpers here
do, for the messages the example robots use.

Postcard in four lines (https://postcard.jamesmunns.com/wire-format): an enum is its variant
index as a varint (for `RadioMsg`, its wire tag: one byte, as every tag is below 128), then
the variant's fields in order; `u8` is one byte; `u16`/`u32`/`u64` are LEB128 varints;
`f32`/`f64` are 4/8 bytes little-endian; a struct is its fields in order.
No lengths, no names: a decoder has to know the type, which is why each message has its own
function here. Decoding follows postcard's `from_bytes`: trailing bytes are ignored.
"""

from __future__ import annotations

import ctypes
import math
import struct
from typing import NamedTuple, Optional

from ._messages import BROADCAST, MAX_OUTBOX, MAX_PAYLOAD, OPAQUE_TAG, Command, Frame
from .scenario import round_half_away

# `RadioMsg` wire tags, the payload's first byte: declared on each line of the `behaviours!`
# list in agent/src/behaviours/mod.rs and generated into `_tags.py`, never written here by
# hand, so a behaviour added in Rust cannot move them. Re-exported as `radio.GOTO`, ...
from ._tags import (  # noqa: F401 (re-exported)
    CHAIN,
    CONSENSUS,
    FLOCKING,
    FORMATION,
    GOTO,
    GROUPING,
    PLANNER,
    TAGS,
)

# `FlockMsg` variant indices (agent/src/behaviours/flocking/messages.rs).
FLOCK_HEADING = 0
FLOCK_BYTE = 1

#: Heading steps in a one-byte flocking message (5 bits).
BYTE_ANGLES = 32


class DecodeError(ValueError):
    """The bytes are not the message asked for (too short, a bad varint, another variant)."""


# --- primitives ----------------------------------------------------------------------------


def varint(n: int) -> bytes:
    """`n` (unsigned) as a LEB128 varint: 7 bits a byte, low first, high bit = more follows."""
    if n < 0:
        raise ValueError("varints here are unsigned")
    out = bytearray()
    while True:
        b = n & 0x7F
        n >>= 7
        if n:
            out.append(b | 0x80)
        else:
            out.append(b)
            return bytes(out)


def f64(x: float) -> bytes:
    """`x` as postcard writes an `f64`: 8 bytes little-endian, the exact bits."""
    return struct.pack("<d", x)


def f32(x: float) -> bytes:
    """`x` rounded to an `f32` (to nearest, as Rust's `as f32`), 4 bytes little-endian."""
    return struct.pack("<f", x)


class Reader:
    """Reads postcard values from `data` front to back; raises `DecodeError` past its end."""

    def __init__(self, data: bytes) -> None:
        self.data = bytes(data)
        self.pos = 0

    def take(self, n: int) -> bytes:
        """The next `n` raw bytes."""
        if self.pos + n > len(self.data):
            raise DecodeError(f"needs {n} more bytes at {self.pos}, has {len(self.data) - self.pos}")
        b = self.data[self.pos : self.pos + n]
        self.pos += n
        return b

    def u8(self) -> int:
        """One byte (postcard writes `u8` as is, not as a varint)."""
        return self.take(1)[0]

    def varint(self, bits: int = 32) -> int:
        """An unsigned varint of at most `bits` bits (`u32` by default: enum tags, lengths)."""
        n = 0
        shift = 0
        max_bytes = (bits + 6) // 7
        for _ in range(max_bytes):
            b = self.u8()
            n |= (b & 0x7F) << shift
            if not b & 0x80:
                if n >> bits:
                    raise DecodeError("varint out of range")
                return n
            shift += 7
        raise DecodeError("varint too long")

    def f64(self) -> float:
        """An `f64`."""
        return struct.unpack("<d", self.take(8))[0]

    def f32(self) -> float:
        """An `f32`, widened exactly to a Python float (as Rust's `as f64`)."""
        return struct.unpack("<f", self.take(4))[0]


# --- frames --------------------------------------------------------------------------------


def frame_bytes(frame: Frame) -> bytes:
    """The valid payload bytes of `frame` (clamped, so a bad `len` cannot read past the array)."""
    n = min(int(frame.len), MAX_PAYLOAD)
    return bytes(frame.payload[:n])


def opaque(data: bytes) -> bytes:
    """An opaque payload: `OPAQUE_TAG` then `data` (at most `MAX_PAYLOAD - 1` bytes). The world
    routes it like any frame without decoding it; Rust robots skip it."""
    if len(data) >= MAX_PAYLOAD:
        raise ValueError(f"an opaque frame carries at most {MAX_PAYLOAD - 1} bytes")
    return bytes([OPAQUE_TAG]) + bytes(data)


def opaque_bytes(payload: bytes) -> Optional[bytes]:
    """The raw bytes of an opaque payload, `None` for a postcard message."""
    if payload[:1] == bytes([OPAQUE_TAG]):
        return payload[1:]
    return None


def push_frame(cmd: Command, dst: int, payload: bytes) -> bool:
    """Queues `payload` for robot `dst` (or `BROADCAST`) in `cmd`'s outbox, as Rust's
    `Command::push_frame` does. Returns False, and queues nothing, when the outbox is full or
    the payload is too large: like the Rust robots, a caller drops that frame as the radio
    would."""
    slot = int(cmd.outbox_len)
    if slot >= MAX_OUTBOX or len(payload) > MAX_PAYLOAD:
        return False
    f = cmd.outbox[slot]
    f.src = 0
    f.dst = dst
    f.sent_tick = 0
    f.len = len(payload)
    ctypes.memset(ctypes.addressof(f.payload), 0, MAX_PAYLOAD)
    ctypes.memmove(ctypes.addressof(f.payload), payload, len(payload))
    cmd.outbox_len = slot + 1
    return True


class Heard(NamedTuple):
    """A frame of this tick's inbox addressed to this robot: sender, send tick, payload."""

    src: int
    sent_tick: int
    payload: bytes


def inbox(obs, robot: int) -> list[Heard]:
    """This tick's frames for `robot` (broadcasts and unicasts to it), in delivery order, as
    the Rust agent filters them (agent/src/agent.rs): frames to someone else are skipped."""
    out = []
    for k in range(min(int(obs.inbox_len), len(obs.inbox))):
        f = obs.inbox[k]
        if f.dst != BROADCAST and f.dst != robot:
            continue
        out.append(Heard(int(f.src), int(f.sent_tick), frame_bytes(f)))
    return out


def tag(payload: bytes) -> Optional[int]:
    """The `RadioMsg` variant of a postcard payload (`GOTO`, `FLOCKING`, ...), `None` for an
    opaque or malformed one."""
    if opaque_bytes(payload) is not None:
        return None
    try:
        return Reader(payload).varint()
    except DecodeError:
        return None


# --- goto ----------------------------------------------------------------------------------


class Beacon(NamedTuple):
    """`RadioMsg::Goto(Beacon { x, y, theta })`: a robot's pose as it estimates it."""

    x: float
    y: float
    theta: float


def encode_beacon(x: float, y: float, theta: float) -> bytes:
    """The 25 bytes a Rust goto robot sends: tag 0, then three `f64`."""
    return varint(GOTO) + f64(x) + f64(y) + f64(theta)


def decode_beacon(payload: bytes) -> Optional[Beacon]:
    """The beacon in `payload`, `None` if it is not one."""
    if opaque_bytes(payload) is not None:
        return None
    try:
        r = Reader(payload)
        if r.varint() != GOTO:
            return None
        return Beacon(r.f64(), r.f64(), r.f64())
    except DecodeError:
        return None


# --- flocking ------------------------------------------------------------------------------


class FlockHeading(NamedTuple):
    """`RadioMsg::Flocking(FlockMsg::Heading { flock, heading })`: the sender's flock (start
    group) and heading estimate, carried as an `f32`."""

    flock: int
    heading: float


class FlockByte(NamedTuple):
    """`RadioMsg::Flocking(FlockMsg::Byte(b))`: the real e-puck's one-byte message
    (`encode_byte`)."""

    byte: int


def encode_flock_heading(flock: int, heading: float) -> bytes:
    """Tag 2, `FlockMsg` tag 0, the flock as one byte, the heading rounded to `f32`."""
    return varint(FLOCKING) + varint(FLOCK_HEADING) + bytes([flock & 0xFF]) + f32(heading)


def encode_flock_byte(b: int) -> bytes:
    """Tag 2, `FlockMsg` tag 1, the byte."""
    return varint(FLOCKING) + varint(FLOCK_BYTE) + bytes([b & 0xFF])


def decode_flock(payload: bytes):
    """A `FlockHeading` or `FlockByte`, `None` if `payload` is no flocking message."""
    if opaque_bytes(payload) is not None:
        return None
    try:
        r = Reader(payload)
        if r.varint() != FLOCKING:
            return None
        v = r.varint()
        if v == FLOCK_HEADING:
            return FlockHeading(r.u8(), r.f32())
        if v == FLOCK_BYTE:
            return FlockByte(r.u8())
        return None
    except DecodeError:
        return None


def _rem_euclid(a: float, b: float) -> float:
    """Rust's `f64::rem_euclid`: `a % b` (C fmod) made non-negative."""
    r = math.fmod(a, b)
    return r + abs(b) if r < 0.0 else r


def encode_byte(robot: int, heading: float) -> int:
    """`encode_byte` of flocking/messages.rs: the low 3 bits of the id in the top bits, the
    heading rounded to the nearest of 32 directions in the low 5."""
    step = math.tau / float(BYTE_ANGLES)
    k = int(round_half_away(_rem_euclid(heading, math.tau) / step)) % BYTE_ANGLES
    return ((robot & 7) << 5) | k


def decode_byte(b: int) -> tuple[int, float]:
    """`(id, heading)` of a one-byte message; the heading in [0, 2 pi)."""
    step = math.tau / float(BYTE_ANGLES)
    return (b >> 5, float(b & 31) * step)
