"""The run's tick bell, as ipc/src/bell.rs defines it: one futex word in the file `tick.bell` of
the run's iceoryx2 root. The world bumps it after each observation sample and wakes every
robot sleeping on it with one `FUTEX_WAKE`, so a robot that sleeps here costs the world
nothing per tick (a listener of the observation event costs it one notification).

Read `seen()` before draining the subscriber, then `wait(seen, ms)`: the kernel sleeps only
while the word still holds `seen`, so a tick published in between is never slept through.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import mmap
import os
import platform

_BELL_FILE = "tick.bell"
_BELL_LEN = 64
_FUTEX_WAIT = 0
# The futex system call's number on the architectures iceoryx2 supports on Linux.
_SYS_FUTEX = {"x86_64": 202, "amd64": 202, "aarch64": 98, "arm64": 98}

_libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
_libc.syscall.restype = ctypes.c_long
_libc.mmap.restype = ctypes.c_void_p
_libc.mmap.argtypes = [
    ctypes.c_void_p, ctypes.c_size_t, ctypes.c_int, ctypes.c_int, ctypes.c_int, ctypes.c_long,
]


class _Timespec(ctypes.Structure):
    _fields_ = [("tv_sec", ctypes.c_long), ("tv_nsec", ctypes.c_long)]


RUNG, TIMED_OUT, INTERRUPTED = "rung", "timed-out", "interrupted"


class Bell:
    """A read-only mapping of a run's bell."""

    def __init__(self, ipc_root: str) -> None:
        number = _SYS_FUTEX.get(platform.machine().lower())
        if number is None:
            raise OSError(f"no futex system call number known for {platform.machine()}")
        path = os.path.join(ipc_root, _BELL_FILE)
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_CLOEXEC)
        try:
            if os.fstat(fd).st_size < _BELL_LEN:
                raise OSError(f"{path} is not a bell (a regular file of {_BELL_LEN} bytes)")
            addr = _libc.mmap(None, _BELL_LEN, mmap.PROT_READ, mmap.MAP_SHARED, fd, 0)
            if addr in (None, ctypes.c_void_p(-1).value):
                raise OSError(ctypes.get_errno(), f"mmap {path}")
        finally:
            os.close(fd)
        self._sys = number
        self._addr = addr
        self._word = ctypes.c_uint32.from_address(addr)

    def seen(self) -> int:
        """The bell's count now (an aligned 32-bit load)."""
        return self._word.value

    def wait(self, seen: int, ms: int) -> str:
        """Sleeps until the count differs from `seen`, `ms` pass, or a signal arrives."""
        if self._word.value != seen:
            return RUNG
        ts = _Timespec(ms // 1000, (ms % 1000) * 1_000_000)
        r = _libc.syscall(
            self._sys, ctypes.c_void_p(self._addr), _FUTEX_WAIT, ctypes.c_uint32(seen),
            ctypes.byref(ts), None, 0,
        )
        if r == 0:
            return RUNG
        err = ctypes.get_errno()
        if err == 11:  # EAGAIN: the count had already moved
            return RUNG
        if err == 110:  # ETIMEDOUT
            return TIMED_OUT
        if err == 4:  # EINTR
            return INTERRUPTED
        raise OSError(err, os.strerror(err))
