"""``stepperdemo device --pty --console``: the simulated StepperDemo firmware on a pty.

A stand-in for a board flashed with the original StepperDemo sketch: the simulated
board (:class:`~stepperdemo.demo.serial_board.SimulatedBoard`) in real time (or
``--speed`` times faster) behind a new pseudo-terminal, speaking the firmware's text
console byte for byte.  Everything ``--board`` does can be tried and tested on it.

The reset: a pty has no DTR line, so the device resets the firmware the way an
Arduino Uno's auto-reset does, when a host opens the port.  :class:`HangupPty` sees
every open and close of the slave side (a close and an open back to back included,
through Linux's inotify; elsewhere as the master's hang-up while nobody has it open);
every open after a close restarts the firmware (banner, usage, stepper table), and
while no host has the port open the firmware stands still and nothing is sent.
``--board`` resets a pty by closing and opening it (its DTR pulse fails there), which
is exactly this.
"""

from __future__ import annotations

import argparse
import errno
import os
import select
import sys
import termios
import time
import tty
from collections.abc import Callable

from fas.arch import get_profile

from .. import messages as msg
from ..demo.serial_board import SimulatedBoard
from . import pty_opens

HANGUP_POLL_S = 0.01  # while no host has the port open: look this often
MAX_SLEEP_S = 0.05
READ_CHUNK = 4096
#: a new host is taken on (the reset, the banner) this long after its open, as an
#: Arduino's bootloader delays the sketch after DTR (there about 1 s): a host that
#: clears its input after opening (pyserial does) must not clear the banner away
BOOT_S = 0.05


class HangupPty:
    """A new pty on which every host's open and close is seen, back to back included.

    Where the kernel reports the slave's opens and closes (:mod:`.pty_opens`), a
    descriptor of the slave is kept here (so the master never hangs up) and a host is
    served from its open to its close: :meth:`read` gives the bytes of the host that
    left, then None once, then the next host's bytes - a new host after a close is
    always seen, even when it opened before the close was noticed.  What the last
    host left unread is discarded when it goes and when the next one comes.
    Elsewhere the slave is not held and a close is the master's hang-up (EIO), seen
    only while nobody has the port open.  A new host is taken on :data:`BOOT_S`
    after its open; what it sends meanwhile waits for it.
    """

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self.clock = clock
        self.master, slave = os.openpty()
        tty.setraw(slave)
        self.path = os.ttyname(slave)
        os.set_blocking(self.master, False)
        self.watch = pty_opens.watch(self.path)  # after our own open: not counted
        self._slave: int | None = slave
        if self.watch is None:
            os.close(slave)
            self._slave = None
        self._hosts = 0  # opens minus closes seen
        self._came = False  # a host opened since a host was last taken on
        self._came_at = 0.0  # ... at this clock time (its last open)
        self._serving = False  # a host is being served
        self._gone = False  # ... and it has closed (another may have opened since)
        self._say_gone = False  # the next read says None

    def _look(self) -> None:
        for opened in self.watch.take():
            if opened:
                self._hosts += 1
                if self._hosts == 1:
                    self._came, self._came_at = True, self.clock()
            else:
                self._hosts = max(0, self._hosts - 1)
                self._gone = self._gone or (self._serving and self._hosts == 0)

    def _discard_unread(self) -> None:
        """Forget what was sent and not read: the next host must not get it."""
        termios.tcflush(self._slave, termios.TCIFLUSH)

    def _read_master(self) -> bytes | None:
        try:
            return os.read(self.master, READ_CHUNK)
        except BlockingIOError:
            return b""
        except OSError as exc:
            if exc.errno == errno.EIO:
                return None
            raise

    def _read_all(self) -> bytes:
        """What is left to read of a host that has closed (bounded: another host may
        be writing behind it)."""
        data = bytearray()
        for _ in range(64):
            chunk = self._read_master()
            if not chunk:
                break
            data += chunk
        return bytes(data)

    def read(self) -> bytes | None:
        """What the host sent (b"": nothing), or None while no host has it open (and
        once after a host closed it, even if another opened it since)."""
        if self.watch is None:
            return self._read_master()
        if self._say_gone:
            self._say_gone = False
            return None
        self._look()
        if self._serving:
            data = self._read_master() or b""
            if self._gone:  # then all the host wrote before its close is its own
                data += self._read_all()
                self._serving = self._gone = False
                self._say_gone = True
                self._discard_unread()
            return data
        if not (self._came or self._hosts) or self.clock() - self._came_at < BOOT_S:
            return None
        self._came = False
        self._serving = True  # a new host
        self._discard_unread()
        data = self._read_master() or b""
        if not self._hosts:  # opened and closed again already: a reset all the same
            data += self._read_all()
            self._serving = False
            self._say_gone = True
        return data

    def write(self, data: bytes) -> int:
        """What the pty took now (0 while its buffer is full or nobody has it open)."""
        if self.watch is not None:
            self._look()
            if not self._serving or self._gone or self._say_gone:
                return 0
        try:
            sent = os.write(self.master, data)
        except (BlockingIOError, OSError):
            return 0
        if self.watch is not None:
            self._look()
            if self._gone:  # it went while this was written
                self._discard_unread()
        return sent

    def readers(self) -> list[int]:
        """Descriptors that become readable when the host sends or opens or closes."""
        return [self.master] if self.watch is None else [self.watch.fd, self.master]

    def idle_readers(self) -> list[int]:
        """Descriptors that become readable when a host opens the port while none is
        served (the master is left out: it hangs up if not held, and a new host's
        bytes wait until it is taken on)."""
        return [] if self.watch is None else [self.watch.fd]

    def close(self) -> None:
        os.close(self.master)
        if self._slave is not None:
            os.close(self._slave)
        if self.watch is not None:
            self.watch.close()


