"""The device firmware (``firmware/``) on the simavr AVR simulator.

* :func:`build` compiles the firmware (avr-gcc) and the harness ``fas-simavr`` (a
  small C program on libsimavr) with ``make``; :func:`toolchain_problem` says what is
  missing, if anything.
* :class:`SimavrDevice` is the firmware as a peer of a
  :class:`~fas.serial.clock.VirtualClock`: the harness runs in lockstep, the chip
  advancing only when the clock does, so runs are deterministic and as fast as the
  computer allows.  It stands where :class:`~fas.serial.device.Device` stands in a
  :class:`~fas.serial.loopback.Loopback`.
* :class:`SimavrServer` runs the harness in real time on a new pty (``stepperdemo
  device --simavr``).

The harness records every pin change with its cycle (``--trace``); the firmware's
tick counter is the CPU cycle counter minus the cycle at which timer 1 was started,
so :meth:`Trace.edges` gives edges in device ticks, as the Python device's recorder.
"""

from __future__ import annotations

import fcntl
import os
import re
import shutil
import struct
import subprocess
import tempfile
from array import array
from dataclasses import dataclass, field
from pathlib import Path

from .stream import ByteStream, LinkClosed

FIRMWARE_DIR_ENV = "STEPPERDEMO_FIRMWARE_DIR"
BAUD_RATES = (115200, 1_000_000)
CPU_HZ = 16_000_000
PINS = 20
NS_PER_S = 1_000_000_000
# lockstep: the chip's output is looked at every QUANTUM; after a quiet step the
# interval doubles up to QUANTUM_MAX (the firmware reports every few ms)
QUANTUM_NS = 50_000
QUANTUM_MAX_NS = 1_000_000
DEFAULT_WATCHDOG_MS = 500  # the firmware's own default (a Hello sets the session's)


class SimavrError(RuntimeError):
    """The firmware or its harness cannot be built or run."""


# ------------------------------------------------------------------------- build
def firmware_dir() -> Path:
    """The firmware sources: $STEPPERDEMO_FIRMWARE_DIR or ``firmware/`` of the repository."""
    env = os.environ.get(FIRMWARE_DIR_ENV)
    if env:
        return Path(env)
    return Path(__file__).resolve().parents[2] / "firmware"


def toolchain_problem() -> str | None:
    """What is missing to build and run the firmware in simavr (None: nothing)."""
    missing = [tool for tool in ("make", "avr-gcc", "avr-objcopy", "avr-size", "cc",
                                 "pkg-config") if shutil.which(tool) is None]
    if missing:
        return "missing " + ", ".join(missing)
    for pkg, what in (("simavr", "libsimavr-dev"), ("libelf", "libelf-dev")):
        ok = subprocess.run(["pkg-config", "--exists", pkg], check=False).returncode == 0
        if not ok:
            return f"missing {what} (pkg-config {pkg})"
    if not (firmware_dir() / "Makefile").is_file():
        return f"no firmware sources at {firmware_dir()}"
    return None


@dataclass
class Build:
    elf: Path
    harness: Path
    flash_bytes: int
    ram_bytes: int
    baud: int


def build_dir() -> Path:
    return firmware_dir() / "build"


def elf_path(baud: int = 115200) -> Path:
    return build_dir() / str(baud) / "fasdevice.elf"


def harness_path() -> Path:
    return build_dir() / "fas-simavr"


def _make(*targets: str) -> None:
    problem = toolchain_problem()
    if problem:
        raise SimavrError(f"cannot build the firmware: {problem}")
    fw = firmware_dir()
    build_dir().mkdir(parents=True, exist_ok=True)
    with open(build_dir() / ".lock", "w") as lock:  # one make at a time (test workers)
        fcntl.flock(lock, fcntl.LOCK_EX)
        res = subprocess.run(["make", "-C", str(fw), *targets], capture_output=True,
                             text=True, check=False)
    if res.returncode != 0:
        tail = "\n".join((res.stdout + res.stderr).strip().splitlines()[-15:])
        raise SimavrError(f"make -C {fw} {' '.join(targets)} failed:\n{tail}")


def build(baud: int = 115200) -> Build:
    """``make -C firmware BAUD=baud all sim`` (one make at a time between processes);
    the firmware's flash and RAM use."""
    if baud not in BAUD_RATES:
        raise SimavrError(f"the firmware is built for {' or '.join(map(str, BAUD_RATES))} "
                          f"baud, not {baud}")
    _make(f"BAUD={baud}", "all", "sim")
    flash, ram = firmware_size(elf_path(baud))
    return Build(elf_path(baud), harness_path(), flash, ram, baud)


def build_harness() -> Path:
    """``make -C firmware sim``: the harness alone (for a firmware ELF built elsewhere)."""
    _make("sim")
    return harness_path()


