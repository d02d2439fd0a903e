"""The device firmware (``firmware/``) on the simavr AVR simulator.

* :func:`build` compiles the firmware (avr-gcc) and the harness ``fas-simavr`` (a
  small C program on libsimavr) with ``make``; :func:`toolchain_problem` says what is
  missing, if anything.
* :class:`SimavrDevice` is the firmware as a peer of a
  :class:`~fas.serial.clock.VirtualClock`: the harness runs in lockstep, the chip
  advancing only when the clock does, so runs are deterministic and as fast as the
  computer allows.  It stands where :class:`~fas.device.Device` stands in a
  :class:`~fas.device.loopback.Loopback`.
* :class:`SimavrServer` runs the harness in real time on a new pty (``stepperdemo
  device --simavr``).

The harness records every pin change with its cycle (``--trace``); the firmware's
tick counter is the CPU cycle counter minus the cycle at which timer 1 was started,
so :meth:`Trace.edges` gives edges in device ticks, as the Python device's recorder.

The harness is also the world outside the board: :meth:`SimavrDevice.set_input` (or
``schedule_input`` at a given tick) closes a switch or turns a pot on the chip's pins
- a level on a digital pin, a value 0..1023 on the A/D converter of A0-A7 (untouched
ones read 512, centred pots) - and the firmware forwards the protocol's SetInput to
it, so a host can turn the simulated pots itself (docs/serial-protocol.md, 18).
"""

from __future__ import annotations

import bisect
import ctypes
import fcntl
import functools
import hashlib
import os
import random
import re
import shutil
import subprocess
import tempfile
from array import array
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from ..serial.clock import Wire
from ..serial.stream import ByteStream, LinkClosed

if TYPE_CHECKING:  # pragma: no cover
    from ..serial.clock import VirtualClock
    from ..sim.pins import EdgeRecorder
    from .device import Device

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
SYNC = 0x7E  # the byte that ends every frame
RAMEND_328P = 0x8FF
STACK_PAINT = 0xC5  # firmware/main.c paints the free RAM with it at reset


class SimavrError(RuntimeError):
    """The firmware or its harness cannot be built or run."""


# ------------------------------------------------------------------------- build
def firmware_dir() -> Path:
    """The firmware sources: $STEPPERDEMO_FIRMWARE_DIR, the installed package's copy
    (``fas/device/firmware``, package data: setup.py) or ``firmware/`` of the checkout."""
    env = os.environ.get(FIRMWARE_DIR_ENV)
    if env:
        return Path(env)
    installed = _installed_firmware()
    return installed if (installed / "Makefile").is_file() else _checkout_firmware()


def _installed_firmware() -> Path:
    return Path(__file__).resolve().parent / "firmware"


def _checkout_firmware() -> Path:
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
    """Where the firmware is built: ``build/`` beside the sources of a checkout (or of
    $STEPPERDEMO_FIRMWARE_DIR); for the installed package, whose folder may be
    read-only and is replaced by every upgrade, a per-user cache named by a hash of
    the sources: ``$XDG_CACHE_HOME/stepperdemo/firmware/<hash>`` (~/.cache)."""
    fw = firmware_dir()
    if fw != _installed_firmware():
        return fw / "build"
    cache = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(cache) / "stepperdemo" / "firmware" / sources_key(fw)


@functools.lru_cache(maxsize=4)
def sources_key(fw: Path) -> str:
    """16 hex digits of a SHA-256 over the names and contents of the firmware's sources
    (its ``build/`` folder left out)."""
    digest = hashlib.sha256()
    for path in sorted(fw.rglob("*")):
        rel = path.relative_to(fw)
        if path.is_file() and rel.parts[0] != "build" and "__pycache__" not in rel.parts:
            digest.update(rel.as_posix().encode() + b"\0" + path.read_bytes() + b"\0")
    return digest.hexdigest()[:16]


def _cached() -> bool:
    """Builds go to the per-user cache: what is there was built from these very sources."""
    return firmware_dir() == _installed_firmware()


def elf_path(baud: int = 115200) -> Path:
    return build_dir() / str(baud) / "fasdevice.elf"


def harness_path() -> Path:
    return build_dir() / "fas-simavr"


