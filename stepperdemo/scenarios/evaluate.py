"""Pin-trace evaluation as FastAccelStepper's own simulator tests do it.

The conformance data counts pin activity from a trace of the chip's port registers:
per pin the L->H and H->L transitions, the longest and the summed HIGH phase, and
per stepper the position counted from step edges and the direction level.  The trace
only knows a pin's level once its port register has been written for the first time;
that first write sets the starting level and is not counted as a transition (so the
direction pin that setup() drives HIGH as the very first write of its port shows no
L->H).  :func:`pin_activity` applies the same rules to the simulated pins so that
like is compared with like.
"""

from __future__ import annotations

import bisect
import gzip
import statistics
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import pairwise
from pathlib import Path

from fas.arch import Profile
from fas.backend import Backend, PinRecording
from fas.codes import PIN_EXTERNAL_FLAG, PIN_UNDEFINED

from ..demo.build import demo_build

LETTERS = "ABCDEFGHIJKLMNOPQRSTUVWXYZ"  # stepper 1 = A ... (ESP32 has up to 14 in the demo)


@dataclass
class PinActivity:
    rises: int
    falls: int
    high_max_us: float
    high_total_us: float


@dataclass
class StepperPins:
    letter: str
    step: int
    direction: int
    enable: int


def stepper_pins(profile: Profile) -> list[StepperPins]:
    out = []
    for i, cfg in enumerate(demo_build(profile).steppers):
        out.append(StepperPins(LETTERS[i], cfg.step, cfg.direction, cfg.enable_low_active))
    return out


def _uncounted_first_edge(backend: Backend, pin: int) -> bool:
    """Was this pin's first write also the first write of its port, and an edge?"""
    ports = backend.profile.pin_ports
    pins = backend.pin_states
    port = ports.get(pin)
    if port is None or pins is None or pin not in pins.first_write:
        return False
    order, level = pins.first_write[pin]
    first_of_port = min((pins.first_write[p][0] for p, q in ports.items()
                         if q == port and p in pins.first_write), default=order)
    return order == first_of_port and level == 1


def _recording(backend: Backend) -> PinRecording:
    if backend.recorder is None:
        raise ValueError("the pins' edges need a backend created with record=True")
    return backend.recorder


def pin_activity(backend: Backend, pin: int) -> PinActivity:
    """Counts for one pin from the recorded edges (needs ``record=True``)."""
    times, levels = _recording(backend).pin_edges(pin)
    tps_us = backend.profile.ticks_per_us
    skip_first = _uncounted_first_edge(backend, pin)
    rises = falls = 0
    high_max = high_total = 0.0
    rise_at = None
    for i, (t, lv) in enumerate(zip(times, levels, strict=True)):
        if i == 0 and skip_first:
            continue  # the port's initialising write: sets the level, counts nothing
        if lv:
            rises += 1
            rise_at = t
        else:
            falls += 1
            if rise_at is not None:
                h = (t - rise_at) / tps_us
                high_total += h
                high_max = max(high_max, h)
            rise_at = None
    return PinActivity(rises, falls, high_max, high_total)


def rising_edges(times: Sequence[int], levels: bytes) -> Sequence[int]:
    """The times of the rising edges among a pin's edges (levels 0/1)."""
    half = len(levels) // 2
    if (len(levels) % 2 == 0 and levels[0::2] == b"\x01" * half
            and levels[1::2] == b"\x00" * half):
        return times[0::2]  # pulses, as a step pin has them
    return [t for t, lv in zip(times, levels, strict=True) if lv]


def position_from_pins(backend: Backend, step_pin: int, dir_pin: int,
                       high_counts_up: bool = True, since: int = 0) -> int:
    """Step edges counted up while the direction pin is at its counting-up level
    (HIGH unless ``high_counts_up`` is False), down otherwise.  Without a direction
    pin on the chip (none, or an external one) every step counts up.  A direction
    edge at the tick of a step counts before it.  ``since``: only steps from this
    tick on (the chip was restarted then)."""
    recording = _recording(backend)
    times, levels = recording.pin_edges(step_pin)
    rises = rising_edges(times, bytes(levels))
    if since:
        rises = rises[bisect.bisect_left(rises, since):]
    if dir_pin == PIN_UNDEFINED or dir_pin & PIN_EXTERNAL_FLAG:
        return len(rises)
    dtimes, dlevels = recording.pin_edges(dir_pin)
    up = 1 if high_counts_up else 0  # the direction level that counts up
    # steps before the first direction edge see the pin LOW
    before = bisect.bisect_left(rises, dtimes[0]) if len(dtimes) else len(rises)
    pos = before if up == 0 else -before
    for i in range(len(dtimes)):
        lo = bisect.bisect_left(rises, dtimes[i])
        hi = bisect.bisect_left(rises, dtimes[i + 1]) if i + 1 < len(dtimes) else len(rises)
        if hi > lo:
            pos += (hi - lo) if dlevels[i] == up else -(hi - lo)
    return pos


def step_times_us(backend: Backend, step_pin: int) -> list[float]:
    tps_us = backend.profile.ticks_per_us
    times, levels = _recording(backend).pin_edges(step_pin)
    return [t / tps_us for t, lv in zip(times, levels, strict=True) if lv]


