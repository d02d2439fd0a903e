"""The contract between a queue and what executes it: :class:`QueueChannel`, and the
entries they share (:class:`QueueEntry`).

A backend executes each :class:`~fas.queue.StepperQueue` through one channel (the
simulated timer-compare unit, a device behind a serial link, QuickStep's timer, a
relay of QuickStep's orders).  The library - the stepper, its planner, the gear, the
synchronized outputs - calls a channel only through the methods declared here.

Every channel runs a queue (:meth:`~QueueChannel.start`, :meth:`~QueueChannel.sync`
...).  Beyond that a channel may offer *capabilities*; each has a default that
means "not offered", so a caller asks before it relies on one:

* **timed start** (:mod:`fas.gear`): :meth:`~QueueChannel.end_tick`,
  :meth:`~QueueChannel.earliest_start_tick`, :meth:`~QueueChannel.start_at`,
  :meth:`~QueueChannel.hold_cuts` - offered when ``earliest_start_tick()`` is not None;
* **cut** (the ramp planner's quick stop behind a deep queue):
  :attr:`~QueueChannel.supports_cut`, :attr:`~QueueChannel.cut_pending`,
  :meth:`~QueueChannel.cut_index`, :meth:`~QueueChannel.cut`;
* **order FIFO** (:class:`OrderChannel`, QuickStep's orders, which keep their slot
  until done): a delay before the first order, which orders may still be taken back,
  and shortening an order already queued.

Pulse counting (ESP32's pcnt) and a detached step pin are attributes every channel
has; :meth:`QueueChannel.take_over` hands them on when a stepper changes queue.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable


class QueueEntry:
    """One command of a queue as its channel executes it (the library writes it, see
    :class:`fas.queue.StepperQueue`; the channel counts its ``steps`` down)."""

    __slots__ = ("steps", "ticks", "count_up", "toggle_dir", "dir_level", "end_pos",
                 "total_steps", "bare")

    def __init__(self) -> None:
        self.steps = 0  # steps still to be made; counted down by the channel
        self.total_steps = 0
        self.ticks = 0
        self.count_up = True
        self.toggle_dir = False
        self.dir_level = True
        self.end_pos = 0
        # written by the library itself, not planned by a ramp (the pauses of auto
        # enable's delay): a bare queue write
        self.bare = False

    def __repr__(self) -> str:  # pragma: no cover - debugging aid
        return (f"QueueEntry(steps={self.steps}/{self.total_steps}, ticks={self.ticks}, "
                f"up={self.count_up}, toggle={self.toggle_dir}, end={self.end_pos})")


class PulseCounter:
    """An independent counter of step pulses (ESP32's pcnt unit).

    Counts rising step edges up or down by the direction: the direction pin's level
    (``follow_direction``), or the level of a read-back GPIO (``readback``), or - with
    neither - always up.  On reaching ``high`` (or ``low``) it resets to 0; with both
    limits 0 it wraps like an int16.
    """

    def __init__(self, low: int, high: int, dir_high_counts_up: bool = True, *,
                 follow_direction: bool = True,
                 readback: Callable[[], int] | None = None) -> None:
        self.low = low
        self.high = high
        self.dir_high_counts_up = dir_high_counts_up
        self.follow_direction = follow_direction
        self.readback = readback
        self.value = 0
        #: called after :meth:`clear` (an executor that keeps a copy clears it, too)
        self.on_clear: Callable[[], None] | None = None

    def count(self, steps: int, dir_level: bool) -> None:
        if steps <= 0:
            return
        if self.readback is not None:
            up = (self.readback() == 1) == self.dir_high_counts_up
        elif self.follow_direction:
            up = dir_level == self.dir_high_counts_up
        else:
            up = True
        v = self.value + (steps if up else -steps)
        if self.high == 0 and self.low == 0:
            v = ((v + 0x8000) & 0xFFFF) - 0x8000
        else:
            if up and self.high > 0 and v >= self.high:
                v %= self.high
            elif not up and self.low < 0 and v <= self.low:
                v = -((-v) % (-self.low))
        self.value = v

    def read(self) -> int:
        return self.value

    def clear(self) -> None:
        self.value = 0
        if self.on_clear is not None:
            self.on_clear()


class QueueChannel(ABC):
    """Executes the entries of one :class:`~fas.queue.StepperQueue`."""

    step_pin: int
    #: the application drives the step pin itself (``detach_from_pin``)
    detached: bool = False
    #: where the channel counts its pulses (None: no counter attached)
    pulse_counter: PulseCounter | None = None
    #: the ramp that plans the commands written now runs continuously (``keep_running``:
    #: set by the ramp planner at each fill; a backend whose CPU time follows it reads it)
    ramp_continuous: bool = False
    #: the ramp planner's last fill wrote the ramp's last command (the ramp ended in it;
    #: set at each fill; a backend whose CPU time follows it reads it)
    ramp_ended: bool = False
    #: the ramp generator's extra arithmetic before the next command written (set by the
    #: ramp planner; a backend whose CPU time follows it reads and clears it): the ramp
    #: config's update() with linear acceleration, a start's jump (RampGenerator.jump_maths)
    ramp_cubic_update: bool = False
    ramp_jump_maths: int = 0
    #: the branches the ramp's arithmetic took for the command written now
    #: (NextCommand.path: fas.codes.PATH_*; set by the ramp planner before each
    #: write, a backend whose CPU time follows it reads it)
    ramp_path: int = 0

    # ------------------------------------------------------- every channel
    @abstractmethod
    def is_running(self) -> bool:
        """True from ``start()`` until the channel has found the queue empty."""

    @abstractmethod
    def start(self) -> None:
        """Begin executing at ``read_idx`` (no-op if the queue is empty)."""

    @abstractmethod
    def force_stop(self) -> None:
        """Stop at once; no further pulse is emitted."""

    @abstractmethod
    def sync(self) -> None:
        """Bring ``read_idx`` and the current entry's remaining steps up to now."""

    def ready_for_commands(self) -> bool:
        return True

    def fill_begins(self) -> int:
        """The ramp task's fill of this stepper reads the queue now: the ticks of the
        entries after the running one that the channel has taken up by the time the
        fill's code reads the indices; 0 by default."""
        return 0

    def ramp_converted(self, ramp_step: int, log2_ticks: int) -> None:  # noqa: B027
        """The ramp computed the next command's period (written next) from ramp step
        ``ramp_step``: the value it converted to log2 and the log2 value ``log2_ticks`` it
        converted back.  A backend whose CPU time follows that arithmetic hooks in; does
        nothing by default."""

    def entry_added(self) -> None:  # noqa: B027 - optional hook: does nothing by default
        """A new entry was appended (a channel waiting for one may continue)."""

    def positions_shifted(self, delta: int) -> None:  # noqa: B027 - optional: no-op by default
        """All queued positions were renumbered by ``delta``."""

    def take_over(self, previous: QueueChannel) -> None:
        """The stepper's queue changes from ``previous``'s to this channel's (a planner
        with a queue of its own): its pulse counter counts on, a detached step pin
        stays detached."""
        counter = previous.pulse_counter
        if counter is not None:
            self.pulse_counter = counter
        self.detached = previous.detached

    # ----------------------------------------- capability: timed start (fas.gear)
    def end_tick(self) -> int | None:
        """While the channel works through its queue without a gap: the tick at which
        the last queued entry ends - where an entry appended now begins.  None when
        the channel is idle, ran dry, or this backend cannot tell."""
        return None

    def earliest_start_tick(self) -> int | None:
        """The earliest tick at which :meth:`start_at` called now could begin the entry
        at ``read_idx`` (None: this backend has no timed start)."""
        return None

    def start_at(self, tick: int) -> int | None:
        """Start the idle channel so that the entry at ``read_idx`` begins at ``tick``
        (an absolute tick), or as soon after as possible.  Returns the tick at which
        it will begin; None if it cannot (running, empty queue, no timed start)."""
        return None

    def hold_cuts(self, hold: bool) -> None:  # noqa: B027 - optional hook: does nothing by default
        """While held, no cut drops queued entries (a follower derived steps from them)."""

    # --------------- capability: cuts, a stop that must not wait for a deep queue
    supports_cut = False  # the planner keeps ramp snapshots and may ask for cuts

    @property
    def cut_pending(self) -> bool:
        """A cut is not yet confirmed: hold back new ramp requests."""
        return False

    def cut_index(self) -> int | None:
        """The first queue index a cut sent now could drop (None: no cut possible)."""
        return None

    def cut(self, index: int, on_refused: Callable[[], None]) -> None:
        """Drop the entries from ``index`` on, here and on the executor; if the executor
        had already begun them, the entries come back and ``on_refused()`` is called.
        Only channels whose :meth:`cut_index` offers an index are asked."""
        raise NotImplementedError(f"{type(self).__name__} cannot cut its queue")


class OrderChannel(QueueChannel):
    """The executor of a FIFO of *orders* (QuickStep, :mod:`fas.quickstep`): an order
    keeps its slot until its last interval has passed, a stop takes back the orders
    that have not begun and shortens the running one."""

    #: ticks the first step of the next start waits (the driver's enable delay); the
    #: planner sets it before an order goes into an idle FIFO, the start consumes it
    start_delay_ticks: int = 0

    @abstractmethod
    def keep_until(self) -> int:
        """The first FIFO index whose order has not begun (nor been passed on) and may
        be dropped; the write index when none may."""

    @abstractmethod
    def orders_dropped(self) -> None:
        """The orders from :meth:`keep_until` on were taken back."""

    @abstractmethod
    def shorten(self, e: QueueEntry, keep: int) -> int:
        """Let order ``e`` (in the FIFO) make at most ``keep`` (>= 1) more steps;
        returns how many steps were taken off it (0: too late)."""
