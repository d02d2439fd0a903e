"""The firmware's step generator alone (firmware/tests/stepgen_rig.c) against the Python
model of the same queue (:class:`fas.sim.channel.SimChannel`, the Python device's step
timer): both get the same entries and starts; their step edges are compared.

The rig firmware takes commands through a mailbox in its RAM, written and read by the
simavr harness in lockstep, so no protocol is involved.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field

from fas.device import simavr
from fas.queue import StepperQueue, i32
from fas.sim import SimBackend
from fas.sim.machine import PRIO_PLAIN
from fas.sim.pins import EdgeRecorder

ENTRY, START_AT, START_NOW, STOP, DIR_PIN, PIN, DETACH, PCNT, SNAPSHOT, BLOCK, HALT = range(1, 12)
LB_DOWN, LB_UP = 0x01, 0x02  # limit_block: a closed switch forbids that direction
STEP_PINS = (9, 10)
QE_TOGGLE_DIR, QE_DIR_LEVEL, QE_COUNT_UP = 0x10, 0x20, 0x40
PCNT_ON, PCNT_DIR_HIGH_UP = 0x01, 0x02


def build_rig() -> str:
    simavr._make("rig", "sim")
    return str(simavr.build_dir() / "stepgen_rig.elf")


@dataclass
class Snapshot:
    state: int
    rp: int
    steps: int
    pulses: int
    pulse_pos: int
    pcnt: int


class Rig:
    """The rig firmware in simavr (lockstep)."""

    def __init__(self, elf: str, trace: str) -> None:
        self.dev = simavr.SimavrDevice(elf=elf, trace=trace)
        self.addr = simavr.symbol_address(elf, "rig")
        self.seq = 0
        self.dev.run_to_cycle(20_000)  # boot
        self.t0 = self.dev.info().timer1_start

    def _write(self, offset: int, data: bytes) -> None:
        self.dev.write_memory(self.addr + offset, data)

    def _read(self, offset: int, n: int) -> bytes:
        return self.dev.read_memory(self.addr + offset, n)

    def command(self, cmd: int, ch: int = 0, arg: int = 0, arg2: int = 0, at: int = 0,
                entry: tuple[int, int, int] = (0, 0, 0), pcnt: tuple[int, int] = (0, 0)) -> None:
        """Run one command; the chip runs until it is done (a few microseconds)."""
        steps, flags, ticks = entry
        self._write(2, struct.pack("<BBBBIBBHhh", cmd, ch, arg, arg2, at & 0xFFFFFFFF, steps,
                                   flags, ticks, *pcnt))
        self.seq = (self.seq + 1) & 0xFF
        self._write(0, bytes((self.seq,)))
        for _ in range(1000):
            self.dev.run_to_cycle(self.dev.cycle + 400)
            if self._read(1, 1)[0] == self.seq:
                return
        raise AssertionError(f"rig command {cmd} not done")

    def tick(self) -> int:
        return self.dev.cycle - self.t0

    def run_to_tick(self, tick: int) -> None:
        self.dev.run_to_cycle(self.t0 + tick)

    def late(self) -> int:
        return self._read(18, 1)[0]

    def snapshot(self, ch: int) -> Snapshot:
        self.command(SNAPSHOT, ch)
        return Snapshot(*struct.unpack("<BBBIih", self._read(19, 13)))

    def hits(self) -> tuple[int, int, int, int]:
        """The limit stops the step generator made: (count, queue, up, tick of the
        last one)."""
        count, ch, up, tick = struct.unpack("<BBBI", self._read(32, 7))
        return count, ch, up, tick


@dataclass
class Model:
    """The Python device's step timer on the simulated machine, fed the same way."""

    backend: SimBackend = field(default_factory=lambda: SimBackend("atmega328p"))
    recorder: EdgeRecorder = field(default_factory=EdgeRecorder)
    queues: dict[int, StepperQueue] = field(default_factory=dict)

    def __post_init__(self) -> None:
        self.backend.machine.pins.sinks.append(self.recorder)
        for ch, pin in enumerate(STEP_PINS):
            self.queues[ch] = StepperQueue(ch, self.backend.profile, self.backend, pin)

    @property
    def machine(self):
        return self.backend.machine

    def run_to_tick(self, tick: int) -> None:
        self.machine.run_until(tick)

    def entry(self, ch: int, steps: int, ticks: int, flags: int) -> None:
        q = self.queues[ch]
        wp = q.next_write_idx
        e = q.entries[wp % q.queue_len]
        e.steps = e.total_steps = steps
        e.ticks = ticks
        e.count_up = bool(flags & QE_COUNT_UP)
        e.toggle_dir = bool(flags & QE_TOGGLE_DIR)
        e.dir_level = bool(flags & QE_DIR_LEVEL)
        e.end_pos = i32(q.queue_end_pos + (steps if e.count_up else -steps))
        q.queue_end_pos = e.end_pos
        q.next_write_idx = (wp + 1) & 0xFF

    def block(self, ch: int, bits: int) -> None:
        """A closed limit switch forbids these directions (LB_*): the queue stops
        before an entry towards it, as the Python device's entry guard does."""
        ch_ = self.queues[ch].channel
        if not bits:
            ch_.entry_guard = None
            return
        ch_.entry_guard = lambda e: bool(bits & (LB_UP if e.count_up else LB_DOWN))

    def start_at(self, ch: int, at: int) -> None:
        ch_ = self.queues[ch].channel
        if at <= self.machine.now:
            ch_.start()
        else:
            self.machine.schedule(at, ch_.start, PRIO_PLAIN)

    def rising(self, pin: int) -> list[int]:
        return self.recorder.rising(pin)


class Both:
    """Rig and model driven together, tick by tick."""

    def __init__(self, rig: Rig) -> None:
        self.rig = rig
        self.model = Model()
        self.model.run_to_tick(rig.tick())

    def sync(self) -> None:
        self.model.run_to_tick(self.rig.tick())

    def dir_pin(self, ch: int, pin: int, level: int = 0) -> None:
        self.rig.command(PIN, ch, pin, level)
        self.rig.command(DIR_PIN, ch, pin)
        self.sync()
        self.model.machine.pins.set(pin, level, self.model.machine.now)
        self.model.queues[ch].dir_pin = pin

    def entry(self, ch: int, steps: int, ticks: int, up: bool = True, toggle: bool = False,
              level: bool | None = None) -> None:
        level = up if level is None else level
        flags = (QE_COUNT_UP if up else 0) | (QE_TOGGLE_DIR if toggle else 0) \
            | (QE_DIR_LEVEL if level else 0)
        self.rig.command(ENTRY, ch, entry=(steps, flags, ticks))
        self.sync()
        self.model.entry(ch, steps, ticks, flags)

    def start_at(self, ch: int, at: int) -> None:
        self.rig.command(START_AT, ch, at=at)
        self.sync()
        self.model.start_at(ch, at)

    def block(self, ch: int, bits: int) -> None:
        self.rig.command(BLOCK, ch, bits)
        self.sync()
        self.model.block(ch, bits)

    def run_to_tick(self, tick: int) -> None:
        self.rig.run_to_tick(tick)
        self.model.run_to_tick(tick)
