"""The timeline of the engine's periodic task (the ~4 ms ramp fill), for every backend.

Run ``i`` of the task is due at ``origin + i * period``.  A backend keeps one
:class:`TaskSchedule` and decides only *how* it waits for the next run: the simulated
chip plans an interrupt event at :meth:`TaskSchedule.next_time`, the serial host polls
it in its loop.  What a run is due, what a changed period does to the timeline, which
runs a quiet engine skips and how many a late run has to credit is decided here once.

The protocol a backend follows (cf. a reactor's ``register_timer(callback, waketime)``
whose callback answers its next wake time)::

    tasks.start(first_time)              # attach_engine
    ...
    skipped = tasks.begin(index)         # a run: credit `skipped` to the engine
    engine.manage_steppers()
    tasks.end(engine.quiescent_tasks())  # the next run (None: until woken)
    ...
    if tasks.wake(now):                  # wake_task: the engine has work again
        replan(tasks.next_time())
"""

from __future__ import annotations

__all__ = ["TaskSchedule"]


class TaskSchedule:
    """Which run of a periodic task comes next, and when (see the module text).

    ``last`` is the index of the last run - before the first run, the index the
    timeline is anchored at (:meth:`start`); ``next`` the index of the next planned
    run, ``None`` while the task sleeps until :meth:`wake`.
    """

    __slots__ = ("last", "next", "origin", "period")

    def __init__(self, period: int = 1) -> None:
        self.period = period
        self.origin = 0
        self.last = -1
        self.next: int | None = None

    def start(self, first_time: int, period: int, anchor: int = -1) -> None:
        """Run 0 is due at ``first_time``, the following ones every ``period``.

        ``anchor``: the run whose time a period change before the first run keeps -
        -1: the moment before run 0 (run 0 then follows one new period after it), 0:
        run 0 itself (it keeps its time)."""
        self.period = period
        self.origin = first_time
        self.last = anchor
        self.next = 0

    def time(self, index: int) -> int:
        """When run ``index`` is due."""
        return self.origin + index * self.period

    def next_time(self) -> int | None:
        """When the next planned run is due (None: none is planned)."""
        nxt = self.next
        return None if nxt is None else self.origin + nxt * self.period

    def is_due(self, now: int) -> bool:
        """A run is planned and its time has come."""
        nxt = self.next
        return nxt is not None and now >= self.origin + nxt * self.period

    def set_period(self, period: int) -> None:
        """Runs after the last one follow ``period``; the last one keeps its time."""
        last_time = self.time(self.last)
        self.period = period
        self.origin = last_time - self.last * period

    def due(self, now: int) -> int:
        """The first run after the last one whose time has not passed at ``now``."""
        due = self.last + 1
        t = self.origin + due * self.period
        if now > t:
            due += -(-(now - t) // self.period)
        return due

    def wake(self, now: int) -> bool:
        """The task has work again: plan the next run no later than the first slot
        that has not passed.  True if that moved the next run (it was later or none)."""
        nxt = self.next
        if nxt is not None and nxt <= self.last + 1:
            return False  # the next slot is planned already (the common case)
        due = self.due(now)
        if nxt is not None and nxt <= due:
            return False
        self.next = due
        return True

    def catch_up(self, now: int) -> int:
        """The planned run, moved on by the periods that have passed since it was due
        (a run that waited behind something else does not run twice)."""
        idx = self.next
        assert idx is not None, "no run is planned"
        late = (now - (self.origin + idx * self.period)) // self.period
        return idx + late if late > 0 else idx

    def begin(self, index: int) -> int:
        """Run ``index`` begins; returns the runs skipped since the last one (the
        engine is credited with them)."""
        skipped = index - self.last - 1
        self.last = index
        return skipped

    def end(self, quiet: int | None) -> int | None:
        """The run is over and the ``quiet`` runs after it would do nothing: the next
        run skips them (None: sleep until :meth:`wake`).  Returns the next index."""
        self.next = None if quiet is None else self.last + 1 + quiet
        return self.next

    def stop(self) -> None:
        """No run is planned any more (the task ends or is replanned)."""
        self.next = None
