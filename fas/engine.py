"""The engine: a factory of steppers and the periodic task that feeds their queues."""

from __future__ import annotations

from typing import Callable, Protocol, TypeVar

from .allocate import Allocator
from .arch import Profile
from .backend import Backend
from .codes import HIGH, LOW, PIN_I2S_FLAG, PIN_UNDEFINED, AqeResult, FasDriver
from .errors import UnsupportedError
from .outputs import UserOutputs
from .planner import Planner
from .queue import StepperQueue
from .stepper import Stepper
from .sync import SyncQueue

ExternalPinCall = Callable[[int, int], int]
T = TypeVar("T")


class TaskHook(Protocol):
    """Work that runs in the periodic ramp task right after the steppers' planners have
    filled their queues (the winder's traverse writes its stepper's queue there)."""

    def run_task(self) -> None:
        """One run of the ramp task."""

    def needs_task(self) -> bool:
        """True while the next runs of the task must not be skipped."""


class Engine:
    """``FastAccelStepperEngine``: connect steppers to step pins and run the ramp task."""

    def __init__(self, backend: Backend) -> None:
        self.backend = backend
        self.profile: Profile = backend.profile
        self._steppers: list[Stepper | None] = [None] * self.profile.max_steppers
        self._stepper_cnt = 0
        self._external_call: ExternalPinCall | None = None
        self._debug_led_pin = PIN_UNDEFINED
        self._debug_led_cnt = 0
        self._debug_led_half_period = self.profile.led_half_period
        self._initialised = False
        self.ramp_abort_listener: Callable[[Stepper, AqeResult, object], None] | None = None
        self.task_runs = 0
        self.task_hooks: list[TaskHook] = []
        # queues, multiplexer slots, pulse counters, timers: who has what (fas.allocate)
        self.allocator = Allocator(self.profile)
        self._task_rate_ms = self.profile.fill_period_ticks // self.profile.ticks_per_ms
        self.cpu_core = 255
        self.i2s_mux_pins: tuple[int, int, int] | None = None
        self.sync = SyncQueue(self)  # synchronized outputs and the motion behind them
        self.outputs = UserOutputs(self)  # Dout0..3, Aout0..3 (seed 003)
        self._shared: dict[str, object] = {}  # see shared()
        # each stepper's queue and planner in use, and the planners' fills in the order of
        # the periodic task (see planners_changed)
        self._motion: list[tuple[StepperQueue, Planner]] = []
        self._fills: list[Callable[[], int]] = []

    def init(self, cpu_core: int = 255) -> None:
        """Start the periodic ramp task (call once, as ``engine.init()`` upstream).

        ``cpu_core`` (ESP32): 0 or 1 pins the stepper task to that core; it changes no
        timing in the simulation."""
        if cpu_core != 255 and not self.profile.cpu_affinity:
            raise UnsupportedError("init(cpu_core)", self.profile.name, "on ESP32")
        if not self._initialised:
            self._initialised = True
            self.cpu_core = cpu_core
            self.backend.attach_engine(self)

    # ------------------------------------------------------ task rate (ESP32, Pico)
    def task_rate(self, delay_ms: int) -> None:
        """The stepper task's pause between two runs, in ms (default 4)."""
        if not self.profile.task_rate_change:
            raise UnsupportedError("task_rate()", self.profile.name, "on ESP32 and the Pico")
        self._task_rate_ms = delay_ms & 0xFF
        # a pause of 0 lets the task run again at the next scheduler tick (1 ms)
        self.backend.set_task_period(max(1, self._task_rate_ms) * self.profile.ticks_per_ms)

    def get_task_rate(self) -> int:
        """Upstream's ``_task_rate()``: the configured pause in ms."""
        if not self.profile.task_rate_change:
            raise UnsupportedError("_task_rate()", self.profile.name, "on ESP32 and the Pico")
        return self._task_rate_ms

    # -------------------------------------------------------- I2S multiplexer (ESP32)
    def _need_i2s(self, call: str) -> None:
        if not self.profile.has_i2s:
            raise UnsupportedError(call, self.profile.name, "on ESP32 with ESP-IDF >= 5.3")

    def init_i2s_mux(self, data_pin: int, bclk_pin: int, ws_pin: int) -> bool:
        """Make one I2S controller a 32-slot output multiplexer (shift registers on
        data/bclk/ws).  Slots are then pins ``PIN_I2S_FLAG | slot`` for steppers
        (step) and for direction and enable signals."""
        self._need_i2s("init_i2s_mux()")
        if not self.allocator.claim_i2s_mux():
            return False
        self.i2s_mux_pins = (data_pin, bclk_pin, ws_pin)
        return True

    def i2s_mux_set_bit(self, slot: int, value: bool) -> None:
        """Drive one slot of the multiplexer (the backend sees it as pin
        ``PIN_I2S_FLAG | slot``; direction changes of mux steppers land there too)."""
        self._need_i2s("i2s_mux_set_bit()")
        if self.i2s_mux_pins is None or not 0 <= slot < 32:
            return
        self.backend.write_pin(PIN_I2S_FLAG | slot, 1 if value else 0)

    def i2s_mux_get_bit(self, slot: int) -> bool:
        self._need_i2s("i2s_mux_get_bit()")
        if self.i2s_mux_pins is None or not 0 <= slot < 32:
            return False
        return bool(self.backend.read_pin(PIN_I2S_FLAG | slot))

    def write_output(self, pin: int, level: int) -> None:
        """Drive a direction/enable output: a GPIO, or a slot of the I2S multiplexer."""
        if self.profile.has_i2s and pin & PIN_I2S_FLAG and pin != PIN_UNDEFINED:
            self.i2s_mux_set_bit(pin & 0x1F, bool(level))
        else:
            self.backend.write_pin(pin, level)

    def claim_mux_slot(self, slot: int) -> bool:
        return self.allocator.claim_mux_slot(slot)

    def claim_pulse_counter(self, unit: int, owner: object) -> bool:
        """A pcnt unit for ``attach_to_pulse_counter`` of ``owner`` (see
        :meth:`fas.allocate.Allocator.claim_pulse_counter`)."""
        return self.allocator.claim_pulse_counter(unit, owner)

    def shared(self, key: str, make: Callable[[], T]) -> T:
        """One object per engine and ``key``, made by ``make()`` on first use - state a
        kind of planner shares between the steppers that use it (QuickStep's timer)."""
        if key not in self._shared:
            self._shared[key] = make()
        # the object make() made for this key: a T (one store holds every kind)
        return self._shared[key]  # type: ignore[return-value]

    # ------------------------------------------------- idle periodic task
    def quiescent_tasks(self) -> int | None:
        """How many following runs of the periodic task would do nothing at all.

        0 while any stepper moves, plans or counts down to auto-disable; otherwise
        the runs until the debug LED toggles (None: unbounded).  A backend may skip
        those runs and credit them with :meth:`credit_skipped_tasks`.
        """
        for s in self._steppers:
            if s is not None and s.needs_task():
                return 0
        for hook in self.task_hooks:
            if hook.needs_task():
                return 0
        if self.sync.active():
            return 0
        if self._debug_led_pin == PIN_UNDEFINED:
            return None
        half = self._debug_led_half_period
        to_toggle = half - (self._debug_led_cnt % half)
        return max(0, to_toggle - 1)

    def may_stop_without_channel(self) -> bool:
        """Is a stepper running whose queue is not being executed (its planner has motion
        to plan or its queue holds entries)?  Only such a stepper can start or stop in
        a run of the periodic task; the others stop when their channel does."""
        for q, planner in self._motion:
            if not q.is_running() and (planner.is_active() or not q.is_queue_empty()):
                return True
        return False

    def credit_skipped_tasks(self, n: int) -> None:
        if n > 0:
            self._debug_led_cnt += n
            self.task_runs += n

    def add_task_hook(self, hook: TaskHook) -> None:
        """Run ``hook`` in every periodic task, after the steppers have planned."""
        if hook not in self.task_hooks:
            self.task_hooks.append(hook)
        self.kick()

    def remove_task_hook(self, hook: TaskHook) -> None:
        if hook in self.task_hooks:
            self.task_hooks.remove(hook)

    def kick(self) -> None:
        """A stepper got work: the periodic task must run again from its next slot."""
        self.backend.wake_task()

    def queues_idle(self) -> None:
        """The backend: a queue ran dry or a synchronized output was made (fas.sync)."""
        if self.sync.active():
            self.sync.progress()

    # ------------------------------------------------------------ steppers
    def stepper_connect_to_pin(self, step_pin: int,
                               driver: int = FasDriver.DONT_CARE) -> Stepper | None:
        """A stepper on ``step_pin``, or None when the pin or the queues are unavailable.

        ``driver`` (ESP32 builds with several driver types): the step generator to use;
        ``DRIVER_DONT_CARE`` takes the first that is free (see :mod:`fas.allocate`)."""
        if driver != FasDriver.DONT_CARE and not self.profile.driver_select:
            raise UnsupportedError("stepper_connect_to_pin(pin, driver)", self.profile.name,
                                   "on ESP32 builds with two or more driver types")
        if not self._initialised:
            self.init()
        got = self.allocator.allocate(step_pin, driver)
        if got is None:
            return None
        idx = got.index
        queue = StepperQueue(idx, self.profile, self.backend, step_pin)
        stepper = Stepper(self, queue, got.pool)
        self._steppers[idx] = stepper
        self._stepper_cnt += 1
        self.planners_changed()
        if got.pool is not None:
            queue.max_speed_in_ticks = got.pool.max_speed_ticks
            queue.position_in_command = got.pool.position_in_command
        else:  # AVR: the step interrupts share the CPU, the limit follows the count
            max_ticks = self.profile.max_speed_ticks(self._stepper_cnt)
            for s in self._steppers:
                if s is not None:
                    s.queue.max_speed_in_ticks = max_ticks
        return stepper

    def planners_changed(self) -> None:
        """A stepper swapped its planner: planners that follow other steppers' queues
        (``Planner.fills_late``) fill after every other one in the periodic task."""
        steppers = [s for s in self._steppers if s is not None]
        self._motion = [(s.queue, s.planner) for s in steppers]
        self._fills = ([s.planner.fill for s in steppers if not s.planner.fills_late]
                       + [s.planner.fill for s in steppers if s.planner.fills_late])

    @property
    def steppers(self) -> list[Stepper]:
        return [s for s in self._steppers if s is not None]

    def stepper(self, index: int) -> Stepper | None:
        return self._steppers[index] if 0 <= index < len(self._steppers) else None

    # ---------------------------------------------------------------- pins
    def set_external_call_for_pin(self, func: ExternalPinCall | None) -> None:
        """Callback ``func(pin, value) -> level`` for pins or'ed with PIN_EXTERNAL_FLAG."""
        self._external_call = func

    def call_external_pin(self, pin: int, value: int) -> int:
        if self._external_call is None:
            return value
        return HIGH if self._external_call(pin, value) else LOW

    @property
    def has_external_call(self) -> bool:
        return self._external_call is not None

    def set_debug_led(self, led_pin: int) -> None:
        self._debug_led_pin = led_pin
        self.backend.write_pin(led_pin, LOW)

    def is_dir_pin_busy(self, dir_pin: int, except_queue: int) -> bool:
        for s in self._steppers:
            if (s is not None and s.queue.index != except_queue
                    and s.get_direction_pin() == dir_pin and s.is_queue_running()):
                return True
        return False

    def report_ramp_abort(self, stepper: Stepper, res: AqeResult, cmd: object) -> None:
        if self.ramp_abort_listener is not None:
            self.ramp_abort_listener(stepper, res, cmd)

    # ------------------------------------------------------- periodic task
    def manage_steppers(self) -> int:
        """One run of the ramp task; returns the number of commands generated."""
        self.task_runs += 1
        if self._debug_led_pin != PIN_UNDEFINED:
            self._debug_led_cnt += 1
            if self._debug_led_cnt == self._debug_led_half_period:
                self.backend.write_pin(self._debug_led_pin, HIGH)
            if self._debug_led_cnt == 2 * self._debug_led_half_period:
                self.backend.write_pin(self._debug_led_pin, LOW)
                self._debug_led_cnt = 0
        generated = 0
        steppers = self._steppers
        for fill in self._fills:  # by stepper number; planners that follow other
            generated += fill()  # steppers' queues last (fas.gear)
        for hook in self.task_hooks:
            hook.run_task()
        for i, s in enumerate(steppers):
            # (the counter first: auto_disable_due() asks it first, and the stepper's
            # is_running only at 1 - most runs call neither method)
            if s is None or s.drive.auto_disable_delay_counter != 1 or not s.auto_disable_due():
                continue
            high_pin = s.get_enable_pin_high_active()
            low_pin = s.get_enable_pin_low_active()
            agree = True
            for j, other in enumerate(steppers):
                if (i != j and other is not None
                        and (other.uses_enable_pin(high_pin) or other.uses_enable_pin(low_pin))
                        and not other.agrees_to_auto_disable()):
                    agree = False
                    break
            if agree:
                for current in steppers:
                    if current is not None and (current.uses_enable_pin(high_pin)
                                                or current.uses_enable_pin(low_pin)):
                        current.disable_outputs()
        for s in steppers:
            if s is not None and s.drive.auto_disable_delay_counter > 1:
                s.count_down_auto_disable()  # (which counts down from 2 only)
        if self.sync.active():
            self.sync.progress()
        return generated

    def planning_queues(self) -> list[StepperQueue]:
        """The queues whose stepper has motion still to plan: the others' fill returns at
        its first check in the next run of the periodic task."""
        out = []  # (a loop: a comprehension is a call of its own, every task)
        for q, planner in self._motion:
            if planner.is_active():
                out.append(q)
        return out
