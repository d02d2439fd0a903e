"""The traverse: S2 moves end to end continuously on the notes' ramped profile.

Each leg is planned as the design notes do it: from a start speed the speed grows by
``acceleration x interval`` every 50 ms interval until the top speed; the steps of an
interval run at one period (the interval's mean speed, in 4 us counts).  The steps
of the ramp up - the *critical distance* - are remembered and the ramp down is their
mirror, so every leg ends exactly on its target.  A leg too short for the top speed
ramps down at half way.  The intervals are generated as the leg goes (replanned
every 50 ms), and written into the stepper's queue a little ahead of time by the
engine's periodic task (:class:`TraverseFeeder`).

At the end of a leg, or when a limit switch stopped S2, the next leg goes the other
way.  Stopping the traverse ramps down along the same mirror.
"""

from __future__ import annotations

from collections.abc import Callable
from enum import IntEnum
from typing import TYPE_CHECKING

from fas.codes import AqeResult
from fas.gear import MAX_STEPS, MAX_TICKS, split_ticks

from . import figures as fig
from .potrule import period_counts

if TYPE_CHECKING:  # pragma: no cover
    from fas import Engine, Stepper


class Phase(IntEnum):
    RAMP_UP = 1
    PLATEAU = 2
    RAMP_DOWN = 3
    DONE = 4


class Leg:
    """One move of ``total`` steps (see module text): a source of (period, steps)."""

    def __init__(self, total: int, start_speed: float, accel: float, top_speed: float,
                 interval_s: float = fig.TRAVERSE_INTERVAL_MS / 1000) -> None:
        self.total = total
        self.half = total // 2
        self.accel = accel
        self.top = max(top_speed, start_speed)
        self.interval = interval_s
        self.v = start_speed
        self.done = 0  # steps planned so far
        self.up: list[tuple[int, int]] = []  # ramp-up intervals: (period counts, steps)
        self.ramp_steps = 0  # steps of the ramp up (the critical distance when reached)
        self.phase = Phase.RAMP_UP if total > 0 else Phase.DONE
        self.plateau_left = 0
        self.plateau_counts = period_counts(self.top)

    @property
    def remaining(self) -> int:
        return self.total - self.done

    def next_interval(self) -> tuple[int, int] | None:
        """The next interval as (period in 4 us counts, steps), None when done."""
        if self.phase == Phase.RAMP_UP:
            v_next = self.v + self.accel * self.interval
            if v_next >= self.top:
                self._to_plateau(self.plateau_counts)
            else:
                mean = (self.v + v_next) / 2
                steps = max(1, round(mean * self.interval))
                if self.ramp_steps + steps > self.half:  # a short leg: down at half way
                    steps = self.half - self.ramp_steps
                    counts = period_counts(mean)
                    self.ramp_steps += max(steps, 0)
                    self._to_plateau(counts)
                    if steps > 0:
                        self.up.append((counts, steps))
                        return self._emit(counts, steps)
                else:
                    counts = period_counts(mean)
                    self.up.append((counts, steps))
                    self.ramp_steps += steps
                    self.v = v_next
                    return self._emit(counts, steps)
        if self.phase == Phase.PLATEAU:
            if self.plateau_left > 0:
                counts = self.plateau_counts
                chunk = max(1, round(self.top * self.interval))
                steps = min(chunk, self.plateau_left)
                self.plateau_left -= steps
                if self.plateau_left == 0:
                    self.phase = Phase.RAMP_DOWN
                return self._emit(counts, steps)
            self.phase = Phase.RAMP_DOWN
        if self.phase == Phase.RAMP_DOWN:
            if self.up:
                counts, steps = self.up.pop()
                return self._emit(counts, steps)
            self.phase = Phase.DONE
        return None

    def _to_plateau(self, counts: int) -> None:
        self.plateau_counts = counts
        self.plateau_left = self.total - 2 * self.ramp_steps
        self.phase = Phase.PLATEAU

    def _emit(self, counts: int, steps: int) -> tuple[int, int]:
        self.done += steps
        return counts, steps

    def stop(self) -> None:
        """Ramp down from here (the mirror of the ramp walked so far)."""
        if self.phase in (Phase.RAMP_UP, Phase.PLATEAU):
            self.plateau_left = 0
            self.phase = Phase.RAMP_DOWN


