"""The small interface between the library and whatever executes its commands.

A backend supplies a tick clock, calls the engine's periodic task, drives pins and
executes queue entries through one :class:`QueueChannel` per stepper.  The library
(:mod:`fas.engine`, :mod:`fas.stepper`, :mod:`fas.queue`) talks only to this
interface; :mod:`fas.sim` implements it on a simulated microcontroller and
:mod:`fas.serial` on a real one behind a serial line.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from typing import TYPE_CHECKING, Callable, Protocol, Sequence

if TYPE_CHECKING:  # pragma: no cover
    from .arch import Profile
    from .outputs import OutputChange
    from .pwm import PwmSetting
    from .queue import StepperQueue


class QueueChannel(ABC):
    """Executes the entries of one :class:`~fas.queue.StepperQueue`."""

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

    def entry_added(self) -> None:
        """A new entry was appended (a channel waiting for one may continue)."""

    def positions_shifted(self, delta: int) -> None:
        """All queued positions were renumbered by ``delta``."""

    # --- timing of the queue (electronic gearing, :mod:`fas.gear`) ---
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

    def hold_cuts(self, hold: bool) -> None:
        """While held, no cut drops queued entries (a follower derived steps from them)."""

    # --- cuts: a stop that must not wait for a deep queue (serial backend) ----------
    supports_cut = False  # the stepper keeps ramp snapshots and may ask for cuts
    cut_pending = False  # a cut is not yet confirmed: hold back new ramp requests

    def cut_index(self) -> int | None:
        """The first queue index a cut sent now could drop (None: no cut possible)."""
        return None

    def cut(self, index: int, on_refused: Callable[[], None]) -> None:
        """Drop the entries from ``index`` on, here and on the executor; if the executor
        had already begun them, the entries come back and ``on_refused()`` is called.
        Only channels whose :meth:`cut_index` offers an index are asked."""
        raise NotImplementedError(f"{type(self).__name__} cannot cut its queue")


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


class PinRecording(Protocol):
    """Every edge of every pin since recording began (:class:`fas.sim.pins.EdgeRecorder`)."""

    def pin_edges(self, pin: int) -> tuple[Sequence[int], bytes | bytearray]:
        """The pin's edges in time order: their ticks and levels (0/1)."""

    def rising(self, pin: int) -> list[int]:
        """The ticks of the pin's rising edges."""


class PinStates(Protocol):
    """The pins as the chip drives them, with statistics per pin: levels, rising and
    falling edges, longest and summed HIGH time in ticks, and the first write
    (``(order among all writes, level written)``) (:class:`fas.sim.pins.PinBank`)."""

    @property
    def level(self) -> Mapping[int, int]: ...
    @property
    def rise(self) -> Mapping[int, int]: ...
    @property
    def fall(self) -> Mapping[int, int]: ...
    @property
    def high_max(self) -> Mapping[int, int]: ...
    @property
    def high_total(self) -> Mapping[int, int]: ...
    @property
    def first_write(self) -> Mapping[int, tuple[int, int]]: ...

    def get(self, pin: int) -> int:
        """The pin's level now (0 for a pin never driven)."""


InputListener = Callable[[int, int, int], None]  # (pin, value, tick)
LimitListener = Callable[[int, int, int, int], None]  # (queue index, pin, position, tick)


