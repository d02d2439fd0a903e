"""What the pins show: per-stepper motion figures from the time-ordered edge stream.

A consumer of :class:`fas.sim.trace.EdgeStream`.  Every figure is computed as the
edges go by, so memory does not grow with the length of a run: step periods go into
a histogram (exact median), position/speed samples for plots are thinned out as they
grow, and CSV rows are written at once.

The planned timing comes from the simulated channels: each time a channel takes up
a queue entry it reports ``(kind, index of its first pulse, ticks, steps)``.  The
interval from one pulse to the next is planned as the entry's ``ticks`` inside an
entry, and as the previous entry's trailing ``ticks`` plus any pauses between two
entries.  The difference between the actual and the planned interval is the
*deviation*: timer-wrap gaps under StepperDemo's ``e`` show up as large positive
deviations, a clean run has none.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import IO

from fas.arch import Profile
from fas.codes import PIN_UNDEFINED
from fas.sim.channel import ENTRY_RESTART, ENTRY_START, SimChannel
from fas.sim.trace import IRQ_BLOCKED

from ..demo.build import DemoStepper, demo_build
from .ramp_rates import phase_rates
from .thinning import PlotSamples

GAP_FACTOR = 4  # an interval longer than this many times the last regular one is a gap
ACC_WINDOWS_PER_S = 100  # acceleration: speed change between windows of >= 10 ms
SHORT_MOTION_WINDOWS = 3  # a motion shorter than this many windows: .ramp_rates instead
PLOT_POINTS = 4000  # samples kept per stepper for plots (.thinning: per time bucket)
CSV_HEADER = "time_us,stepper,direction,position,tick\n"


@dataclass(frozen=True)
class Wiring:
    """The pins of one StepperDemo stepper as a logic analyser would name them."""

    number: int  # 1-based, as M1, M2 ...
    label: str  # "A", "B" ...
    step: int
    direction: int | None
    enable_low: int | None
    enable_high: int | None
    high_counts_up: bool

    @classmethod
    def from_demo(cls, index: int, cfg: DemoStepper) -> Wiring:
        def pin(p: int) -> int | None:
            return None if p == PIN_UNDEFINED else p

        return cls(index + 1, chr(ord("A") + index), cfg.step, pin(cfg.direction),
                   pin(cfg.enable_low_active), pin(cfg.enable_high_active),
                   cfg.direction_high_counts_up)


def demo_wiring(profile: Profile) -> list[Wiring]:
    return [Wiring.from_demo(i, cfg) for i, cfg in enumerate(demo_build(profile).steppers)]


def shared_step_pins(wiring: Sequence[Wiring]) -> set[int]:
    """Step pins that are another stepper's direction or enable pin too (StepperDemo on
    an ESP32 wires M12's step pin 26 as the enable pin of M1, M7 and M13): a rise
    there is a step only when the stepper's channel has a pulse planned for it."""
    roles = {p for w in wiring for p in (w.direction, w.enable_low, w.enable_high)
             if p is not None}
    return {w.step for w in wiring} & roles


class ChannelCounts:
    """A channel's counts at the moment a recording ended: the report of a finished
    recording does not count what the channel did afterwards."""

    entry_listeners = ()  # nothing listens any more

    def __init__(self, channel) -> None:
        self.pulses = channel.pulses
        self.dry = channel.dry
        self.missed_compares = channel.missed_compares
        self.starts = channel.starts
        if hasattr(channel, "lost_periods"):  # QuickStep
            self.lost_periods = channel.lost_periods
            self.clock = channel.clock