class TraverseFeeder:
    """Writes a traverse's legs into the stepper's queue from the engine's task.

    ``ends`` are the two positions; ``start_counts``/``accel``/``top_counts`` the
    profile.  ``blocked(up)`` says whether a limit forbids a direction: a blocked
    leg is not started and the other end becomes the target.  ``on_event`` hears
    ``("leg", target)`` and ``("done", position)``.
    """

    def __init__(self, engine: Engine, stepper: Stepper, ends: tuple[int, int], *,
                 start_counts: int, accel: int, top_counts: int,
                 blocked: Callable[[bool], bool] | None = None,
                 on_event: Callable[[str, int], None] | None = None) -> None:
        self.engine = engine
        self.stepper = stepper
        self.ends = ends
        p = engine.profile
        self.ticks_per_count = p.ticks_per_us * fig.COUNT_US
        self.ahead_ticks = fig.TRAVERSE_AHEAD_MS * p.ticks_per_ms
        self.min_cmd_ticks = p.min_cmd_ticks
        self.start_speed = fig.COUNTS_PER_S / start_counts
        self.accel = accel
        self.top_speed = fig.COUNTS_PER_S / top_counts
        self.blocked = blocked
        self.on_event = on_event
        self.active = False
        self.stopping = False
        self.leg: Leg | None = None
        self.leg_up = True
        self.target = ends[1]
        self.legs = 0
        self._seg: tuple[int, int] | None = None  # (ticks per step, steps left)

    # ---------------------------------------------------------------- control
    def start(self) -> None:
        self.active = True
        self.stopping = False
        self.leg = None
        pos = self.stepper.get_position_after_commands_completed()
        # first towards `to`; from there (or beyond it) towards `from`
        self.target = self.ends[1] if pos != self.ends[1] else self.ends[0]
        self.engine.add_task_hook(self)

    def stop(self) -> None:
        """Ramp down and end (the steps already queued run)."""
        self.stopping = True
        if self.leg is not None:
            self.leg.stop()
        else:
            self._end()

    def limit_hit(self) -> None:
        """A limit stopped the stepper (its queue was dropped): turn round."""
        self.leg = None
        self._seg = None
        if self.stopping:
            self._end()
            return
        pos = self.stepper.get_position_after_commands_completed()
        up = self.leg_up
        self.target = min(self.ends) if up else max(self.ends)
        if self.target == pos:
            self.target = max(self.ends) if up else min(self.ends)

    def _end(self) -> None:
        self.active = False
        self.leg = None
        self._seg = None
        self.engine.remove_task_hook(self)
        if self.on_event is not None:
            self.on_event("done", self.stepper.get_position_after_commands_completed())

    # -------------------------------------------------------------- task hook
    def needs_task(self) -> bool:
        return self.active

    def run_task(self) -> None:
        if not self.active:
            return
        s = self.stepper
        q = s.queue
        if self.leg is None and s.is_ramp_generator_active():
            return  # another motion still ramps down
        q.ignore_commands = False  # a planner of this queue, as the ramp task's fill
        started = q.is_running()
        for _ in range(q.queue_len):  # at most a queue's worth per task
            if not self.active or q.is_queue_full():
                break
            if q.ticks_in_queue() >= self.ahead_ticks:
                break
            if (self._seg is None or self._seg[1] == 0) and not self._next_interval():
                break
            if not self._write():
                break
        if not started and not q.is_queue_empty() and not q.is_running():
            s.add_queue_entry(None, start=True)

    def _next_interval(self) -> bool:
        if self.leg is not None:
            nxt = self.leg.next_interval()
            if nxt is not None:
                counts, steps = nxt
                self._seg = (counts * self.ticks_per_count, steps)
                return True
            self.leg = None  # the leg is planned to its end
            if self.stopping:
                self._end()
                return False
            self.target = self.ends[0] if self.target == self.ends[1] else self.ends[1]
        pos = self.stepper.get_position_after_commands_completed()
        total = abs(self.target - pos)
        up = self.target > pos
        if total == 0 or (self.blocked is not None and self.blocked(up)):
            # nothing to do this way: the other end
            self.target = self.ends[0] if self.target == self.ends[1] else self.ends[1]
            total = abs(self.target - pos)
            up = self.target > pos
            if total == 0 or (self.blocked is not None and self.blocked(up)):
                self._end()
                return False
        self.leg_up = up
        self.leg = Leg(total, self.start_speed, self.accel, self.top_speed)
        self.legs += 1
        if self.on_event is not None:
            self.on_event("leg", self.target)
        return self._next_interval()

    def _write(self) -> bool:
        """One queue command (or a step and its pauses) of the current interval."""
        ticks, left = self._seg
        s = self.stepper
        up = self.leg_up
        if ticks > MAX_TICKS:  # slower than 244 steps/s: a step, then pauses
            parts = split_ticks(ticks)
            if s.queue.queue_entries() + len(parts) > s.queue.queue_len:
                return False
            ok = s.add_queue_entry(parts[0], 1, up, start=False) == AqeResult.OK
            for part in parts[1:]:
                ok = ok and s.add_queue_entry(part, 0, up, start=False) == AqeResult.OK
            self._seg = (ticks, left - 1)
            return ok
        steps = min(left, MAX_STEPS)
        if left - steps == 1 and ticks < self.min_cmd_ticks:
            steps -= 1  # never leave a single step shorter than a command may be
        if steps == 1 and ticks < self.min_cmd_ticks:
            ticks = self.min_cmd_ticks
        if s.add_queue_entry(ticks, steps, up, start=False) != AqeResult.OK:
            return False
        self._seg = (self._seg[0], left - steps)
        return True
