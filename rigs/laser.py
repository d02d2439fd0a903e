"""Issue 25's laser through ``--port``: one run of the M4 program on a device, and how
each timed duty change the laser asks for shows on the device's PWM pin (the Uno's
pin 11).

A change asked for device tick ``at`` should show from the first PWM period that
begins after ``at`` (the compare registers are double-buffered), unless a later change
replaced it before then - whether the host sent it (OutputAt, OutputNext) or left it
out because a later one falls in the same period of the device (PwmGrid)."""

from __future__ import annotations

import bisect
from collections import Counter
from dataclasses import dataclass

from fas.device.loopback import Loopback
from rigs.gcode import SETUP
from stepperdemo.program import make_program

TPS = 16_000_000
LASER_PIN = 11  # Aout1 on the Uno: OC2A
PROGRAM = "M4 S1000\nG1 X40 F3000\nG0 X0\n"
LASER = ["$30=2000", "$32=1", "$141=1000"]  # full feed: 50 % duty; ~1 kHz PWM


def high_time(times: list[int], levels: bytes, a: int, b: int) -> int:
    """Ticks the pin is high within [a, b)."""
    k = bisect.bisect_right(times, a) - 1
    level = levels[k] if k >= 0 else 0
    t, total = a, 0
    k += 1
    while k < len(times) and times[k] < b:
        if level:
            total += times[k] - t
        t, level = times[k], levels[k]
        k += 1
    return total + (b - t if level else 0)


@dataclass
class LaserRun:
    out: str
    asked: list[tuple[int, int]]  # (device tick, duty count) of every change the laser made
    sent: list[tuple[int, int]]  # ... of those sent (OutputAt, OutputNext; not the replaced)
    times: list[int]  # the PWM pin's edges (device ticks) and levels
    levels: bytes
    counts: int
    period: int  # ticks
    counters: dict[str, int]
    grids: dict[int, tuple[int, int]]  # the device's PwmGrid reports: pin -> (origin, period)

    def shown(self, start: int) -> int:
        """The duty count the PWM period beginning at ``start`` shows."""
        return round(high_time(self.times, self.levels, start, start + self.period)
                     * self.counts / self.period)

    def checks(self) -> list[tuple[int, int, int, int]]:
        """(at, value, first period's start, periods late) of every change the laser
        asked for that a later one does not replace before its first period (late: -1
        if it never shows within 40 periods) - whether the host sent it or not."""
        per = self.period
        rises = [t for t, v in zip(self.times, self.levels, strict=True) if v]
        origin = Counter(t % per for t in rises).most_common(1)[0][0]  # the periods' grid
        out = []
        for i, (at, value) in enumerate(self.asked):
            first = at - (at - origin) % per + per  # the first period beginning after at
            if i + 1 < len(self.asked) and self.asked[i + 1][0] < first:
                continue  # replaced before it could show
            late = next((k for k in range(40) if self.shown(first + k * per) == value), -1)
            out.append((at, value, first, late))
        return out


def run(device: str, baud: int = 115200) -> LaserRun:
    """The laser program through ``--port`` on the Python device or our firmware."""
    with Loopback(device=device, record=device == "python", baud=baud) as lb:
        backend = lb.backend
        assert backend is not None
        asked: list[tuple[int, int]] = []
        sent: list[tuple[int, int]] = []
        timed = backend.outputs.timed
        timed_output = backend.timed_output

        def ask(change, tick):  # type: ignore[no-untyped-def]
            asked.append((backend.sync.device_tick32(tick) & 0xFFFFFFFF, change.value))
            return timed_output(change, tick)

        def spy(change, device_tick):  # type: ignore[no-untyped-def]
            sent.append((device_tick & 0xFFFFFFFF, change.value))  # (OutputAt or OutputNext)
            return timed(change, device_tick)

        backend.outputs.timed = spy  # type: ignore[method-assign]
        backend.timed_output = ask  # type: ignore[method-assign]
        app = make_program("gcode", backend, scripted=True, axes=2,
                           setup_lines=SETUP + LASER)
        app.run_script(PROGRAM, max_ticks=30 * TPS)
        assert backend.settle()
        setting = app.machine.engine.outputs.frequency_setting(1)
        if device == "python":
            times, levels = lb.device.recorder.pin_edges(LASER_PIN)
        else:
            times, levels = lb.device.trace().edges(LASER_PIN)
        return LaserRun(app.transcript.decode(), asked, sent, list(times), bytes(levels),
                        setting.counts, setting.clock_div * setting.counts,
                        backend.device_counters(), dict(backend.pwm_grids))
