"""``stepperdemo gcode --pty`` / ``--tcp``: the G-code machine for G-code senders.

The program (:class:`~.program.GcodeProgram`) is served in real time (``--speed``
times faster if asked) on a new pseudo-terminal or a TCP port, so that bCNC, cncjs,
Universal G-code Sender, LaserGRBL, pygrbl-streamer ... connect to it as to a board
running Grbl 1.1:

* **A host opening the port is a reset**, as an Arduino's DTR is: the machine powers
  on (stopped, outputs off, machine position 0, the banner
  ``\\r\\nGrbl 1.1h ['$' for help]\\r\\n``); settings and ``$N`` lines are kept.  On a
  pty the host's open and close are seen because no descriptor of its slave side is
  kept here (:class:`~stepperdemo.front.console_device.HangupPty`); on TCP a
  connection is a host, one at a time (a second one is told it is busy and closed).
* Bytes go to Grbl's receive path the moment they are read: real-time bytes act at
  the simulated tick of that moment, the rest fills the 128-byte ring.
* The simulated chip runs whether or not a host is there: what a host queued goes on
  after it left (as on a board); its output is dropped.  Host after host until
  Ctrl-C (or SIGTERM), then the statistics and ``--vcd``/``--report`` are finished.

With ``--port DEVICE`` the queue commands go to a device (``stepperdemo device``,
our firmware) whose clock is the program's.
"""

from __future__ import annotations

import contextlib
import errno
import select
import socket
import time
from collections.abc import Callable

from .. import messages as msg
from ..front.console_device import HangupPty
from .program import GcodeProgram

MAX_SLEEP_S = 0.02
NO_HOST_POLL_S = 0.01  # while no host has the port: look this often
READ_CHUNK = 4096
MAX_UNSENT = 1 << 20  # a host that reads nothing is dropped beyond this much output


class TcpPort:
    """A listening TCP socket; one accepted connection is the host."""

    def __init__(self, host: str, port: int) -> None:
        self.server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.server.bind((host, port))
        self.server.listen(2)
        self.server.setblocking(False)
        self.client: socket.socket | None = None
        self.address = self.server.getsockname()
        self.path = f"tcp://{self.address[0]}:{self.address[1]}"
        self.refused = 0
        self._left = False  # the host went while being written to: not yet said

    def fileno_list(self) -> list:
        return [self.server] + ([self.client] if self.client is not None else [])

    def _accept(self) -> None:
        while True:
            try:
                conn, _ = self.server.accept()
            except (BlockingIOError, InterruptedError):
                return
            conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            if self.client is None:
                conn.setblocking(False)
                self.client = conn
            else:  # one host at a time
                self.refused += 1
                with contextlib.suppress(OSError):
                    conn.sendall((msg.GRBL_MSG.format(text=msg.GCODE_TCP_BUSY) + "\r\n")
                                 .encode())
                conn.close()

    def read(self) -> bytes | None:
        """What the host sent (b"": nothing now), or None while no host is connected.
        A host that has left is noticed before a new one is let in."""
        if self._left:  # it went while answers were sent: say so before the next host
            self._left = False
            return None
        if self.client is None:
            self._accept()
            if self.client is None:
                return None
        try:
            data = self.client.recv(READ_CHUNK)
        except (BlockingIOError, InterruptedError):
            self._accept()  # a second host now is refused
            return b""
        except OSError:
            data = b""
        if not data:  # the host closed the connection
            self._drop()
            return None
        # no _accept() here: bytes may be the last a leaving host sent (its close is
        # seen at the next read), and the one who connects next is then the next host;
        # a second host is refused once this one is seen alive (nothing to read now)
        return data

    def _drop(self) -> None:
        if self.client is not None:
            with contextlib.suppress(OSError):
                self.client.close()
        self.client = None

    def write(self, data: bytes) -> int:
        if self.client is None:
            return 0
        try:
            return self.client.send(data)
        except (BlockingIOError, InterruptedError):
            return 0
        except OSError:
            self._drop()
            self._left = True
            return 0

    def close(self) -> None:
        self._drop()
        self.server.close()


class PtyPort:
    """A new pseudo-terminal whose host's open and close are seen."""

    def __init__(self) -> None:
        self.pty = HangupPty()
        self.path = self.pty.path

    def fileno_list(self) -> list:
        return [self.pty.master]

    def read(self) -> bytes | None:
        return self.pty.read()

    def write(self, data: bytes) -> int:
        return self.pty.write(data)

    def close(self) -> None:
        self.pty.close()


