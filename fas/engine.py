"""The engine: a factory of steppers and the periodic task that feeds their queues."""

from __future__ import annotations

from typing import Callable

from .arch import Profile
from .backend import Backend
from .codes import HIGH, LOW, PIN_UNDEFINED, AqeResult
from .outputs import UserOutputs
from .queue import StepperQueue
from .stepper import Stepper
from .sync import SyncQueue

ExternalPinCall = Callable[[int, int], int]


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
        self._debug_led_half_period = max(1, self.profile.ticks_per_s // 65536 // 2)
        self._initialised = False
        self.ramp_abort_listener: Callable[[Stepper, AqeResult, object], None] | None = None
        self.task_runs = 0
        self.sync = SyncQueue(self)  # synchronized outputs and the motion behind them
        self.outputs = UserOutputs(self)  # Dout0..3, Aout0..3 (seed 003)
        self.quickstep_clock = None  # fas.quickstep.clock.QuickStepClock, made on first use

    def init(self) -> None:
        """Start the periodic ramp task (call once, as ``engine.init()`` upstream)."""
        if not self._initialised:
            self._initialised = True
            self.backend.attach_engine(self)

    # ------------------------------------------------- idle periodic task
    def quiescent_tasks(self) -> int | None:
        """How many following runs of the periodic task would do nothing at all.

        0 while any stepper moves, plans or counts down to auto-disable; otherwise
        the runs until the debug LED toggles (None: unbounded).  A backend may skip
        those runs and credit them with :meth:`credit_skipped_tasks`.
        """
        for s in self._steppers:
            if s is not None and s._needs_task():
                return 0
        if self.sync.active():
            return 0
        if self._debug_led_pin == PIN_UNDEFINED:
            return None
        half = self._debug_led_half_period
        to_toggle = half - (self._debug_led_cnt % half)
        return max(0, to_toggle - 1)

    def credit_skipped_tasks(self, n: int) -> None:
        if n > 0:
            self._debug_led_cnt += n
            self.task_runs += n

    def kick(self) -> None:
        """A stepper got work: the periodic task must run again from its next slot."""
        self.backend.wake_task()

    def queues_idle(self) -> None:
        """The backend: a queue ran dry or a synchronized output was made (fas.sync)."""
        if self.sync.active():
            self.sync.progress()

    # ------------------------------------------------------------ steppers
    def stepper_connect_to_pin(self, step_pin: int) -> Stepper | None:
        """A stepper on ``step_pin``, or None when the pin or the queues are unavailable."""
        if not self._initialised:
            self.init()
        idx = self.profile.queue_for_step_pin(step_pin)
        if idx is None:
            return None
        if self.profile.fixed_queue_mapping:
            if self._steppers[idx] is not None:
                return None
        else:
            if self._stepper_cnt >= self.profile.max_steppers:
                return None
            if any(s is not None and s.get_step_pin() == step_pin for s in self._steppers):
                return None
            if len(set(self.profile.step_pin_groups)) > 1:
                # one channel per pin group (SAM): the group must be free
                if self._steppers[idx] is not None:
                    return None
            else:
                idx = self._steppers.index(None)
        queue = StepperQueue(idx, self.profile, self.backend, step_pin)
        stepper = Stepper(self, queue)
        self._steppers[idx] = stepper
        self._stepper_cnt += 1
        max_ticks = self.profile.max_speed_ticks(self._stepper_cnt)
        for s in self._steppers:
            if s is not None:
                s.queue.max_speed_in_ticks = max_ticks
        return stepper

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
            if s is not None and s.queue.index != except_queue:
                if s.get_direction_pin() == dir_pin and s.is_queue_running():
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
        for s in steppers:
            if s is not None:
                generated += s.fill_queue()
        for i, s in enumerate(steppers):
            if s is None or not s._need_auto_disable():
                continue
            high_pin = s.get_enable_pin_high_active()
            low_pin = s.get_enable_pin_low_active()
            agree = True
            for j, other in enumerate(steppers):
                if i != j and other is not None:
                    if (other._uses_auto_enable_pin(high_pin)
                            or other._uses_auto_enable_pin(low_pin)):
                        if not other._agree_with_auto_disable():
                            agree = False
                            break
            if agree:
                for current in steppers:
                    if current is not None and (current._uses_auto_enable_pin(high_pin)
                                                or current._uses_auto_enable_pin(low_pin)):
                        current.disable_outputs()
        for s in steppers:
            if s is not None:
                s._update_auto_disable()
        if self.sync.active():
            self.sync.progress()
        return generated
