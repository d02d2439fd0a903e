"""``stepperdemo device --pty --console``: the simulated StepperDemo firmware on a pty.

A stand-in for a board flashed with the original StepperDemo sketch: the simulated
board (:class:`~stepperdemo.demo.serial_board.SimulatedBoard`) in real time (or
``--speed`` times faster) behind a new pseudo-terminal, speaking the firmware's text
console byte for byte.  Everything ``--board`` does can be tried and tested on it.

The reset: a pty has no DTR line, so the device resets the firmware the way an
Arduino Uno's auto-reset does, when a host opens the port.  The device keeps no
descriptor of the pty's slave side open, so it sees the slave close (the master
reads EIO: a hang-up) and open again; every open after a close restarts the
firmware (banner, usage, stepper table), and while no host has the port open the
firmware stands still and nothing is sent.  ``--board`` resets a pty by closing
and opening it (its DTR pulse fails there), which is exactly this.
"""

from __future__ import annotations

import argparse
import errno
import os
import select
import sys
import time
import tty
from collections.abc import Callable

from fas.arch import get_profile

from .. import messages as msg
from ..demo.serial_board import SimulatedBoard

HANGUP_POLL_S = 0.01  # while no host has the port open: look this often
MAX_SLEEP_S = 0.05
READ_CHUNK = 4096


class HangupPty:
    """A new pty whose slave side is not held open here (a host's close is seen)."""

    def __init__(self) -> None:
        self.master, slave = os.openpty()
        tty.setraw(slave)
        self.path = os.ttyname(slave)
        os.close(slave)
        os.set_blocking(self.master, False)

    def read(self) -> bytes | None:
        """What the host sent (b"": nothing), or None while no host has it open."""
        try:
            return os.read(self.master, READ_CHUNK)
        except BlockingIOError:
            return b""
        except OSError as exc:
            if exc.errno == errno.EIO:
                return None
            raise

    def write(self, data: bytes) -> int:
        """What the pty took now (0 while its buffer is full or nobody has it open)."""
        try:
            return os.write(self.master, data)
        except (BlockingIOError, OSError):
            return 0

    def close(self) -> None:
        os.close(self.master)


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
            select.select([], [], [], HANGUP_POLL_S)
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
        select.select([self.pty.master], writable, [], sleep)

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