class Endpoint:
    """Serves a :class:`GcodeProgram` to host after host on a port (see the module)."""

    def __init__(self, program: GcodeProgram, port, speed: float = 1.0, *,
                 device_clock: bool = False, events: Callable[[str], None] | None = None,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.program = program
        self.port = port
        self.speed = speed
        self.device_clock = device_clock  # a device's clock runs by itself (--port)
        self.events = events
        self.clock = clock
        self.open = False
        self.hosts = 0
        self.rx_bytes = 0
        self.tx_bytes = 0
        self.tx_dropped = 0
        self.lagged = 0  # ticks the chip fell behind the wall clock (and gave up)
        self._unsent = bytearray()
        program.output = self._collect
        program.setup()
        self._unsent.clear()  # the power-on banner: nobody is there yet
        self._wall0 = clock()
        self._tick0 = program.backend.now()
        self._tps = program.profile.ticks_per_s

    def _collect(self, data: bytes) -> None:
        if not self.open:
            self.tx_dropped += len(data)
            return
        self._unsent += data
        if len(self._unsent) > MAX_UNSENT:  # nobody reads: let the host go
            self.tx_dropped += len(self._unsent)
            self._unsent.clear()

    def _event(self, text: str) -> None:
        if self.events is not None:
            self.events(text)

    def target_tick(self) -> int:
        if self.device_clock:
            return self.program.backend.now()
        return self._tick0 + int((self.clock() - self._wall0) * self.speed * self._tps)

    def _run(self) -> None:
        program = self.program
        if self.device_clock:
            backend = program.backend
            program.run_until(backend.now())
            backend.app_wait_until(backend.now())
            program.loop_pass()
            return
        # never more than one step's worth at once: a chip that fell behind the wall
        # clock (a busy computer) goes on from there instead of racing ahead of the
        # host's next bytes - the sender's lines must not arrive "late"
        limit = program.backend.now() + int(MAX_SLEEP_S * self.speed * self._tps)
        target = self.target_tick()
        if target > limit:
            self.lagged += target - limit
            self._tick0 -= target - limit
            target = limit
        program.run_until(target)

    def step(self) -> None:
        """Serve once: run the chip up to now, take the host's bytes, send the answers,
        sleep until the program or the host has something."""
        self._run()
        data = self.port.read()
        if data is None:
            if self.open:
                self.open = False
                self._unsent.clear()
                self._event(msg.GCODE_HOST_CLOSED)
        else:
            if not self.open:
                self.open = True
                self.hosts += 1
                self._unsent.clear()
                self.program.host_opened()
                self._event(msg.GCODE_HOST_OPENED)
            if data:
                self.rx_bytes += len(data)
                self.program.feed(data)
                self.program.loop_pass()
        if self._unsent:
            sent = self.port.write(bytes(self._unsent))
            self.tx_bytes += sent
            del self._unsent[:sent]
        self._sleep(data is None)

    def _sleep(self, no_host: bool) -> None:
        timeout = NO_HOST_POLL_S if no_host else MAX_SLEEP_S
        wake = self.program.next_wake_tick()
        if wake is not None and not self.device_clock:
            ahead = (wake - self.target_tick()) / self._tps / self.speed
            timeout = min(timeout, max(0.0, ahead))
        elif wake is not None:
            timeout = min(timeout, 0.001)
        readers = self.port.fileno_list()
        writers = [f for f in readers[-1:]] if self._unsent else []
        try:
            select.select([] if no_host and isinstance(self.port, PtyPort) else readers,
                          writers, [], timeout)
        except OSError as exc:  # pragma: no cover - a closed descriptor at the end
            if exc.errno != errno.EBADF:
                raise

    def serve(self, stop: Callable[[], bool]) -> None:
        while not stop():
            self.step()


def parse_tcp(text: str) -> tuple[str, int]:
    """``[HOST:]PORT`` -> (host, port); loopback unless a host is given."""
    host, sep, port = text.rpartition(":")
    if not sep:
        host = "127.0.0.1"
    try:
        number = int(port)
    except ValueError:
        raise ValueError(msg.GCODE_TCP_BAD.format(text=text)) from None
    if not 0 <= number <= 65535:
        raise ValueError(msg.GCODE_TCP_BAD.format(text=text))
    return host or "127.0.0.1", number
