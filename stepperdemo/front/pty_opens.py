"""Every open and close of a pty's slave side, in order, as the kernel reports them.

A pty has no DTR line, and the master side sees a host's close only as a hang-up
(EIO) while nobody has the slave open: a host that closes and opens again at once
is not seen at all.  Linux's inotify reports each open (``IN_OPEN``) and each last
close of an open file (``IN_CLOSE_WRITE`` / ``IN_CLOSE_NOWRITE``) of the slave's
device node (``/dev/pts/N``), in the order they happened, whoever opens it (also
through a symlink).  The two system calls are reached through ``ctypes`` (the
standard library has no inotify); where they are missing (not Linux, no inotify
instance left) :func:`watch` gives None and the caller falls back to the hang-up.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import struct

IN_CLOSE_WRITE = 0x0008
IN_CLOSE_NOWRITE = 0x0010
IN_OPEN = 0x0020
IN_Q_OVERFLOW = 0x4000
_EVENT = struct.Struct("iIII")  # wd, mask, cookie, len (then len bytes of name)
_READ = 65536


class OpenWatch:
    """The opens and closes of one path, read without blocking."""

    def __init__(self, fd: int) -> None:
        self.fd = fd

    def take(self) -> list[bool]:
        """What happened since the last call, oldest first: True an open, False a close.
        A lost queue (overflow) reads as a close and an open: someone may be there."""
        changes: list[bool] = []
        while True:
            try:
                data = os.read(self.fd, _READ)
            except (BlockingIOError, InterruptedError):
                return changes
            if not data:
                return changes
            at = 0
            while at + _EVENT.size <= len(data):
                _wd, mask, _cookie, size = _EVENT.unpack_from(data, at)
                at += _EVENT.size + size
                if mask & IN_Q_OVERFLOW:
                    changes += [False, True]
                elif mask & IN_OPEN:
                    changes.append(True)
                elif mask & (IN_CLOSE_WRITE | IN_CLOSE_NOWRITE):
                    changes.append(False)

    def close(self) -> None:
        os.close(self.fd)


def watch(path: str) -> OpenWatch | None:
    """An :class:`OpenWatch` of ``path``, or None where the kernel offers none."""
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or None, use_errno=True)
        init1, add_watch = libc.inotify_init1, libc.inotify_add_watch
    except (OSError, AttributeError):
        return None
    add_watch.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_uint32]
    fd = init1(os.O_NONBLOCK | os.O_CLOEXEC)
    if fd < 0:
        return None
    if add_watch(fd, os.fsencode(path), IN_OPEN | IN_CLOSE_WRITE | IN_CLOSE_NOWRITE) < 0:
        os.close(fd)
        return None
    return OpenWatch(fd)