def firmware_size(elf: Path) -> tuple[int, int]:
    """(flash bytes, static RAM bytes) of an ELF (avr-size)."""
    res = subprocess.run(["avr-size", "--format=avr", "--mcu=atmega328p", str(elf)],
                         capture_output=True, text=True, check=True)
    flash = re.search(r"Program:\s+(\d+)", res.stdout)
    ram = re.search(r"Data:\s+(\d+)", res.stdout)
    if not flash or not ram:
        raise SimavrError(f"avr-size said: {res.stdout.strip()}")
    return int(flash.group(1)), int(ram.group(1))


# ------------------------------------------------------------------------- trace
@dataclass
class Trace:
    """Pin changes recorded by the harness: per Arduino pin, cycles and levels."""

    cycles: dict[int, array] = field(default_factory=dict)
    levels: dict[int, bytearray] = field(default_factory=dict)
    timer1_start: int = 0
    end_cycle: int = 0

    @classmethod
    def read(cls, path: str | Path) -> Trace:
        tr = cls()
        end = re.compile(r"# end at cycle (\d+), timer 1 started at cycle (\d+)")
        with open(path) as f:
            for line in f:
                if line.startswith("#"):
                    m = end.match(line)
                    if m:
                        tr.end_cycle, tr.timer1_start = int(m.group(1)), int(m.group(2))
                    continue
                cycle, pin, level = line.split()
                p = int(pin)
                if p not in tr.cycles:
                    tr.cycles[p] = array("q")
                    tr.levels[p] = bytearray()
                tr.cycles[p].append(int(cycle))
                tr.levels[p].append(int(level))
        return tr

    def edges(self, pin: int) -> tuple[array, bytearray]:
        """Edges of ``pin`` in device ticks (cycles since timer 1 started)."""
        base = self.timer1_start
        return (array("q", (c - base for c in self.cycles.get(pin, ()))),
                self.levels.get(pin, bytearray()))

    def rising(self, pin: int) -> list[int]:
        times, levels = self.edges(pin)
        return [t for t, lv in zip(times, levels) if lv]

    def recorder(self):
        """The edges as a :class:`fas.sim.pins.EdgeRecorder` (ticks)."""
        from ..sim.pins import EdgeRecorder

        rec = EdgeRecorder()
        for pin in self.cycles:
            times, levels = self.edges(pin)
            rec.edges(pin, times, bytes(levels))
        return rec


@dataclass(frozen=True)
class PinCount:
    level: int
    rising: int
    falling: int


@dataclass(frozen=True)
class HarnessInfo:
    cycle: int
    timer1_start: int
    frequency: int
    cycles_per_byte: int
    tx_dropped: int
    rx_overruns: int
    sleep_cycles: int  # the chip's idle time (sleep mode)