def _stamps(targets: tuple[str, ...]) -> list[Path]:
    """In the cache: the marks of the make targets that were built (``all`` per baud)."""
    baud = next((t.split("=", 1)[1] for t in targets if t.startswith("BAUD=")), "115200")
    return [build_dir() / f".made-{t}-{baud}" if t == "all" else build_dir() / f".made-{t}"
            for t in targets if "=" not in t]


def is_built(*targets: str) -> bool:
    """True when ``make targets`` has nothing to do for certain: the installed sources
    were built into the cache before (a checkout asks make, which knows the times)."""
    return _cached() and all(p.is_file() for p in _stamps(targets))


def _make(*targets: str) -> None:
    if is_built(*targets):  # the cache is keyed by the sources: nothing can be stale
        return
    problem = toolchain_problem()
    if problem:
        raise SimavrError(f"cannot build the firmware: {problem}")
    fw, out = firmware_dir(), build_dir()
    out.mkdir(parents=True, exist_ok=True)
    with open(out / ".lock", "w") as lock:  # one make at a time (test workers)
        fcntl.flock(lock, fcntl.LOCK_EX)
        where = [f"BUILD={out}"] if _cached() else []  # a checkout: its Makefile's build/
        res = subprocess.run(["make", "-C", str(fw), *where, *targets],
                             capture_output=True, text=True, check=False)
        if res.returncode == 0 and _cached():
            for stamp in _stamps(targets):
                stamp.touch()
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


def first_build(baud: int | None = 115200) -> bool:
    """True when :func:`build` (``baud``) or :func:`build_harness` (None) has to compile
    from nothing, which takes a while (a checkout's make may still refresh a file)."""
    targets = ("sim",) if baud is None else (f"BAUD={baud}", "all", "sim")
    if is_built(*targets):
        return False
    outputs = [harness_path()] if baud is None else [harness_path(), elf_path(baud)]
    return _cached() or not all(p.is_file() for p in outputs)


def build_harness() -> Path:
    """``make -C firmware sim``: the harness alone (for a firmware ELF built elsewhere)."""
    _make("sim")
    return harness_path()


def symbol_address(elf: str | Path, name: str) -> int:
    """A symbol's address in the chip's data (or program) space (avr-nm)."""
    out = subprocess.run(["avr-nm", str(elf)], capture_output=True, text=True,
                         check=True).stdout
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[2] == name:
            return int(parts[0], 16) & 0xFFFF
    raise SimavrError(f"{elf} has no symbol {name}")


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

    cycles: dict[int, array[int]] = field(default_factory=dict)
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

    def edges(self, pin: int) -> tuple[array[int], bytearray]:
        """Edges of ``pin`` in device ticks (cycles since timer 1 started)."""
        base = self.timer1_start
        return (array("q", (c - base for c in self.cycles.get(pin, ()))),
                self.levels.get(pin, bytearray()))

    def rising(self, pin: int) -> list[int]:
        times, levels = self.edges(pin)
        return [t for t, lv in zip(times, levels, strict=True) if lv]

    def recorder(self) -> EdgeRecorder:
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
    rx_waiting: int  # bytes from the host not yet taken by the chip's UART


# ---------------------------------------------------------------------- lockstep
def library_path() -> Path:
    return build_dir() / "libfassimavr.so"