class ConsoleDevice:
    """Serves a :class:`SimulatedBoard` on a :class:`HangupPty` in real time."""

    def __init__(self, board: SimulatedBoard, pty: HangupPty, speed: float = 1.0,
                 events: Callable[[str], None] | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.board = board
        self.pty = pty
        self.speed = speed
        self.events = events
        self.clock = clock
        self.open = False
        self._unsent = bytearray()  # printed, not yet taken by the pty (a slow host)
        self._wall0 = clock()
        self._tps = board.profile.ticks_per_s

    def _event(self, text: str) -> None:
        if self.events is not None:
            self.events(text)

    def _target_tick(self) -> int:
        return int((self.clock() - self._wall0) * self.speed * self._tps)

    @property
    def tx_unsent(self) -> int:
        """Characters printed that the host has not taken yet."""
        return len(self._unsent)

    def _opened(self) -> None:
        self.open = True
        self._unsent.clear()  # a new host: what the old one left is not its business
        self.board.reset()
        self._wall0 = self.clock()
        self._event(msg.CONSOLE_DEVICE_OPENED)

    def step(self) -> None:
        """Serve once: take input, run the firmware up to now, send what it printed,
        and sleep until it next has something to do or input arrives."""
        data = self.pty.read()
        if data is None:
            if self.open:
                self.open = False
                self._event(msg.CONSOLE_DEVICE_CLOSED)
            select.select(self.pty.idle_readers(), [], [], HANGUP_POLL_S)
            return
        if not self.open:
            self._opened()
        if data:
            self.board.receive(data)
        now = self._target_tick()
        self.board.run_until(now)
        self._unsent += self.board.take_output(now)
        if self._unsent:  # a host that falls behind gets the output late, never loses it
            del self._unsent[:self.pty.write(bytes(self._unsent))]
        wake = self.board.next_wake_tick()
        sleep = MAX_SLEEP_S
        if wake is not None:
            sleep = min(sleep, max(0.0, (wake - self._target_tick()) / self._tps / self.speed))
        writable = [self.pty.master] if self._unsent else []
        select.select(self.pty.readers(), writable, [], sleep)

    def serve(self, stop: Callable[[], bool]) -> None:
        while not stop():
            self.step()


def run(args: argparse.Namespace) -> int:
    """``stepperdemo device --pty --console [--arch] [--speed] [--link] [--quiet]``."""
    from fas.serial.stream import remove_link, set_link

    from .serial_cli import StopOnSignal

    if args.port:
        print(msg.CLI_ERROR.format(problem=msg.CLI_CONSOLE_NO_PORT), file=sys.stderr)
        return 2
    profile = get_profile(args.arch)
    pty = HangupPty()
    set_link(args.link, pty.path)
    events = None if args.quiet else (
        lambda text: print(msg.CONSOLE_DEVICE_EVENT.format(event=text), flush=True))
    device = ConsoleDevice(SimulatedBoard(profile), pty, args.speed, events)
    if args.quiet:
        print(pty.path, flush=True)
    else:
        print(msg.CONSOLE_DEVICE_LISTENING.format(
            profile=profile.name, title=profile.title, path=pty.path,
            link=f" ({args.link})" if args.link else "", speed=args.speed), flush=True)
    stop = StopOnSignal()
    try:
        device.serve(stop)
    finally:
        remove_link(args.link, pty.path)
        pty.close()
    if not args.quiet:
        b = device.board
        print(msg.CONSOLE_DEVICE_STATS.format(resets=b.resets, rx=b.rx_bytes,
                                              dropped=b.rx_dropped, tx=b.tx_bytes,
                                              tx_unsent=device.tx_unsent))
        positions = ", ".join(f"M{i + 1} {p}" for i, p in enumerate(b.positions())
                              if p is not None)
        print(msg.CONSOLE_DEVICE_POSITIONS.format(positions=positions))
    return 0