class Backend(ABC):
    profile: Profile
    #: called with (pin, value, tick) when a watched input changes (see watch_input)
    input_listeners: list[InputListener]
    #: called with (queue index, pin, position, tick) for every queue a limit stopped
    limit_listeners: list[LimitListener]
    # ticks a stepper plans ahead beyond its forward-planning time once its queue runs
    # (a serial link's delays; 0 on a chip, where the queue is the timer's own)
    planning_extra_ticks: int = 0

    @abstractmethod
    def now(self) -> int:
        """Current time in ticks of ``profile.ticks_per_s``."""

    @abstractmethod
    def attach_engine(self, engine) -> None:
        """Run ``engine.manage_steppers()`` periodically (the ~4 ms ramp task).

        A backend may skip runs that ``engine.quiescent_tasks()`` declares idle, and
        must then report them with ``engine.credit_skipped_tasks(n)``.
        """

    def wake_task(self) -> None:
        """The engine has work again: do not skip the next periodic run."""

    @property
    def task_period_ticks(self) -> int:
        """Period of the periodic ramp task (``engine.task_rate()`` may change it)."""
        return getattr(self, "_task_period", None) or self.profile.fill_period_ticks

    def set_task_period(self, ticks: int) -> None:
        """From the next run on, run the periodic task every ``ticks``."""
        self._task_period = max(1, ticks)

    @abstractmethod
    def allocate_channel(self, queue: StepperQueue) -> QueueChannel:
        """Create the executor for ``queue`` (its ``step_pin`` and ``index`` are set)."""

    def allocate_order_channel(self, queue, fas_queue, clock) -> QueueChannel:
        """The executor of a QuickStep FIFO (``fas.quickstep``).  By default its orders
        are relayed into the stepper's command queue ``fas_queue`` (a device behind a
        serial link runs them so); the simulated chip runs them on QuickStep's timer."""
        from .quickstep.relay import OrderRelay
        return OrderRelay(queue, fas_queue, clock)

    @abstractmethod
    def write_pin(self, pin: int, level: int) -> None:
        """Drive an ordinary output pin (direction, enable, LED)."""

    @abstractmethod
    def read_pin(self, pin: int) -> int:
        """Read an output pin's level."""

    @abstractmethod
    def wait_until(self, predicate: Callable[[], bool], timeout_ticks: int) -> bool:
        """Let time pass until ``predicate()`` holds; False on timeout."""

    def attach_pulse_counter(self, queue: StepperQueue, counter: PulseCounter) -> bool:
        """Count ``queue``'s pulses into ``counter``; False if the backend cannot."""
        return False

    def detach_step_pin(self, queue: StepperQueue, detached: bool) -> None:
        """Hand the step pin to the application (``detached``) or back to the library."""

    def reset_chip(self) -> None:
        """Reboot the microcontroller (ESP32's ``ESP.restart()``): every channel stops,
        the periodic task ends, outputs fall back to LOW; the clock keeps running.
        The caller builds a new :class:`~fas.engine.Engine` afterwards."""
        raise NotImplementedError(f"{type(self).__name__} cannot reboot its chip")

    # --- user outputs (issue 12, fas.outputs) ---
    def configure_pwm(self, number: int, pin: int, setting: PwmSetting, count: int) -> None:
        """(Re)start the PWM timer of analog output ``number`` on ``pin`` at once, with
        duty ``count`` (the period starts now)."""
        raise NotImplementedError(f"{type(self).__name__} has no user outputs")

    def set_output(self, change: OutputChange) -> None:
        """Make an output change at once (immediate; a PWM duty from its next period)."""
        raise NotImplementedError(f"{type(self).__name__} has no user outputs")

    def sync_output(self, change: OutputChange) -> object:
        """Make ``change`` once every queue has executed every command written so far
        (in order with them); returns a token for :meth:`sync_output_done`.  The engine
        calls this only when all motion commanded before is written (fas.sync)."""
        raise NotImplementedError(f"{type(self).__name__} has no user outputs")

    def sync_output_done(self, token: object) -> bool:
        """Has the change of :meth:`sync_output` been made?"""
        return True

    def cancel_sync_outputs(self) -> None:
        """Drop synchronized changes not made yet (alarm)."""

    # --- hosting an application main loop (StepperDemo) beside the library ---
    def app_started(self) -> None:
        """The application's ``setup()`` begins (Arduino has just started ``millis()``)."""

    def millis(self) -> int:
        """The application's millisecond clock."""
        return self.now() * 1000 // self.profile.ticks_per_s

    def tick_at_millis(self, ms: int) -> int:
        """Earliest tick at which :meth:`millis` returns at least ``ms``."""
        return -(-ms * self.profile.ticks_per_s // 1000)

    @abstractmethod
    def app_spend(self, ticks: int) -> None:
        """The main loop uses ``ticks`` of CPU time (interrupts keep running)."""

    @abstractmethod
    def app_wait_until(self, tick: int, until: Callable[[], bool] | None = None) -> bool:
        """The main loop idles until ``tick`` (interrupts keep running), or until
        ``until()`` holds after something happened; True if it stopped for that."""

    @abstractmethod
    def next_event_time(self) -> int | None:
        """Tick of the next thing that may change the library's state, if known."""

    def console_write(self, data: bytes, cpu_after: Sequence[int] | None = None) -> None:
        """The main loop prints ``data`` on its console; may take time (a slow UART).

        ``cpu_after``: CPU time the loop spends after each character (e.g. looking up
        the rest of a text), one figure per character."""
        if cpu_after:
            for ticks in cpu_after:
                if ticks:
                    self.app_spend(ticks)

    def block_interrupts(self, ticks: int) -> None:
        """The main loop busy-waits ``ticks`` with interrupts disabled."""
        self.app_spend(ticks)

    def stray_read(self, pins: tuple[int, ...]) -> None:
        """The main loop reads step pins with a stray ``digitalRead()``."""

    # --- inputs of the application: switches and potentiometers ---
    def watch_input(self, pin: int, analog: bool = False, pullup: bool = True,
                    period_ms: int = 0) -> bool:
        """Read ``pin`` as an input from now on: digital (0/1, with the pull-up
        resistor if ``pullup``) or analog (0..1023, sampled every ``period_ms``).
        Changes go to :attr:`input_listeners`.  False if this backend has no inputs."""
        return False

    def read_input(self, pin: int) -> int | None:
        """The last known value of a watched input (None: not known yet)."""
        return None

    def drive_input(self, pin: int, value: int) -> bool:
        """The simulated world sets what an input reads (a switch closes, a pot turns).
        False where the inputs are real pins (a device)."""
        return False

    def _notify_input(self, pin: int, value: int, tick: int) -> None:
        for fn in list(getattr(self, "input_listeners", ())):
            fn(pin, value, tick)

    # --- limit switches: stops where the pulses are made ---
    def set_limit(self, index: int, pin: int, level: int, up: bool,
                  stop: tuple[int, ...] = ()) -> bool:
        """A limit switch for queue ``index``: whenever it steps ``up`` (or down) while
        ``pin`` reads ``level`` - the switch closes during a move, or a move starts
        towards a closed one - the backend stops it and the queues in ``stop`` at once,
        without a further pulse, where the pulses are made (the chip, the device), and
        reports each stopped queue to :attr:`limit_listeners` with the position where
        its pulses stopped.  The application must then force-stop those steppers at
        that position.  Setting a limit again replaces it.  False: not supported."""
        return False

    def clear_limit(self, index: int, up: bool) -> None:
        """Remove queue ``index``'s limit in that direction."""

    def _notify_limit(self, index: int, pin: int, position: int, tick: int) -> None:
        for fn in list(getattr(self, "limit_listeners", ())):
            fn(index, pin, position, tick)

    # --- what observers look at (traces, reports, scenario checks): the machine time is
    # now(); a backend that executes on the chip itself also shows its pins ---
    #: every pin edge since the backend was made, if it records them (None: it does not)
    recorder: PinRecording | None = None

    @property
    def pin_states(self) -> PinStates | None:
        """The pins as the chip drives them, with their statistics (None: this backend
        does not see its pins - they are on a device)."""
        return None

    def deliver_edges(self) -> None:
        """Hand every pin edge made up to now to the recording and the pin statistics
        (a PWM wave makes its edges when asked)."""