class _Chip:
    """The harness library (libfassimavr.so) in this process: one chip at a time."""

    _lib: ctypes.CDLL | None = None
    _lib_path = ""  # the library _lib was loaded from
    _open = False

    def __init__(self, lib_path: Path, elf: Path, trace: Path, boot_count: int,
                 world: bool = True) -> None:
        if _Chip._open:
            raise SimavrError("one simulated chip per process at a time")
        lib = _Chip._lib
        if lib is None or _Chip._lib_path != str(lib_path):
            lib = ctypes.CDLL(str(lib_path))
            u8p, u32p, u64p = (ctypes.POINTER(ctypes.c_uint8), ctypes.POINTER(ctypes.c_uint32),
                               ctypes.POINTER(ctypes.c_uint64))
            lib.fs_open.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_char_p,
                                    ctypes.c_uint32, ctypes.c_uint16, ctypes.c_int]
            lib.fs_input.argtypes = [ctypes.c_int, ctypes.c_uint32, ctypes.c_int]
            lib.fs_run.argtypes = [ctypes.c_uint64, ctypes.c_char_p, ctypes.c_uint32, u8p,
                                   ctypes.c_uint32, u32p, u64p]
            lib.fs_pins.argtypes = [u8p, u32p, u32p]
            lib.fs_info.argtypes = [u64p]
            lib.fs_mem.argtypes = [ctypes.c_uint16, ctypes.c_uint16, u8p, ctypes.c_int]
            _Chip._lib = lib
            _Chip._lib_path = str(lib_path)
        self.lib = lib
        if lib.fs_open(str(elf).encode(), str(trace).encode(), b"atmega328p", CPU_HZ,
                       boot_count & 0xFFFF, int(world)) != 0:
            raise SimavrError(f"simavr cannot load {elf}")
        _Chip._open = True
        self._out = (ctypes.c_uint8 * 65536)()
        self._out_n = ctypes.c_uint32()
        self._state = (ctypes.c_uint64 * 2)()

    def run(self, cycle: int, data: bytes) -> tuple[bytes, int, int]:
        if self.lib.fs_run(cycle, data, len(data), self._out, len(self._out),
                           ctypes.byref(self._out_n), self._state) != 0:
            raise SimavrError("the simulated chip stopped (see the messages above)")
        return bytes(self._out[:self._out_n.value]), self._state[0], self._state[1]

    def pins(self) -> list[PinCount]:
        level = (ctypes.c_uint8 * PINS)()
        rising, falling = (ctypes.c_uint32 * PINS)(), (ctypes.c_uint32 * PINS)()
        self.lib.fs_pins(level, rising, falling)
        return [PinCount(level[i], rising[i], falling[i]) for i in range(PINS)]

    def info(self) -> HarnessInfo:
        v = (ctypes.c_uint64 * 8)()
        self.lib.fs_info(v)
        return HarnessInfo(*v)

    def mem(self, addr: int, n: int, data: bytes | None = None) -> bytes:
        buf = (ctypes.c_uint8 * max(n, 1))()
        if data is not None:
            ctypes.memmove(buf, data, n)
        if self.lib.fs_mem(addr, n, buf, int(data is not None)) != 0:
            raise SimavrError(f"memory access {addr:#x}+{n} outside the chip's RAM")
        return bytes(buf[:n])

    def input(self, pin: int, value: int, analog: bool) -> None:
        if self.lib.fs_input(pin, value, int(analog)) != 0:
            raise SimavrError(f"the board has no input {'A' if analog else 'pin '}{pin}")

    def flush_trace(self) -> None:
        self.lib.fs_flush_trace()

    def close(self) -> None:
        if _Chip._open:
            self.lib.fs_close()
            _Chip._open = False


