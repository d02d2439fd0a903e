"""The stepper driver's direction and enable inputs, and writing one command.

A :class:`~fas.stepper.Stepper` keeps one :class:`Drive`: the direction pin (its
polarity, the pause a direction change needs, shared and external pins), the enable
pins with auto enable and its delays, and :meth:`Drive.write` - one command into
the command queue with what the driver needs before it: switched on (and the enable
delay waited) under auto enable, the pauses around a direction change, an external
direction pin set first.  ``write`` is what a stepper lends its planner
(:attr:`fas.planner.PlannerHost.write`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from .codes import (
    HIGH,
    LOW,
    PIN_EXTERNAL_FLAG,
    PIN_I2S_FLAG,
    PIN_UNDEFINED,
    AqeResult,
    DelayResult,
    FasDriver,
)
from .errors import UnsupportedError
from .queue import AQE_OK, StepperQueue

if TYPE_CHECKING:  # pragma: no cover
    from .arch import DriverPool
    from .engine import Engine


class Drive:
    """Direction and enable of one stepper's driver (see the module text).

    ``queue()`` is the stepper's queue in use (a planner may run one of its own),
    ``commands`` its command queue, ``is_running()`` whether it moves."""

    def __init__(self, engine: Engine, pool: DriverPool | None, commands: StepperQueue,
                 queue: Callable[[], StepperQueue], is_running: Callable[[], bool]) -> None:
        self._engine = engine
        self._profile = engine.profile
        self.pool = pool
        self._commands = commands
        self._queue = queue
        self._is_running = is_running
        self.dir_pin = PIN_UNDEFINED
        self.dir_high_counts_up = True
        self.dir_change_delay_ticks = 0
        self.enable_pin_low_active = PIN_UNDEFINED
        self.enable_pin_high_active = PIN_UNDEFINED
        self.auto_enable = False
        self.on_delay_ticks = 0
        self.off_delay_count = 1
        self.auto_disable_delay_counter = 0
        self.pending_external_dir: int | None = None

    # ------------------------------------------------------------ direction
    def set_direction_pin(self, dir_pin: int, dir_high_counts_up: bool,
                          dir_change_delay_us: int) -> None:
        p = self._profile
        engine = self._engine
        if dir_pin != PIN_UNDEFINED and dir_pin & PIN_EXTERNAL_FLAG and not p.external_dir_pin:
            raise UnsupportedError("an external direction pin (PIN_EXTERNAL_FLAG)",
                                   p.name, "on ESP32 and AVR except ATmega32U4")
        self.dir_pin = dir_pin
        self.dir_high_counts_up = bool(dir_high_counts_up)
        if dir_pin != PIN_UNDEFINED:
            level = HIGH if dir_high_counts_up else LOW
            if dir_pin & PIN_EXTERNAL_FLAG:
                engine.call_external_pin(dir_pin, level)
            else:
                if (p.has_i2s and dir_pin & PIN_I2S_FLAG and self.pool is not None
                        and self.pool.driver == FasDriver.I2S_MUX):
                    engine.claim_mux_slot(dir_pin & 0x1F)
                engine.write_output(dir_pin, level)
        q = self._queue()
        q.dir_pin = dir_pin
        q.dir_high_counts_up = bool(dir_high_counts_up)
        if dir_change_delay_us != 0:
            us = min(max(dir_change_delay_us, p.min_dir_delay_us), p.max_dir_delay_us)
            self.dir_change_delay_ticks = p.us_to_ticks(us)
        else:
            self.dir_change_delay_ticks = 0

    # --------------------------------------------------------------- enable
    def set_enable_pin(self, enable_pin: int, low_active_enables_stepper: bool) -> None:
        engine = self._engine
        if low_active_enables_stepper:
            self.enable_pin_low_active = enable_pin
            if enable_pin != PIN_UNDEFINED:
                if enable_pin & PIN_EXTERNAL_FLAG:
                    engine.call_external_pin(enable_pin, HIGH)
                else:
                    engine.write_output(enable_pin, HIGH)
                    if self.enable_pin_high_active == enable_pin:
                        self.enable_pin_high_active = PIN_UNDEFINED
        else:
            self.enable_pin_high_active = enable_pin
            if enable_pin != PIN_UNDEFINED:
                if enable_pin & PIN_EXTERNAL_FLAG:
                    engine.call_external_pin(enable_pin, LOW)
                else:
                    engine.write_output(enable_pin, LOW)
                    if self.enable_pin_low_active == enable_pin:
                        self.enable_pin_low_active = PIN_UNDEFINED

    def set_auto_enable(self, auto_enable: bool) -> None:
        was = self.auto_enable
        self.auto_enable = bool(auto_enable)
        if auto_enable and self.off_delay_count == 0:
            self.off_delay_count = 1
        # steps queued before are still to come: auto enable means the driver is on for
        # them (upstream waits for the next queued command to switch it on)
        if (auto_enable and not was and self._queue().has_steps_in_queue()
                and self.enable_outputs()):
            self.auto_disable_delay_counter = self.off_delay_count
            self._engine.kick()

    def set_delay_to_enable(self, delay_us: int) -> DelayResult:
        p = self._profile
        delay_ticks = p.us_to_ticks(delay_us & 0xFFFFFFFF)
        if 0 < delay_ticks < p.min_cmd_ticks:
            return DelayResult.TOO_LOW
        if delay_ticks > p.max_on_delay_ticks:
            return DelayResult.TOO_HIGH
        self.on_delay_ticks = delay_ticks
        return DelayResult.OK

    def set_delay_to_disable(self, delay_ms: int) -> None:
        delay_ms &= 0xFFFF
        delay_count = delay_ms // self._profile.delay_ms_base
        if delay_ms > 0 and delay_count < 2:
            delay_count = 2
        self.off_delay_count = max(delay_count, 1)

    def _set_enable_pin_state(self, pin: int, level: int) -> bool:
        if pin == PIN_UNDEFINED:
            return True
        if pin & PIN_EXTERNAL_FLAG:
            return self._engine.call_external_pin(pin, level) == level
        self._engine.write_output(pin, level)
        return True

    def enable_outputs(self) -> bool:
        a = self._set_enable_pin_state(self.enable_pin_low_active, LOW)
        b = self._set_enable_pin_state(self.enable_pin_high_active, HIGH)
        return a and b

    def disable_outputs(self) -> bool:
        if self._is_running() and self.auto_enable:
            return False
        a = self._set_enable_pin_state(self.enable_pin_low_active, HIGH)
        b = self._set_enable_pin_state(self.enable_pin_high_active, LOW)
        disabled = a and b
        if disabled:
            self.auto_disable_delay_counter = 0
        return disabled

    def outputs_enabled(self) -> bool | None:
        """Level of the driver's enable input(s) as seen on the pins (None: no pin)."""
        pins = []
        backend = self._engine.backend
        low, high = self.enable_pin_low_active, self.enable_pin_high_active
        if low != PIN_UNDEFINED and not low & PIN_EXTERNAL_FLAG:
            pins.append(backend.read_pin(low) == LOW)
        if high != PIN_UNDEFINED and not high & PIN_EXTERNAL_FLAG:
            pins.append(backend.read_pin(high) == HIGH)
        if not pins:
            return None
        return all(pins)

    # --------------------------------------------------------- auto disable
    def count_down_auto_disable(self) -> None:
        if self.auto_disable_delay_counter > 1 and not self._is_running():
            self.auto_disable_delay_counter -= 1

    def agrees_to_auto_disable(self) -> bool:
        return not self._is_running() and self.auto_disable_delay_counter <= 1

    def auto_disable_due(self) -> bool:
        return self.auto_disable_delay_counter == 1 and not self._is_running()

    def uses_enable_pin(self, pin: int) -> bool:
        return pin != PIN_UNDEFINED and pin in (self.enable_pin_high_active,
                                                self.enable_pin_low_active)

    def start_delay(self) -> int:
        """Before a planner writes a queue of its own, idle: auto enable switches the
        driver on; returns the delay (ticks) the first step must wait for it."""
        q = self._queue()
        if q.is_running() or not q.is_queue_empty():
            return 0
        if self.auto_enable and self.auto_disable_delay_counter == 0:
            self.enable_outputs()
            return self.on_delay_ticks
        return 0

    def command_written(self) -> None:
        """A planner wrote a queue of its own: auto disable counts from now."""
        if self.auto_enable:
            self.auto_disable_delay_counter = self.off_delay_count
        self._engine.kick()

    # -------------------------------------------------------------- writing
    def write(self, ticks: int | None, steps: int = 0, count_up: bool = True,
              start: bool = True) -> AqeResult:
        """Write one command into the command queue, after what auto enable and a
        direction change need (``ticks`` None: only start the queue)."""
        q = self._commands
        if ticks is None:
            return q.add_queue_entry(None, start=start)
        if not (0 <= steps <= 255) or not (0 <= ticks <= 65535):
            return AqeResult.ERROR_TICKS_TOO_LOW
        if ticks < q.max_speed_in_ticks:
            return AqeResult.ERROR_TICKS_TOO_LOW
        dir_pin = self.dir_pin
        if dir_pin != PIN_UNDEFINED:
            if not q.is_running() and self._engine.is_dir_pin_busy(dir_pin, q.index):
                return AqeResult.DIR_PIN_IS_BUSY
        elif not count_up:
            return AqeResult.ERROR_NO_DIR_PIN_TO_TOGGLE

        res = AQE_OK
        if self.auto_enable and self.auto_disable_delay_counter == 0:
            if not self.enable_outputs():
                return AqeResult.WAIT_FOR_ENABLE_PIN_ACTIVE
            self._engine.backend.auto_enabled()
            if self.on_delay_ticks > 0:
                delay = self.on_delay_ticks
                if delay < self.dir_change_delay_ticks and q.queue_end_count_up != count_up:
                    delay = self.dir_change_delay_ticks
                while delay > 0:
                    half = delay >> 1
                    if half > 65535:
                        chunk = 65535
                    elif half < 32768:
                        chunk = delay & 0xFFFF
                    else:
                        chunk = half
                    q.add_queue_entry(chunk, 0, count_up, start=False, bare=True)
                    delay -= chunk
                res = q.add_queue_entry(None, start=start)
                if res != AQE_OK:
                    return res

        if dir_pin != PIN_UNDEFINED and q.queue_end_count_up != count_up:  # a direction change
            if dir_pin & PIN_EXTERNAL_FLAG:
                if not self._set_external_direction(count_up):
                    res = q.add_queue_entry(self._profile.us_to_ticks(2000), 0, count_up,
                                            start=start)
                    return AqeResult.DIR_PIN_2MS_PAUSE_ADDED if res == AQE_OK else res
            elif steps != 0:
                pool = self.pool
                before_delay = pool.before_dir_change_ticks if pool is not None else 0
                after_delay = self.dir_change_delay_ticks
                if pool is not None:
                    after_delay = max(after_delay, pool.after_dir_change_ticks)
                if q.last_command_ticks >= before_delay:
                    before_delay = 0  # the last command already lasts long enough
                needed = 1 + (before_delay > 0) + (after_delay > 0)
                if q.queue_entries() >= q.queue_len - needed:
                    return AqeResult.DIR_PIN_IS_BUSY
                for delay in (before_delay, after_delay):
                    if delay > 0:
                        res = q.add_queue_entry(max(delay, self._profile.min_cmd_ticks), 0,
                                                count_up, start=start)
                        if res != AQE_OK:
                            return res

        res = q.add_queue_entry(ticks, steps, count_up, start)
        if res == AQE_OK and self.auto_enable:
            self.auto_disable_delay_counter = self.off_delay_count
        self._engine.backend.wake_task()  # (Engine.kick, written out: every command)
        return res

    def _set_external_direction(self, count_up: bool) -> bool:
        """An external direction pin towards ``count_up``: False while it is not there
        yet (the queue still has steps the other way, or the callback refused)."""
        engine = self._engine
        if self.pending_external_dir is not None:
            desired = self.pending_external_dir
            if engine.call_external_pin(self.dir_pin, desired) == desired:
                self.pending_external_dir = None
            if self.pending_external_dir is not None:
                return False
        q = self._commands
        if q.queue_end_count_up != count_up:
            if q.has_steps_in_queue():
                return False
            desired = HIGH if count_up == self.dir_high_counts_up else LOW
            if engine.call_external_pin(self.dir_pin, desired) != desired:
                self.pending_external_dir = desired
                return False
        return True
