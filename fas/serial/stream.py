"""Byte streams under the link: a pyserial port, a raw descriptor (pty), a new pty.

A stream reads what has arrived without blocking and raises :class:`LinkClosed`
when the other end is gone (unplugged adapter, closed pty).  Under a virtual clock a
stream carries :class:`~fas.serial.clock.Wire` counters (``tx_wire``/``rx_wire``):
writes count bytes sent, and a read takes every byte already sent, waiting for the
kernel to deliver them, so that what a party reads at an instant never depends on
how the pty happened to split the data.
"""

from __future__ import annotations

import contextlib
import errno
import os
import select
import tty
from abc import ABC, abstractmethod
from typing import Protocol

from .clock import Wire, wait_readable

READ_CHUNK = 4096
VIRTUAL_IO_TIMEOUT_S = 10.0


class LinkClosed(ConnectionError):
    """The serial line is gone."""


class ByteStream(ABC):
    """Base: non-blocking reads, best-effort writes, optional wire counters."""

    tx_wire: Wire | None = None
    rx_wire: Wire | None = None
    name = ""

    @abstractmethod
    def fileno(self) -> int:
        """Implemented by each kind of line."""

    @abstractmethod
    def _read_raw(self) -> bytes:
        """Implemented by each kind of line."""

    @abstractmethod
    def _write_raw(self, data: bytes) -> int:
        """Implemented by each kind of line."""

    @abstractmethod
    def close(self) -> None:
        """Implemented by each kind of line."""

    def read_available(self) -> bytes:
        wire = self.rx_wire
        if wire is None:
            return self._read_raw()
        out = bytearray()
        while True:
            data = self._read_raw()
            if data:
                out += data
                wire.received += len(data)
            if wire.received >= wire.sent:
                return bytes(out)
            if not wait_readable([self.fileno()], VIRTUAL_IO_TIMEOUT_S):
                raise LinkClosed(f"{wire.name or 'wire'}: bytes sent but never delivered")

    def write(self, data: bytes) -> int:
        n = self._write_raw(data)
        if self.tx_wire is not None:
            self.tx_wire.sent += n
        return n


class FdStream(ByteStream):
    """A raw descriptor (pty master or slave, tty).  Writes that would block are dropped
    and counted (``tx_dropped``) when ``drop_when_full``, as a UART with no listener."""

    def __init__(self, fd: int, *, name: str = "", drop_when_full: bool = True,
                 owns: bool = True, keep_fds: tuple[int, ...] = ()) -> None:
        self.fd = fd
        self.name = name
        self.drop_when_full = drop_when_full
        self.owns = owns
        self.keep_fds = keep_fds  # descriptors closed together with this one
        self.tx_dropped = 0
        self.closed = False
        os.set_blocking(fd, False)

    def fileno(self) -> int:
        return self.fd

    def _read_raw(self) -> bytes:
        if self.closed:
            raise LinkClosed(f"{self.name}: closed")
        out = bytearray()
        while True:
            try:
                data = os.read(self.fd, READ_CHUNK)
            except BlockingIOError:
                return bytes(out)
            except OSError as exc:
                if exc.errno in (errno.EIO, errno.EBADF, errno.ENXIO):
                    if out:
                        return bytes(out)
                    raise LinkClosed(f"{self.name}: {exc.strerror}") from exc
                raise
            if not data:
                if out:
                    return bytes(out)
                raise LinkClosed(f"{self.name}: end of file")
            out += data
            if len(data) < READ_CHUNK:
                return bytes(out)

    def _write_raw(self, data: bytes) -> int:
        if self.closed:
            raise LinkClosed(f"{self.name}: closed")
        done = 0
        view = memoryview(data)
        while done < len(data):
            try:
                done += os.write(self.fd, view[done:])
            except BlockingIOError:
                if self.drop_when_full:
                    self.tx_dropped += len(data) - done
                    return done
                select.select([], [self.fd], [], 1.0)
            except OSError as exc:
                raise LinkClosed(f"{self.name}: {exc.strerror}") from exc
        return done

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        if self.owns:
            for fd in (self.fd, *self.keep_fds):
                with contextlib.suppress(OSError):
                    os.close(fd)


class SerialPort(Protocol):
    """What a stream uses of a pyserial port (``serial.Serial`` has it)."""

    in_waiting: int
    dtr: bool  # a board's reset line (stepperdemo's board console pulses it)

    def fileno(self) -> int: ...
    def read(self, size: int = 1) -> bytes: ...
    def write(self, data: bytes, /) -> int | None: ...
    def close(self) -> None: ...


class SerialStream(ByteStream):
    """A pyserial port (``serial.Serial`` or anything ``serial_for_url`` returns)."""

    def __init__(self, port: SerialPort, *, name: str = "") -> None:
        self.port = port
        self.name = name or getattr(port, "port", "") or ""
        self.close_error = ""

    def fileno(self) -> int:
        return self.port.fileno()

    def _read_raw(self) -> bytes:
        import serial

        try:
            r, _, _ = select.select([self.port.fileno()], [], [], 0)
            if not r:
                return b""
            return self.port.read(max(1, self.port.in_waiting))
        except (serial.SerialException, OSError, ValueError, TypeError) as exc:
            raise LinkClosed(f"{self.name}: {exc}") from exc

    def _write_raw(self, data: bytes) -> int:
        import serial

        try:
            return self.port.write(data) or 0
        except (serial.SerialException, OSError, ValueError, TypeError) as exc:
            raise LinkClosed(f"{self.name}: {exc}") from exc

    def close(self) -> None:
        try:
            self.port.close()
        except (OSError, ValueError) as exc:  # a dead port may fail to close
            self.close_error = str(exc)


def open_serial(path: str, baud: int = 115200) -> SerialStream:
    """Open a serial port (or pty, or pyserial URL) raw and non-blocking, input flushed."""
    import serial

    try:
        port = serial.serial_for_url(path, baudrate=baud, timeout=0, write_timeout=2.0)
        port.reset_input_buffer()
    except (serial.SerialException, OSError, ValueError) as exc:
        raise LinkClosed(f"{path}: {exc}") from exc
    return SerialStream(port, name=path)


class Pty:
    """A new pseudo-terminal: we keep the master; the slave ``path`` is for the other side.

    The slave is set raw and one descriptor of it stays open here, so that the master
    never sees a hang-up while no program has the slave open: a host may come, go and
    come back, as with a USB adapter that stays plugged in.
    """

    def __init__(self, name: str = "pty") -> None:
        master, slave = os.openpty()
        tty.setraw(slave)
        self.path = os.ttyname(slave)
        self.stream = FdStream(master, name=f"{name} {self.path}", keep_fds=(slave,))

    def close(self) -> None:
        self.stream.close()


def set_link(link_path: str | None, target: str) -> None:
    """Point the symbolic link ``link_path`` at ``target`` (atomically replaced)."""
    if not link_path:
        return
    tmp = f"{link_path}.tmp{os.getpid()}"
    with contextlib.suppress(FileNotFoundError):
        os.unlink(tmp)
    os.symlink(target, tmp)
    os.replace(tmp, link_path)


def remove_link(link_path: str | None, target: str) -> None:
    """Remove ``link_path`` if it still points at ``target``."""
    if not link_path:
        return
    try:
        if os.readlink(link_path) == target:
            os.unlink(link_path)
    except OSError:
        pass