class SimavrDevice:
    """The firmware in simavr as a virtual-clock peer (see the module text).

    Bytes the host wrote reach the chip's UART at the instant the clock has when they
    are read; bytes the chip sends are handed to the line once their last bit has
    left (10 bits a character at the chip's baud setting).  The chip runs in this
    process (the harness as a library), one at a time.  ``world=False``: the harness
    does not mark the chip as simulated (a board: the firmware refuses SetInput).
    """

    def __init__(self, stream: ByteStream | None = None, clock: VirtualClock | None = None, *,
                 elf: str | Path | None = None, baud: int = 115200,
                 trace: str | Path | None = None, boot_count: int | None = None,
                 world: bool = True) -> None:
        if elf is None or not library_path().exists():
            built = build(baud)
            elf = elf or built.elf
        self.elf = Path(elf)
        self.clock = clock
        self.default_watchdog_ms = DEFAULT_WATCHDOG_MS
        self._tmpdir: str | None = None
        if trace is None:
            self._tmpdir = tempfile.mkdtemp(prefix="fas-simavr-")
            trace = os.path.join(self._tmpdir, "trace.txt")
        self.trace_path = Path(trace)
        if boot_count is None:
            boot_count = random.getrandbits(16)
        self.chip = _Chip(library_path(), self.elf, self.trace_path, boot_count, world)
        self.cycle = 0
        self._inputs: list[tuple[int, int, int, int, bool]] = []  # (cycle, n, pin, value, analog)
        self._input_count = 0
        self._next_tx_cycle = 0
        self._quantum_ns = QUANTUM_NS
        self._out = bytearray()  # bytes for the line ...
        self._partial = bytearray()  # ... and the start of a frame not yet complete
        self.stream: ByteStream | None = None
        self.in_wires: list[Wire] = []
        self.closed = False
        self.rx_log: list[tuple[int, bytes]] = []  # (cycle, bytes) the chip received
        self.attach(stream)

    # ------------------------------------------------------------ the chip
    def run_to_cycle(self, cycle: int, data: bytes = b"") -> bytes:
        """Hand ``data`` to the UART now, run to ``cycle``; the bytes sent meanwhile.
        Inputs scheduled meanwhile change at their cycles."""
        if self.closed:
            raise SimavrError("the simulated chip is closed")
        sent = b""
        while self._inputs and self._inputs[0][0] <= cycle:
            at, _n, pin, value, analog = self._inputs.pop(0)
            if at > self.cycle:
                part, self.cycle, self._next_tx_cycle = self.chip.run(at, data)
                sent += part
                data = b""
            self.chip.input(pin, value, analog)
        part, self.cycle, self._next_tx_cycle = self.chip.run(max(cycle, self.cycle), data)
        return sent + part

    @property
    def tick(self) -> int:
        """The chip's tick counter now (cycles since timer 1 started)."""
        return self.cycle - self.info().timer1_start

    # ------------------------------------------------------------ the world
    def set_input(self, pin: int, value: int, analog: bool | None = None) -> None:
        """The world outside the board, now: a switch holds ``pin`` at level ``value``
        (0/1) or a pot turns analog pin ``pin`` (A0-A7: 14-21) to ``value`` (0..1023).
        ``analog`` None: a value above 1 is a pot."""
        self.chip.input(pin, value, value > 1 if analog is None else analog)

    def schedule_input(self, tick: int, pin: int, value: int,
                       analog: bool | None = None) -> None:
        """``set_input`` at device tick ``tick`` (a switch that closes at a known time)."""
        cycle = tick + self.info().timer1_start
        if cycle <= self.cycle:  # the chip is there already
            self.set_input(pin, value, analog)
            return
        self._input_count += 1
        bisect.insort(self._inputs, (cycle, self._input_count, pin, value,
                                     value > 1 if analog is None else analog))

    def _sent(self, data: bytes) -> None:
        """Bytes the chip sent: the line gets them when a frame is complete (its sync
        byte): a host acts on whole frames only, and fewer, larger writes cost less."""
        if not data:
            return
        self._partial += data
        end = self._partial.rfind(SYNC) + 1
        if end:
            self._out += self._partial[:end]
            del self._partial[:end]

    def pins(self) -> list[PinCount]:
        return self.chip.pins()

    def info(self) -> HarnessInfo:
        return self.chip.info()

    def read_memory(self, addr: int, n: int) -> bytes:
        return self.chip.mem(addr, n)

    def write_memory(self, addr: int, data: bytes) -> None:
        self.chip.mem(addr, len(data), data)

    def stack_used(self) -> int:
        """The deepest the chip's stack went so far, in bytes: the firmware paints the
        RAM between its static data (``_end``) and the top (RAMEND) at reset."""
        end = symbol_address(self.elf, "_end")
        top = RAMEND_328P
        ram = self.read_memory(end, top + 1 - end)
        untouched = 0
        while untouched < len(ram) and ram[untouched] == STACK_PAINT:
            untouched += 1
        return len(ram) - untouched

    def rx_overruns(self) -> int:
        """Bytes the firmware's receive path lost (its ring full, or the UART's)."""
        addr = symbol_address(self.elf, "uart_rx_overruns")
        return int.from_bytes(self.read_memory(addr, 2), "little")

    def trace(self) -> Trace:
        """The pin changes so far."""
        if not self.closed:
            self.chip.flush_trace()
            tr = Trace.read(self.trace_path)
            tr.timer1_start = self.info().timer1_start
            tr.end_cycle = self.cycle
            return tr
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
        if data:
            self.rx_log.append((self.cycle, data))
        self._sent(self.run_to_cycle(self.cycle, data))
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
        self._sent(sent)
        if sent:
            self._quantum_ns = QUANTUM_NS
        else:  # quiet: look less often
            self._quantum_ns = min(self._quantum_ns * 2, QUANTUM_MAX_NS)

    def next_ns(self) -> int | None:
        now = self.ns_at(self.cycle)
        nxt = now + self._quantum_ns
        if self._next_tx_cycle:
            nxt = min(nxt, self.ns_at(self._next_tx_cycle))
        if self._inputs:  # the chip's answer to an input change is looked at soon after
            nxt = min(nxt, self.ns_at(self._inputs[0][0]))
        return max(nxt, now + 1)

    def close(self) -> None:
        if not self.closed:
            self.chip.close()
            self.closed = True
        if self._tmpdir is not None:
            shutil.rmtree(self._tmpdir, ignore_errors=True)
            self._tmpdir = None