class StepperMotion:
    """Figures of one stepper, fed edge by edge in global time order."""

    def __init__(self, wiring: Wiring, ticks_per_s: int, levels: dict[int, int],
                 position: int = 0, csv: IO[str] | None = None,
                 clock: Callable[[], int] | None = None) -> None:
        """``clock``: the simulated time, for a stepper whose step pin is shared (when
        a queue entry was taken up: no pulse of it comes earlier)."""
        self.wiring = wiring
        self.clock = clock
        self.tps = ticks_per_s
        self.levels = levels  # shared pin levels of the stream (dir/enable lookups)
        self.csv = csv
        self.start_position = self.position = position
        self.channel: SimChannel | None = None
        self.base = {"pulses": 0, "dry": 0, "missed_compares": 0, "starts": 0}
        # earlier channels of the same step pin (a planner switch): their counts so far
        self.others: list[tuple[SimChannel, dict[str, int]]] = []
        # plan of the channel: (kind, first pulse index, ticks, steps), consumed in order
        self.plan: deque[tuple[int, int, int, int]] = deque()
        self.index = 0  # channel pulse index of the next rising edge
        self.cur_ticks: int | None = None
        self.pulses = 0
        self.last_rise: int | None = None
        self.first_rise: int | None = None
        self.last_interval: int | None = None
        self.new_motion = True
        self.motions = 0
        self.restarts = 0
        self.periods: dict[int, int] = {}
        self.period_min: int | None = None
        self.period_max: int | None = None
        self.high_min: int | None = None
        self.high_max: int | None = None
        self.gaps = 0
        self.gap_max = 0
        self.dev_compared = 0
        self.dev_late = 0
        self.dev_early = 0
        self.dev_max_late = 0
        self.dev_max_early = 0
        self.acc_max: float | None = None  # None: nothing to measure it from
        self.dec_max: float | None = None
        self._win_ticks = max(1, ticks_per_s // ACC_WINDOWS_PER_S)
        # the rising edges of the motion under way while it is short (None: it is not),
        # and what its windows found meanwhile (used only if it turns out long)
        self._short: list[int] | None = None
        self._short_rates: tuple[float | None, float | None] = (None, None)
        self._win: list[int] | None = None  # [start tick, intervals, sign]
        self._prev_win: tuple[float, float] | None = None  # (signed speed, mid tick)
        self.dir_changes = 0
        self.dir_to_step_min: int | None = None
        self._dir_edge: int | None = None
        self.enables = 0
        self.enable_to_step: list[int] = []  # one per driver activation followed by a step
        self._enable_edge: int | None = None
        self.steps_disabled = 0
        # (tick, position, speed steps/s) for plots, thinned per time bucket keeping
        # the extremes of the speed and the ends of every standstill
        self.plot = PlotSamples(PLOT_POINTS, key=2)
        self.entry_steps: dict[int, int] = {}  # planned period -> steps (QuickStep plateaus)
        self.entries_taken = 0
        # channel pulse index after the last pulse of the entries taken up by the time
        # of the edge at hand (None: not known, the channel ran when bound): on a step
        # pin shared with another role a rise beyond it is not a step.  The entries
        # taken up later than that edge wait in pending_ends: (tick, end).
        self.planned_end: int | None = 0
        self.pending_ends: deque[tuple[int, int]] = deque()
        self._in_pulse = False

    # --------------------------------------------------------------- channel
    def bind(self, channel: SimChannel) -> None:
        if self.channel is not None:  # another channel drives the pin from now on
            self.others.append((self.channel, self.base))
            self.index = channel.pulses + (self.index - self.channel.pulses)
        else:
            self.index = channel.pulses
        self.planned_end = None if channel.is_running() else self.index
        self.channel = channel
        self.base = {"pulses": channel.pulses, "dry": channel.dry,
                     "missed_compares": channel.missed_compares, "starts": channel.starts}
        channel.entry_listeners.append(self.entry)

    def resume(self, channel: SimChannel | None, base: dict[str, int],
               others: list[tuple[SimChannel, dict[str, int]]], index: int,
               cur_ticks: int | None,
               entries: Sequence[tuple[int, int, int, int]] = (),
               planned_end: int | None = None,
               pending_ends: Sequence[tuple[int, int]] = ()) -> None:
        """Continue where an earlier part of the run left off (a replay from the head
        of a bounded recording): the channel and its counts at that point, the pulse
        index of the next rising edge, the period in force, the entries taken up
        from there on and where the pulses planned so far end - without listening to
        the channel."""
        self.channel = channel
        self.base = base
        self.others = others
        self.index = index
        self.cur_ticks = cur_ticks
        for e in entries:
            self.entry(*e)
        self.planned_end = planned_end  # (what the entries said, as of the head)
        self.pending_ends = deque(pending_ends)

    def unbind(self) -> None:
        for ch in [self.channel] + [c for c, _ in self.others]:
            if ch is not None and self.entry in ch.entry_listeners:
                ch.entry_listeners.remove(self.entry)

    def entry(self, kind: int, index: int, ticks: int, steps: int) -> None:
        self.plan.append((kind, index, ticks, steps))
        if self.clock is not None:  # a shared step pin: this entry's pulses come later
            self.pending_ends.append((self.clock(), index + steps))
        elif self.planned_end is None or index + steps > self.planned_end:
            self.planned_end = index + steps
        if steps:
            self.entry_steps[ticks] = self.entry_steps.get(ticks, 0) + steps
            self.entries_taken += 1

    def channel_count(self, name: str) -> int:
        if self.channel is None:
            return 0
        total = getattr(self.channel, name) - self.base[name]
        for ch, base in self.others:
            total += getattr(ch, name) - base[name]
        return total

    # ----------------------------------------------------------------- pins
    def direction_up(self) -> bool:
        w = self.wiring
        if w.direction is None:
            return True
        return (self.levels.get(w.direction, 0) == 1) == w.high_counts_up

    def enabled(self) -> bool:
        w = self.wiring
        ok = True
        if w.enable_low is not None:
            ok = self.levels.get(w.enable_low, 0) == 0
        if w.enable_high is not None:
            ok = ok and self.levels.get(w.enable_high, 0) == 1
        return ok

    def dir_edge(self, t: int) -> None:
        self.dir_changes += 1
        self._dir_edge = t

    def enable_edge(self, t: int, was_enabled: bool) -> None:
        if not was_enabled and self.enabled():
            self.enables += 1
            self._enable_edge = t

    def shared_edge(self, t: int, level: int) -> bool:
        """An edge on a step pin that also serves another role: is it this stepper's
        (a rise the channel has a pulse planned for, or the fall after it)?  If so it
        is taken; False: it is the other role's."""
        if level:
            pending = self.pending_ends
            while pending and pending[0][0] <= t:
                end = pending.popleft()[1]
                if self.planned_end is None or end > self.planned_end:
                    self.planned_end = end
            end = self.planned_end
            if end is not None and self.index >= end:
                return False
            self._in_pulse = True
        elif not self._in_pulse:
            return False
        else:
            self._in_pulse = False
        self.step_run((t,), bytes((level,)))
        return True

    def step_run(self, times: Sequence[int], levels: bytes) -> None:
        rise = self._rise
        last = self.last_rise
        for t, lv in zip(times, levels, strict=True):
            if lv:
                rise(t)
                last = t
            elif last is not None:
                high = t - last
                if self.high_min is None or high < self.high_min:
                    self.high_min = high
                if self.high_max is None or high > self.high_max:
                    self.high_max = high

    # ---------------------------------------------------------------- steps
    def _planned(self, k: int) -> int | None:
        """Planned interval before pulse ``k``; consumes the entries taken up before it."""
        plan = self.plan
        if not plan or plan[0][1] > k:
            return self.cur_ticks
        acc = self.cur_ticks
        planned: int | None = None
        stepping = False
        while plan and plan[0][1] <= k:
            kind, _, ticks, steps = plan.popleft()
            if kind == ENTRY_START:
                self.new_motion = True
                acc = None
            elif kind == ENTRY_RESTART:
                self.restarts += 1
            if steps == 0:
                if acc is not None:
                    acc += ticks
            else:
                stepping = True
                planned = acc
                self.cur_ticks = acc = ticks
        return planned if stepping else acc

    def _rise(self, t: int) -> None:
        planned = self._planned(self.index)
        self.index += 1
        up = self.direction_up()
        self.position += 1 if up else -1
        self.pulses += 1
        if self.first_rise is None:
            self.first_rise = t
        prev = self.last_rise
        speed = 0.0
        if prev is None or self.new_motion:
            before = self.position - (1 if up else -1)
            if prev is not None:  # the last motion ended at its last pulse
                self.plot.add((prev, before, 0.0))
            self.plot.add((t, before, 0.0))  # standing at the old position until now
            self.motions += 1
            self._close_window(prev)
            self._end_motion()
            self._short = [t]
            self._prev_win = None
            self.last_interval = None
        else:
            interval = t - prev
            self._period(interval)
            ref = self.last_interval
            short = self._short
            if short is not None:
                if t - short[0] < SHORT_MOTION_WINDOWS * self._win_ticks:
                    short.append(t)
                else:
                    self._long_motion()
            if ref is not None and interval > GAP_FACTOR * ref:
                self.gaps += 1
                self.gap_max = max(self.gap_max, interval)
                self._win = None
                self._prev_win = None
                self._long_motion()  # (the windows' figures, not a slope across the gap)
            else:
                self._window(prev, t, 1 if up else -1)
                self.last_interval = interval
            if planned is not None:
                self._deviation(interval - planned)
            if interval:  # 0: two edges in one tick (a pin shared with another role)
                speed = self.tps / interval if up else -self.tps / interval
        self.new_motion = False
        self.last_rise = t
        if self._dir_edge is not None:
            d = t - self._dir_edge
            if self.dir_to_step_min is None or d < self.dir_to_step_min:
                self.dir_to_step_min = d
            self._dir_edge = None
        if self._enable_edge is not None:
            self.enable_to_step.append(t - self._enable_edge)
            self._enable_edge = None
        if not self.enabled():
            self.steps_disabled += 1
        self.plot.add((t, self.position, speed))
        if self.csv is not None:
            self.csv.write(f"{t * 1_000_000 / self.tps:.4f},{self.wiring.number},"
                           f"{1 if up else -1},{self.position},{t}\n")

    def _period(self, interval: int) -> None:
        if not interval:  # two rises in one tick: a pin shared with another role
            return
        self.periods[interval] = self.periods.get(interval, 0) + 1
        if self.period_min is None or interval < self.period_min:
            self.period_min = interval
        if self.period_max is None or interval > self.period_max:
            self.period_max = interval

    def _deviation(self, dev: int) -> None:
        self.dev_compared += 1
        if dev > 0:
            self.dev_late += 1
            self.dev_max_late = max(self.dev_max_late, dev)
        elif dev < 0:
            self.dev_early += 1
            self.dev_max_early = max(self.dev_max_early, -dev)

    # ---------------------------------------------- acceleration from periods
    def _window(self, start: int, end: int, sign: int) -> None:
        """Mean speeds over windows of >= 10 ms of steps; acceleration is the change of
        mean speed between window middles (exact for a constant acceleration, and
        blind to the tick rounding of single commands)."""
        win = self._win
        if win is not None and win[2] != sign:
            self._close_window(start)
            win = None
        if win is None:
            win = self._win = [start, 0, sign]
        win[1] += 1
        if end - win[0] >= self._win_ticks:
            self._close_window(end)

    def _close_window(self, end: int | None) -> None:
        win = self._win
        self._win = None
        if win is None or end is None or end <= win[0] or not win[1]:
            return
        speed = win[2] * win[1] * self.tps / (end - win[0])
        mid = (win[0] + end) / 2
        prev = self._prev_win
        self._prev_win = (speed, mid)
        if prev is None:
            return
        dt = (mid - prev[1]) / self.tps
        if not dt:
            return
        if speed * prev[0] < 0:  # a reversal counts as deceleration
            acc = -abs(speed - prev[0]) / dt
        else:
            acc = (abs(speed) - abs(prev[0])) / dt
        if self._short is not None:  # held until the motion is known to be long
            a, d = self._short_rates
            self._short_rates = ((max(a or 0.0, acc) if acc > 0 else a),
                                 (max(d or 0.0, -acc) if acc < 0 else d))
        else:
            self._rates(acc if acc > 0 else None, -acc if acc < 0 else None)

    def _rates(self, acc: float | None, dec: float | None) -> None:
        if acc is not None and (self.acc_max is None or acc > self.acc_max):
            self.acc_max = acc
        if dec is not None and (self.dec_max is None or dec > self.dec_max):
            self.dec_max = dec

    def _long_motion(self) -> None:
        """The motion under way is not short (or has a gap): its windows count."""
        if self._short is not None:
            self._short = None
            self._rates(*self._short_rates)
            self._short_rates = (None, None)

    def _end_motion(self) -> None:
        """A motion ended: a short one is measured by its step times (.ramp_rates)."""
        if self._short is not None:
            self._rates(*phase_rates(self._short, self.tps))
            self._short = None
            self._short_rates = (None, None)

    # ------------------------------------------------------------ plot data
    @property
    def samples(self) -> list[tuple[int, int, float]]:
        """The plot samples (tick, position, speed in steps/s), in time order."""
        return self.plot.samples()

    def finish(self, end_tick: int) -> None:
        self._close_window(self.last_rise)
        self._end_motion()
        if self.last_rise is not None:  # the last motion ends at its last pulse
            self.plot.add((self.last_rise, self.position, 0.0))
        self.unbind()
        if self.channel is not None and not isinstance(self.channel, ChannelCounts):
            self.channel = ChannelCounts(self.channel)
            self.others = [(ChannelCounts(c), base) for c, base in self.others]

    # -------------------------------------------------------------- figures
    def period_median(self) -> int | None:
        total = sum(self.periods.values())
        if not total:
            return None
        half = (total + 1) // 2
        seen = 0
        for period in sorted(self.periods):
            seen += self.periods[period]
            if seen >= half:
                return period
        return None  # pragma: no cover


class MotionAnalysis:
    """Consumer of the ordered edge stream for all StepperDemo steppers of a backend."""

    def __init__(self, backend, wiring: Sequence[Wiring], *,
                 positions: Sequence[int] | None = None, csv: IO[str] | None = None,
                 initial: dict[int, int] | None = None, live: bool = True) -> None:
        """``live``: bind to the backend's channels now and to those made later (a
        recording as it happens); False for a replay of recorded edges, whose steppers
        are then set up with :meth:`StepperMotion.resume` (``stepperdemo.watch.recent``).
        """
        self.backend = backend
        self.tps = backend.profile.ticks_per_s
        self.levels: dict[int, int] = dict(initial or {})
        self.csv = csv
        if csv is not None:
            csv.write(CSV_HEADER)
        # step pins that are another stepper's direction or enable pin too: their edges
        # are sorted by the plans of the channels
        self._shared = shared_step_pins(wiring)
        clock = backend.now if live else None
        self.steppers = [
            StepperMotion(w, self.tps, self.levels,
                          positions[i] if positions is not None and i < len(positions)
                          and positions[i] is not None else 0, csv,
                          clock if w.step in self._shared else None)
            for i, w in enumerate(wiring)]
        self._by_step = {m.wiring.step: m for m in self.steppers}
        self._by_dir: dict[int, list[StepperMotion]] = {}
        self._by_enable: dict[int, list[StepperMotion]] = {}
        for m in self.steppers:
            w = m.wiring
            if w.direction is not None:
                self._by_dir.setdefault(w.direction, []).append(m)
            for pin in (w.enable_low, w.enable_high):
                if pin is not None:
                    self._by_enable.setdefault(pin, []).append(m)
        self.irq_windows = 0
        self.irq_ticks = 0
        self._irq_rise: int | None = None
        self.stray_base = (backend.stray_reads, backend.stray_reads_during_pulse)
        if live:
            for ch in backend.channels:
                self._bind(ch)
            backend.channel_listeners.append(self._bind)

    def _bind(self, channel: SimChannel) -> None:
        m = self._by_step.get(channel.step_pin)
        if m is not None and channel is not m.channel:
            m.bind(channel)

    # ----------------------------------------------------- OrderedEdgeSink
    def edge_run(self, pin: int, times: Sequence[int], levels: bytes) -> None:
        m = self._by_step.get(pin)
        if m is not None and m.channel is not None:
            if pin in self._shared:
                for t, lv in zip(times, levels, strict=True):
                    if not m.shared_edge(t, lv):
                        self._pin_edges(pin, (t,), bytes((lv,)))
                return
            m.step_run(times, levels)
            return
        if m is not None and pin not in self._shared:  # no channel: an output drives it
            self.levels[pin] = levels[-1] if levels else self.levels.get(pin, 0)
            return
        if pin == IRQ_BLOCKED:
            self._irq(times, levels)
            return
        self._pin_edges(pin, times, levels)

    def _pin_edges(self, pin: int, times: Sequence[int], levels: bytes) -> None:
        """Edges of a direction or enable pin (or of another pin: its level only)."""
        dirs = self._by_dir.get(pin)
        enables = self._by_enable.get(pin)
        for t, lv in zip(times, levels, strict=True):
            was = [s.enabled() for s in enables] if enables else []
            self.levels[pin] = lv
            if dirs:
                for s in dirs:
                    s.dir_edge(t)
            if enables:
                for s, w in zip(enables, was, strict=True):
                    s.enable_edge(t, w)

    def _irq(self, times: Sequence[int], levels: bytes) -> None:
        for t, lv in zip(times, levels, strict=True):
            if lv:
                self.irq_windows += 1
                self._irq_rise = t
            elif self._irq_rise is not None:
                self.irq_ticks += t - self._irq_rise
                self._irq_rise = None

    def finish(self, end_tick: int) -> None:
        for m in self.steppers:
            m.finish(end_tick)
        if self._bind in self.backend.channel_listeners:
            self.backend.channel_listeners.remove(self._bind)

    @property
    def stray_reads(self) -> tuple[int, int]:
        b = self.backend
        return (b.stray_reads - self.stray_base[0],
                b.stray_reads_during_pulse - self.stray_base[1])