# ---------------------------------------------------------------------- lockstep
class SimavrDevice:
    """The firmware in simavr as a virtual-clock peer (see the module text).

    Bytes the host wrote reach the chip's UART at the instant the clock has when they
    are read; bytes the chip sends are handed to the line once their last bit has
    left (10 bits a character at the chip's baud setting).
    """

    def __init__(self, stream: ByteStream | None = None, clock=None, *,
                 elf: str | Path | None = None, baud: int = 115200,
                 trace: str | Path | None = None, harness: str | Path | None = None) -> None:
        if elf is None or harness is None:
            built = build(baud)
            elf = elf or built.elf
            harness = harness or built.harness
        self.elf = Path(elf)
        self.clock = clock
        self.default_watchdog_ms = DEFAULT_WATCHDOG_MS
        self._tmpdir: str | None = None
        if trace is None:
            self._tmpdir = tempfile.mkdtemp(prefix="fas-simavr-")
            trace = os.path.join(self._tmpdir, "trace.txt")
        self.trace_path = Path(trace)
        self.proc = subprocess.Popen([str(harness), "--lockstep", "--trace", str(trace),
                                      str(elf)], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, bufsize=0)
        self.cycle = 0
        self._next_tx_cycle = 0
        self._quantum_ns = QUANTUM_NS
        self._out = bytearray()
        self.stream: ByteStream | None = None
        self.in_wires: list = []
        self.closed = False
        self.rx_log: list[tuple[int, bytes]] | None = None  # (cycle, bytes) if recording
        self.attach(stream)

    # ---------------------------------------------------------- the harness
    def _ask(self, request: bytes, answer: int) -> bytes:
        if self.closed:
            raise SimavrError("the simavr harness has ended")
        try:
            self.proc.stdin.write(request)
            data = self._read(answer)
        except (BrokenPipeError, OSError) as exc:
            raise SimavrError(f"the simavr harness ended: {self._stderr()}") from exc
        return data

    def _read(self, n: int) -> bytes:
        out = bytearray()
        while len(out) < n:
            chunk = self.proc.stdout.read(n - len(out))
            if not chunk:
                raise SimavrError(f"the simavr harness ended: {self._stderr()}")
            out += chunk
        return bytes(out)

    def _stderr(self) -> str:
        self.proc.poll()
        return f"exit code {self.proc.returncode}"

    def run_to_cycle(self, cycle: int, data: bytes = b"") -> bytes:
        """Hand ``data`` to the UART now, run to ``cycle``; the bytes sent meanwhile."""
        head = self._ask(b"R" + struct.pack("<QH", cycle, len(data)) + data, 18)
        self.cycle, self._next_tx_cycle, m = struct.unpack("<QQH", head)
        return self._read(m) if m else b""

    def pins(self) -> list[PinCount]:
        data = self._ask(b"P", 9 * PINS)
        return [PinCount(*struct.unpack_from("<BII", data, 9 * i)) for i in range(PINS)]

    def info(self) -> HarnessInfo:
        return HarnessInfo(*struct.unpack("<QQIIIIQ", self._ask(b"I", 40)))

    def trace(self) -> Trace:
        """The pin changes so far (the harness flushes its trace file first)."""
        if not self.closed:
            self._ask(b"Q", 1)
            self.closed = True
            self.proc.wait(timeout=10)
        return Trace.read(self.trace_path)

    # ------------------------------------------------------------- the line
    def attach(self, stream: ByteStream | None) -> None:
        """Plug a line in (``None``: unplugged; the chip keeps running)."""
        self.stream = stream
        self.in_wires = [stream.rx_wire] if stream is not None and stream.rx_wire else []

    def unplug(self) -> None:
        if self.stream is not None:
            if self.stream.rx_wire is not None:
                self.stream.rx_wire.drain()
            self.stream.close()
        self.attach(None)

    def poll(self) -> None:
        """Take what the host wrote: it reaches the UART at the chip's present cycle."""
        if self.stream is None:
            return
        try:
            data = self.stream.read_available()
        except LinkClosed:
            self.attach(None)
            return
        if data and self.rx_log is not None:
            self.rx_log.append((self.cycle, data))
        for i in range(0, len(data), 65535):  # the harness takes 65535 bytes a step
            self._out += self.run_to_cycle(self.cycle, data[i:i + 65535])
        if data:
            self._quantum_ns = QUANTUM_NS

    def flush(self) -> bool:
        if not self._out:
            return False
        data, self._out = bytes(self._out), bytearray()
        if self.stream is None:
            return False
        try:
            return self.stream.write(data) > 0
        except LinkClosed:
            self.attach(None)
            return False

    # --------------------------------------------------------------- time
    def cycle_at(self, now_ns: int) -> int:
        return now_ns * CPU_HZ // NS_PER_S

    def ns_at(self, cycle: int) -> int:
        return -(-cycle * NS_PER_S // CPU_HZ)

    def advance(self, now_ns: int) -> None:
        target = self.cycle_at(now_ns)
        if target <= self.cycle:
            return
        sent = self.run_to_cycle(target)
        self._out += sent
        if sent:
            self._quantum_ns = QUANTUM_NS
        else:  # quiet: look less often
            self._quantum_ns = min(self._quantum_ns * 2, QUANTUM_MAX_NS)

    def next_ns(self) -> int | None:
        now = self.ns_at(self.cycle)
        nxt = now + self._quantum_ns
        if self._next_tx_cycle:
            nxt = min(nxt, self.ns_at(self._next_tx_cycle))
        return max(nxt, now + 1)

    def close(self) -> None:
        if not self.closed:
            try:
                self._ask(b"Q", 1)
            except SimavrError:
                pass
            self.closed = True
        try:
            self.proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        for f in (self.proc.stdin, self.proc.stdout):
            if f is not None:
                f.close()
        if self._tmpdir is not None:
            shutil.rmtree(self._tmpdir, ignore_errors=True)
            self._tmpdir = None


# --------------------------------------------------------------------- real time
class SimavrServer:
    """The harness on a new pty, in real time (``stepperdemo device --simavr``)."""

    def __init__(self, elf: str | Path, harness: str | Path, *, speed: float = 1.0,
                 link: str | None = None, trace: str | None = None) -> None:
        args = [str(harness), "--pty", "--speed", repr(float(speed))]
        if link:
            args += ["--link", link]
        if trace:
            args += ["--trace", trace]
        args.append(str(elf))
        self.proc = subprocess.Popen(args, stdout=subprocess.PIPE, text=True, bufsize=1)
        first = self.proc.stdout.readline().strip()
        if not first.startswith("/"):
            self.proc.wait(timeout=10)
            raise SimavrError(f"the simavr harness did not start (exit code "
                              f"{self.proc.returncode})")
        self.path = first

    def stop(self) -> list[str]:
        """End the run; the harness's summary lines."""
        if self.proc.poll() is None:
            self.proc.terminate()
        out, _ = self.proc.communicate(timeout=30)
        return [line for line in out.splitlines() if line.strip()]

    def wait(self) -> int:
        return self.proc.wait()