# --------------------------------------------------------------------- real time
class SimavrServer:
    """The harness on a new pty, in real time (``stepperdemo device --simavr``)."""

    def __init__(self, elf: str | Path, harness: str | Path, *, speed: float = 1.0,
                 link: str | None = None, trace: str | None = None) -> None:
        # --parent: the harness ends when this process is gone, even if it is killed
        # before the harness has looked (see fas_simavr.c's serve_pty)
        args = [str(harness), "--pty", "--speed", repr(float(speed)), "--parent",
                str(os.getpid())]
        if link:
            args += ["--link", link]
        if trace:
            args += ["--trace", trace]
        args.append(str(elf))
        self.proc = subprocess.Popen(args, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     text=True, bufsize=1)
        assert self.proc.stdout is not None
        first = self.proc.stdout.readline().strip()
        if not first.startswith("/"):
            self.proc.wait(timeout=10)
            raise SimavrError(f"the simavr harness did not start (exit code "
                              f"{self.proc.returncode})")
        self.path = first

    def set_input(self, pin: int, value: int, analog: bool = False) -> None:
        """The world sets an input of the simulated board (see :class:`SimavrDevice`)."""
        if self.proc.stdin is None or self.proc.poll() is not None:
            raise SimavrError("the simavr harness has ended")
        self.proc.stdin.write(f"{pin} {value}{' a' if analog else ''}\n")
        self.proc.stdin.flush()

    def stop(self) -> list[str]:
        """End the run; the harness's summary lines."""
        if self.proc.stdin is not None:
            self.proc.stdin.close()
            self.proc.stdin = None
        if self.proc.poll() is None:
            self.proc.terminate()
        out, _ = self.proc.communicate(timeout=30)
        return [line for line in out.splitlines() if line.strip()]

    def wait(self) -> int:
        return self.proc.wait()


# ----------------------------------------------------------------------- replay
def replay_on_python_device(rx_log: list[tuple[int, bytes]], timer1_start: int,
                            cycles_per_byte: int, end_tick: int,
                            arch: str = "atmega328p") -> Device:
    """The bytes the firmware received, at the ticks they reached its UART, fed to the
    Python device (:class:`fas.device.Device`, recording its pins): the same
    session on both, so their step edges can be compared.

    simavr hands a received byte to the UART one character time after it was queued
    (11 bit times in simavr 1.6, which counts a parity bit), and one character after
    the byte before it; the Python device takes each byte at that tick.
    """
    from ..serial.clock import VirtualClock
    from .device import Device

    dev = Device(None, arch, VirtualClock(), record=True)
    sim_cpb = cycles_per_byte * 11 // 10
    ready = 0
    for cycle, data in rx_log:
        for b in data:
            ready = max(cycle, ready) + sim_cpb
            tick = ready - timer1_start
            dev.advance(dev.ns_at(tick))
            for seq, payload in dev.decoder.feed(bytes((b,))):
                dev.session.on_frame(seq, payload)
            dev.board.out.clear()
    dev.advance(dev.ns_at(end_tick))
    return dev
