"""Synchronized output changes: barriers in the engine's stream of motion commands.

A synchronized change (``engine.outputs.digital(0, True)``) must happen after all
motion commanded before it and before any motion commanded after it.  The engine
keeps one FIFO of *barriers* (the changes) and *held calls* (motion commanded while
a barrier waits):

1. A barrier is handed to the backend (``backend.sync_output``) once everything
   commanded before it is planned - no ramp generator is active any more, so every
   queue command of that motion has been written.  The backend makes the change when
   every queue has executed all its commands (the simulated chip at the tick the
   last queue runs dry; a device likewise, in order with the entries it received).
2. The barrier is passed when the backend has made the change and no stepper runs;
   then the held calls behind it are made, in the order they were given, up to the
   next barrier.

While any barrier waits, the motion calls of every stepper (``move``, ``move_to``,
``run_forward`` ...) are held: they check what they can at once (direction pin,
speed and acceleration defined) and return OK; ``add_queue_entry`` answers
``QUEUE_FULL`` (try again), as a full queue does.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # pragma: no cover
    from .backend import OutputChange
    from .engine import Engine


class Barrier:
    __slots__ = ("change", "handed", "token")

    def __init__(self, change: OutputChange) -> None:
        self.change = change
        self.handed = False
        self.token: object = None


class HeldCall:
    __slots__ = ("fn", "stepper", "done")

    def __init__(self, fn: Callable[[], object], stepper: int) -> None:
        self.fn = fn
        self.stepper = stepper
        self.done = False


class SyncQueue:
    """The FIFO of barriers and held motion calls of one engine."""

    def __init__(self, engine: Engine) -> None:
        self._engine = engine
        self._fifo: deque[Barrier | HeldCall] = deque()
        self._busy = False
        self._again = False
        self._releasing = False
        self.passed = 0
        self.held_calls = 0

    # ------------------------------------------------------------- queries
    def holding(self) -> bool:
        """Motion commanded now has to wait (a barrier is pending)."""
        return bool(self._fifo) and not self._releasing

    def active(self) -> bool:
        return bool(self._fifo)

    def pending_changes(self) -> int:
        return sum(1 for item in self._fifo if isinstance(item, Barrier))

    def pending_analog(self, numbers: list[int]) -> bool:
        return any(isinstance(item, Barrier) and item.change.analog
                   and item.change.number in numbers for item in self._fifo)

    # -------------------------------------------------------------- adding
    def add_barrier(self, change: OutputChange) -> None:
        self._fifo.append(Barrier(change))
        self._engine.kick()
        self.progress()

    def hold(self, fn: Callable[[], object], stepper: int) -> HeldCall:
        call = HeldCall(fn, stepper)
        self._fifo.append(call)
        self.held_calls += 1
        return call

    def cancel(self, drop_motion: bool = True) -> int:
        """Drop the barriers not yet passed (and the held motion unless told to keep it:
        then it is made at once).  Returns the number of changes dropped."""
        dropped = 0
        kept: list[HeldCall] = []
        for item in self._fifo:
            if isinstance(item, Barrier):
                dropped += 1
            elif not drop_motion:
                kept.append(item)
            else:
                item.done = True
        self._fifo.clear()
        self._engine.backend.cancel_sync_outputs()
        for call in kept:
            call.done = True
            call.fn()
        return dropped

    # ------------------------------------------------------------ progress
    def progress(self) -> None:
        """Hand over, pass and release what can be (re-entrant calls are folded in)."""
        if self._busy:
            self._again = True
            return
        self._busy = True
        try:
            self._again = True
            while self._again:
                self._again = False
                self._step()
        finally:
            self._busy = False

    def _step(self) -> None:
        engine = self._engine
        backend = engine.backend
        fifo = self._fifo
        while fifo:
            head = fifo[0]
            if isinstance(head, HeldCall):
                fifo.popleft()
                head.done = True
                self._releasing = True
                try:
                    head.fn()
                finally:
                    self._releasing = False
                continue
            steppers = engine.steppers
            if not head.handed:
                if any(s.is_ramp_generator_active() for s in steppers):
                    return
                head.handed = True
                head.token = backend.sync_output(head.change)
            if not backend.sync_output_done(head.token):
                return
            if any(s.is_running() for s in steppers):
                return
            fifo.popleft()
            self.passed += 1
            engine.outputs.applied(head.change)
