"""The small interface between the library and whatever executes its commands.

A backend supplies a tick clock, calls the engine's periodic task, drives pins and
executes queue entries through one :class:`QueueChannel` per stepper.  The library
(:mod:`fas.engine`, :mod:`fas.stepper`, :mod:`fas.queue`) talks only to this
interface (and to the channels of :mod:`fas.channel`); :mod:`fas.sim` implements it
on a simulated microcontroller and :mod:`fas.serial` on a real one behind a serial line.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable, Protocol, Sequence

from .channel import OrderChannel, PulseCounter, QueueChannel

if TYPE_CHECKING:  # pragma: no cover
    from .arch import Profile
    from .pwm import PwmSetting
    from .queue import StepperQueue

#: how the main loop polls: its pass length and the sections (offset, ticks) of a pass
#: with interrupts off (:meth:`Backend.app_spend_in`)
AppPoll = tuple[int, tuple[tuple[int, int], ...]]

__all__ = ["AppPoll", "Backend", "EngineStepper", "OutputChange", "OrderChannel", "PulseCounter",
           "QueueChannel", "InputListener", "LimitListener", "PinRecording", "PinStates",
           "TaskEngine"]


@dataclass(frozen=True)
class OutputChange:
    """One change of one user output (:mod:`fas.outputs`), as a backend executes it."""

    analog: bool
    number: int
    pin: int
    value: int  # digital: 0/1; analog: the duty count (0 .. setting.counts)
    setting: PwmSetting | None = None  # analog: the timer setting the count is for
    synchronized: bool = False
    percent: float = 0.0  # analog: the duty asked for (the count is what it makes)

    @property
    def name(self) -> str:
        return f"{'Aout' if self.analog else 'Dout'}{self.number}"


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


class EngineStepper(Protocol):
    """What a backend may do with a stepper of its engine (:class:`fas.stepper.Stepper`):
    find its queue, read and set its position, see whether it runs (a link lost or a
    device reconnected)."""

    @property
    def queue(self) -> StepperQueue: ...

    def get_current_position(self) -> int: ...

    def is_running(self) -> bool: ...

    def force_stop_and_new_position(self, new_pos: int) -> None: ...


class TaskEngine(Protocol):
    """What a backend calls on the engine it runs (:class:`fas.engine.Engine`): the
    periodic task, which runs it may skip, and the moment queues ran dry."""

    @property
    def steppers(self) -> Sequence[EngineStepper]: ...

    def manage_steppers(self) -> int:
        """One run of the periodic ramp task."""
        ...

    def quiescent_tasks(self) -> int | None:
        """Runs after this one that would do nothing (None: all, until woken)."""
        ...

    def credit_skipped_tasks(self, n: int) -> None:
        """``n`` runs were skipped (as :meth:`quiescent_tasks` allowed)."""
        ...

    def may_stop_without_channel(self) -> bool:
        """A stepper may start or stop in this run without its channel noticing."""
        ...

    def queues_idle(self) -> None:
        """A queue ran dry or a synchronized output was made (:mod:`fas.sync`)."""
        ...

    def planning_queues(self) -> list[StepperQueue]:
        """The queues whose stepper has motion still to plan in the next run."""
        ...


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
    # the period set by set_task_period (None: the profile's fill period)
    _task_period: int | None = None

    @abstractmethod
    def now(self) -> int:
        """Current time in ticks of ``profile.ticks_per_s``."""

    @abstractmethod
    def attach_engine(self, engine: TaskEngine) -> None:
        """Run ``engine.manage_steppers()`` periodically (the ~4 ms ramp task).

        A backend may skip runs that ``engine.quiescent_tasks()`` declares idle, and
        must then report them with ``engine.credit_skipped_tasks(n)``.
        """

    def wake_task(self) -> None:  # noqa: B027 - optional hook: does nothing by default
        """The engine has work again: do not skip the next periodic run."""

    @property
    def task_period_ticks(self) -> int:
        """Period of the periodic ramp task (``engine.task_rate()`` may change it)."""
        return self._task_period or self.profile.fill_period_ticks

    def set_task_period(self, ticks: int) -> None:
        """From the next run on, run the periodic task every ``ticks``."""
        self._task_period = max(1, ticks)

    @abstractmethod
    def allocate_channel(self, queue: StepperQueue) -> QueueChannel:
        """Create the executor for ``queue`` (its ``step_pin`` and ``index`` are set)."""

    def allocate_order_channel(self, queue: StepperQueue, fas_queue: StepperQueue,
                               clock: object) -> OrderChannel | None:
        """An executor of a FIFO of orders (QuickStep's, :mod:`fas.quickstep`) on a timer
        of the chip's own, paced by ``clock``; None (the default): this backend has
        none, and the planner relays its orders into the stepper's command queue
        ``fas_queue`` (a device behind a serial link runs them so)."""
        return None

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

    def detach_step_pin(  # noqa: B027 - optional hook: does nothing by default
            self, queue: StepperQueue, detached: bool) -> None:
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

    def cancel_sync_outputs(self) -> None:  # noqa: B027 - optional hook: does nothing by default
        """Drop synchronized changes not made yet (alarm)."""

    # timed output (capability, issue 25's laser): a change made at a tick by the chip
    def timed_output(self, change: OutputChange, tick: int) -> bool:
        """Make ``change`` at tick ``tick`` of :meth:`now`'s clock where the outputs are
        (a timer compare on the chip, the device's clock), not when the main loop gets
        to it; a PWM duty then shows from the timer's next period, as with
        :meth:`set_output`.  A tick already past: at once.  Changes of one output are
        made in tick order.  False (the default): not offered - the caller makes the
        change itself when the tick comes (:meth:`UserOutputs.poll_timed
        <fas.outputs.UserOutputs.poll_timed>`)."""
        return False

    def cancel_timed_outputs(self) -> None:  # noqa: B027 - optional hook: does nothing by default
        """Drop the timed changes whose tick has not come yet (they are not made)."""

    # --- hosting an application main loop (StepperDemo) beside the library ---
    def app_started(self) -> None:  # noqa: B027 - optional hook: does nothing by default
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

    def app_polls(self, poll: tuple[int, tuple[tuple[int, int], ...]] | None) -> None:
        """How the main loop polls in the following waits (:meth:`app_wait_until`): its
        pass length and, per pass, the sections (offset, ticks) with interrupts off
        (None: not followed).  Backends without interrupt contention ignore it."""
        return

    def app_spend_in(self, ticks: int, poll: tuple[int, tuple[tuple[int, int], ...]]) -> None:
        """:meth:`app_spend` in passes of ``poll[0]`` ticks, each with interrupts off in
        the sections ``poll[1]`` (offset, ticks): a loop that reads something under
        ``cli`` again and again."""
        self.app_spend(ticks)

    def app_spend_passes(self, passes: Sequence[tuple[int, int, AppPoll | None]],
                         before: int, changed: Callable[[], bool]) -> int:
        """The main loop runs the same round of passes again and again while nothing it
        looks at changes: each pass ``(head, ticks, poll)`` spends ``head`` ticks, makes
        its reads, then spends ``ticks`` (``poll``: as :meth:`app_spend_in`'s, None: as
        :meth:`app_spend`).  A pass is spent only if its reads come before tick
        ``before`` and nothing of the library's happens before them in it; after a pass
        in which something happened, the backend stops once ``changed()`` holds.
        Returns how many passes were spent, from the round's first: spending them one
        by one, as the loop would, ends at the same tick with the same effects.  A
        backend that cannot tell spends none (0): the caller runs its passes itself."""
        return 0

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

    def auto_enabled(self) -> None:  # noqa: B027 - optional: no-op by default
        """Auto enable switched a driver's outputs on while a command was written (the
        library's ``enableOutputs()`` inside ``addQueueEntry()``): a backend that counts
        CPU time charges it here."""

    def stray_read(self, pins: tuple[int, ...]) -> None:  # noqa: B027 - optional: no-op by default
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

    def clear_limit(self, index: int, up: bool) -> None:  # noqa: B027 - optional: no-op by default
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

    def deliver_edges(self) -> None:  # noqa: B027 - optional hook: does nothing by default
        """Hand every pin edge made up to now to the recording and the pin statistics
        (a PWM wave makes its edges when asked)."""