def read_reference_steps(path: Path) -> list[float]:
    """One rising step edge per line: time in µs since reset, tab, direction level."""
    return read_reference_track(path)[0]


def read_reference_track(path: Path) -> tuple[list[float], list[int]]:
    """Times (µs) and direction levels of the reference's rising step edges."""
    opener = gzip.open if path.suffix == ".gz" else open
    times: list[float] = []
    dirs: list[int] = []
    with opener(path, "rt") as fh:
        for line in fh:
            parts = line.split()
            if parts:
                times.append(float(parts[0]))
                dirs.append(int(parts[1]) if len(parts) > 1 else 0)
    return times, dirs


@dataclass
class TimingComparison:
    steps_ours: int
    steps_ref: int
    median_abs_us: float
    max_abs_us: float
    worst_index: int
    duration_ours_us: float
    duration_ref_us: float
    offset_us: float  # subtracted from ours before comparing (0 unless aligned)
    first_dev_us: float = 0.0  # ours - reference at the first step, before any alignment

    @property
    def duration_ratio(self) -> float:
        if self.duration_ref_us <= 0:
            return 1.0
        return self.duration_ours_us / self.duration_ref_us


MOVE_GAP_US = 100_000.0  # a pause this long in the reference separates two moves


def move_starts(ref: list[float], dirs: list[int] | None = None) -> list[int]:
    """Indices of the first step of each move: after a pause of MOVE_GAP_US or more, or
    where the direction changes (a stepper stops before it reverses)."""
    return [0] + [i for i in range(1, len(ref))
                  if ref[i] - ref[i - 1] >= MOVE_GAP_US
                  or (dirs is not None and dirs[i] != dirs[i - 1])]


def compare_steps(ours: list[float], ref: list[float], align: str = "absolute",
                  ref_dirs: list[int] | None = None) -> TimingComparison:
    """Per-step time deviation between two lists of rising edges (µs).

    ``align``: "absolute" compares times as they are; "first_step" removes the offset of
    the first step; "each_move" removes each move's own start offset (moves are
    separated by pauses of at least MOVE_GAP_US or by a change of ``ref_dirs``).
    """
    n = min(len(ours), len(ref))
    offset = 0.0
    offsets = [0.0] * n
    if align == "first_step" and n:
        offset = ours[0] - ref[0]
        offsets = [offset] * n
    elif align == "each_move" and n:
        starts = [i for i in move_starts(ref, ref_dirs) if i < n] + [n]
        previous = 0.0
        for a, b in pairwise(starts):
            o = ours[a] - ref[a]
            offset = max(offset, abs(o - previous))  # this move's own start shift
            previous = o
            for i in range(a, b):
                offsets[i] = o
    devs = [abs(ours[i] - offsets[i] - ref[i]) for i in range(n)]
    worst = max(range(n), key=devs.__getitem__) if n else -1
    dur_o = ours[-1] - ours[0] if len(ours) > 1 else 0.0
    dur_r = ref[-1] - ref[0] if len(ref) > 1 else 0.0
    return TimingComparison(len(ours), len(ref), statistics.median(devs) if devs else 0.0,
                            max(devs) if devs else 0.0, worst, dur_o, dur_r, offset,
                            ours[0] - ref[0] if n else 0.0)


# --------------------------------------------------- `e`: the timer-wrap gaps
GAP_US = 4000.0  # a step interval this long is a missed compare: the timer wrapped
FAST_US = 2000.0  # ... when it comes between fast steps (not the slow start of a ramp)
WINDOW_PERIOD_US = 256_000.0  # `e` blocks while millis() & 0xff < 0x40: every 256 ms ...
WINDOW_SPAN_US = 72_000.0  # ... for 64 ms of millis() and the last block (+ margin)


def wrap_gaps(times: Sequence[float]) -> list[float]:
    """Start times (µs) of the ~4.1 ms gaps among rising step edges: an interval of
    ``GAP_US`` or more next to intervals shorter than ``FAST_US`` (a compare missed
    while interrupts were blocked; the 16-bit timer wrapped before it matched).  The
    interval that ends at the last step counts too: a run may end on a wrap."""
    out = []
    n = len(times)
    for i in range(1, n):
        if times[i] - times[i - 1] < GAP_US:
            continue
        j = i - 1  # the nearest intervals that are no gaps, on both sides
        while j >= 1 and times[j] - times[j - 1] >= GAP_US:
            j -= 1
        k = i + 1
        while k < n and times[k] - times[k - 1] >= GAP_US:
            k += 1
        before = times[j] - times[j - 1] if j >= 1 else None
        after = times[k] - times[k - 1] if k < n else None
        if (before is not None and before < FAST_US) or (after is not None and after < FAST_US):
            out.append(times[i - 1])
    return out


def gaps_per_window(gap_starts: Sequence[float]) -> dict[int, int]:
    """Gaps per window of `e` (window k: the 256 ms period k, from its start to
    ``WINDOW_SPAN_US`` after it), by window number; gaps outside windows are left out."""
    out: dict[int, int] = {}
    for g in gap_starts:
        k = int(g // WINDOW_PERIOD_US)
        if g - k * WINDOW_PERIOD_US < WINDOW_SPAN_US:
            out[k] = out.get(k, 0) + 1
    return out
