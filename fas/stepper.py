"""One stepper: the public API of FastAccelStepper in snake_case.

Movement goes through the ramp generator (``move``, ``move_to``, ``run_forward`` …)
or straight into the command queue (``add_queue_entry``).  This class also does what
sits between the two: auto enable with its delays, the pause before the first step
after a direction change, shared direction pins, external (callback) pins.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .backend import PulseCounter
from .codes import (
    HIGH,
    LOW,
    PIN_EXTERNAL_FLAG,
    PIN_I2S_FLAG,
    PIN_UNDEFINED,
    RAMP_DIRECTION_COUNT_UP,
    TICKS_FOR_STOPPED_MOTOR,
    AqeResult,
    DelayResult,
    FasDriver,
    MoveResult,
)
from .errors import UnsupportedError
from .queue import AQE_OK, StepperQueue, i32
from .quickstep.clock import QsConfigResult
from .ramp.generator import RampGenerator
from .timed import TimedMove, move_timed

if TYPE_CHECKING:  # pragma: no cover
    from .arch import DriverPool
    from .engine import Engine
    from .quickstep.planner import QuickStepPlanner

PLANNER_FAS = 0  # FastAccelStepper's ramp generator (default)
PLANNER_QUICKSTEP = 1  # QuickStep's plateau orders (fas.quickstep)

DRIVER_NAMES = {FasDriver.MCPWM_PCNT: "MCPWM_PCNT", FasDriver.RMT: "RMT",
                FasDriver.I2S_DIRECT: "I2S_DIRECT", FasDriver.I2S_MUX: "I2S_MUX"}


class Stepper:
    def __init__(self, engine: Engine, queue: StepperQueue,
                 pool: DriverPool | None = None) -> None:
        profile = engine.profile
        self._engine = engine
        self._profile = profile
        self._queue = queue
        self._pool = pool
        self._step_pin = queue.step_pin
        self._dir_pin = PIN_UNDEFINED
        self._dir_high_counts_up = True
        self._dir_change_delay_ticks = 0
        self._enable_pin_low_active = PIN_UNDEFINED
        self._enable_pin_high_active = PIN_UNDEFINED
        self._auto_enable = False
        self._on_delay_ticks = 0
        self._off_delay_count = 1
        self._auto_disable_delay_counter = 0
        self._forward_planning_in_ticks = profile.ticks_per_s // 50
        self._pending_external_dir: int | None = None
        self._pulse_counter: PulseCounter | None = None
        self._rg = RampGenerator(profile.ticks_per_s, profile.min_cmd_ticks,
                                 profile.log2_ticks_per_s, profile.log2_ticks_per_s_div_sqrt2,
                                 profile.log2_accel_factor)
        self.fill_calls = 0
        self.commands_generated = 0
        # ramp state after each planned command, by the write index that follows it:
        # the points a deep queue (serial backend) can be cut back to
        self._snapshots: list | None = [None] * 256 if queue.channel.supports_cut else None
        self._fas_queue = queue  # FastAccelStepper's command queue (kept while QuickStep runs)
        self._qs: QuickStepPlanner | None = None  # the QuickStep planner, when selected

    # ----------------------------------------------------------------- pins
    @property
    def queue(self) -> StepperQueue:
        return self._queue

    @property
    def index(self) -> int:
        return self._queue.index

    def get_step_pin(self) -> int:
        return self._step_pin

    def set_direction_pin(self, dir_pin: int, dir_high_counts_up: bool = True,
                          dir_change_delay_us: int = 0) -> None:
        if (dir_pin != PIN_UNDEFINED and dir_pin & PIN_EXTERNAL_FLAG
                and not self._profile.external_dir_pin):
            raise UnsupportedError("an external direction pin (PIN_EXTERNAL_FLAG)",
                                   self._profile.name, "on ESP32 and AVR except ATmega32U4")
        self._dir_pin = dir_pin
        self._dir_high_counts_up = bool(dir_high_counts_up)
        if dir_pin != PIN_UNDEFINED:
            level = HIGH if dir_high_counts_up else LOW
            if dir_pin & PIN_EXTERNAL_FLAG:
                self._engine.call_external_pin(dir_pin, level)
            else:
                if (self._profile.has_i2s and dir_pin & PIN_I2S_FLAG
                        and self.driver_kind() == FasDriver.I2S_MUX):
                    self._engine.claim_mux_slot(dir_pin & 0x1F)
                self._engine.write_output(dir_pin, level)
        self._queue.dir_pin = dir_pin
        self._queue.dir_high_counts_up = bool(dir_high_counts_up)
        p = self._profile
        if dir_change_delay_us != 0:
            us = min(max(dir_change_delay_us, p.min_dir_delay_us), p.max_dir_delay_us)
            self._dir_change_delay_ticks = p.us_to_ticks(us)
        else:
            self._dir_change_delay_ticks = 0

    def get_direction_pin(self) -> int:
        return self._dir_pin

    def direction_pin_high_counts_up(self) -> bool:
        return self._dir_high_counts_up

    def set_enable_pin(self, enable_pin: int, low_active_enables_stepper: bool = True) -> None:
        if low_active_enables_stepper:
            self._enable_pin_low_active = enable_pin
            if enable_pin != PIN_UNDEFINED:
                if enable_pin & PIN_EXTERNAL_FLAG:
                    self._engine.call_external_pin(enable_pin, HIGH)
                else:
                    self._engine.write_output(enable_pin, HIGH)
                    if self._enable_pin_high_active == enable_pin:
                        self._enable_pin_high_active = PIN_UNDEFINED
        else:
            self._enable_pin_high_active = enable_pin
            if enable_pin != PIN_UNDEFINED:
                if enable_pin & PIN_EXTERNAL_FLAG:
                    self._engine.call_external_pin(enable_pin, LOW)
                else:
                    self._engine.write_output(enable_pin, LOW)
                    if self._enable_pin_low_active == enable_pin:
                        self._enable_pin_low_active = PIN_UNDEFINED

    def get_enable_pin_high_active(self) -> int:
        return self._enable_pin_high_active

    def get_enable_pin_low_active(self) -> int:
        return self._enable_pin_low_active

    def set_auto_enable(self, auto_enable: bool) -> None:
        was = self._auto_enable
        self._auto_enable = bool(auto_enable)
        if auto_enable and self._off_delay_count == 0:
            self._off_delay_count = 1
        if auto_enable and not was and self._queue.has_steps_in_queue():
            # steps queued before are still to come: auto enable means the driver is on
            # for them (upstream waits for the next queued command to switch it on)
            if self.enable_outputs():
                self._auto_disable_delay_counter = self._off_delay_count
                self._engine.kick()

    def get_auto_enable(self) -> bool:
        """Is auto enable on (not in upstream's API; a front end that switches the
        drivers itself for a while restores it afterwards)."""
        return self._auto_enable

    def set_delay_to_enable(self, delay_us: int) -> DelayResult:
        delay_ticks = self._profile.us_to_ticks(delay_us & 0xFFFFFFFF)
        if 0 < delay_ticks < self._profile.min_cmd_ticks:
            return DelayResult.TOO_LOW
        if delay_ticks > self._profile.max_on_delay_ticks:
            return DelayResult.TOO_HIGH
        self._on_delay_ticks = delay_ticks
        return DelayResult.OK

    def get_delay_to_enable_ticks(self) -> int:
        """The enable delay set with :meth:`set_delay_to_enable` (not in upstream's API:
        a front end that enables drivers itself waits this long before a step)."""
        return self._on_delay_ticks

    def get_dir_change_delay_ticks(self) -> int:
        """The direction-change delay of :meth:`set_direction_pin` (0: none)."""
        return self._dir_change_delay_ticks

    def set_delay_to_disable(self, delay_ms: int) -> None:
        delay_ms &= 0xFFFF
        delay_count = delay_ms // self._profile.delay_ms_base
        if delay_ms > 0 and delay_count < 2:
            delay_count = 2
        self._off_delay_count = max(delay_count, 1)

    def _set_enable_pin_state(self, pin: int, level: int) -> bool:
        if pin == PIN_UNDEFINED:
            return True
        if pin & PIN_EXTERNAL_FLAG:
            return self._engine.call_external_pin(pin, level) == level
        self._engine.write_output(pin, level)
        return True

    def enable_outputs(self) -> bool:
        a = self._set_enable_pin_state(self._enable_pin_low_active, LOW)
        b = self._set_enable_pin_state(self._enable_pin_high_active, HIGH)
        return a and b

    def disable_outputs(self) -> bool:
        if self.is_running() and self._auto_enable:
            return False
        a = self._set_enable_pin_state(self._enable_pin_low_active, HIGH)
        b = self._set_enable_pin_state(self._enable_pin_high_active, LOW)
        disabled = a and b
        if disabled:
            self._auto_disable_delay_counter = 0
        return disabled

    def outputs_enabled(self) -> bool | None:
        """Level of the driver's enable input(s) as seen on the pins (None: no pin)."""
        pins = []
        backend = self._engine.backend
        if self._enable_pin_low_active != PIN_UNDEFINED and not (
                self._enable_pin_low_active & PIN_EXTERNAL_FLAG):
            pins.append(backend.read_pin(self._enable_pin_low_active) == LOW)
        if self._enable_pin_high_active != PIN_UNDEFINED and not (
                self._enable_pin_high_active & PIN_EXTERNAL_FLAG):
            pins.append(backend.read_pin(self._enable_pin_high_active) == HIGH)
        if not pins:
            return None
        return all(pins)

    # ------------------------------------------------------------- auto disable
    def _update_auto_disable(self) -> None:
        if self._auto_disable_delay_counter > 1 and not self.is_running():
            self._auto_disable_delay_counter -= 1

    def _agree_with_auto_disable(self) -> bool:
        return not self.is_running() and self._auto_disable_delay_counter <= 1

    def _need_auto_disable(self) -> bool:
        return self._auto_disable_delay_counter == 1 and not self.is_running()

    def _needs_task(self) -> bool:
        if self._qs is not None and self._qs.has_orders():
            return True
        return (self._auto_disable_delay_counter > 0 or self._rg.is_ramp_generator_active()
                or self._rg.force_immediate_stop or self._queue.is_running()
                or not self._queue.is_queue_empty())

    def _uses_auto_enable_pin(self, pin: int) -> bool:
        return pin != PIN_UNDEFINED and pin in (self._enable_pin_high_active,
                                                self._enable_pin_low_active)

    # ------------------------------------------------------------- position
    def get_current_position(self) -> int:
        return self._queue.current_position()

    def set_current_position(self, new_pos: int) -> None:
        delta = i32(new_pos - self.get_current_position())
        if delta != 0:
            self._queue.shift_positions(delta)
            self._rg.advance_target_position(delta)

    def get_position_after_commands_completed(self) -> int:
        return self._queue.queue_end_pos

    def set_position_after_commands_completed(self, new_pos: int) -> None:
        delta = i32(new_pos - self._queue.queue_end_pos)
        if delta != 0:
            self._queue.shift_positions(delta)
            self._rg.advance_target_position(delta)

    def target_pos(self) -> int:
        if self._qs is not None:
            return self._qs.target_pos()
        return self._rg.target_pos

    # ---------------------------------------------------------------- state
    def is_running(self) -> bool:
        if self._qs is not None:
            return self._qs.has_orders()
        q = self._queue
        return q.is_running() or self._rg.is_ramp_generator_active() or not q.is_queue_empty()

    def is_running_continuously(self) -> bool:
        if self._qs is not None:
            return self._qs.is_running_continuously()
        return self._rg.is_running_continuously()

    def is_stopping(self) -> bool:
        if self._qs is not None:
            return False
        return self._rg.is_stopping()

    def is_ramp_generator_active(self) -> bool:
        if self._qs is not None:
            return self._qs.is_active()
        return self._rg.is_ramp_generator_active()

    def ramp_state(self) -> int:
        if self._qs is not None:
            return self._qs.ramp_state()
        return self._rg.ramp_state()

    def steps_to_stop(self) -> int:
        if self._qs is not None:
            return self._qs.steps_to_stop()
        return self._rg.steps_to_stop()

    # ---------------------------------------------------------------- speed
    def get_max_speed_in_ticks(self) -> int:
        return self._queue.max_speed_in_ticks

    def get_max_speed_in_us(self) -> int:
        return self.get_max_speed_in_ticks() // self._profile.ticks_per_us

    def get_max_speed_in_hz(self) -> int:
        return self._profile.ticks_per_s // self.get_max_speed_in_ticks()

    def get_max_speed_in_milli_hz(self) -> int:
        return (250 * self._profile.ticks_per_s) // self.get_max_speed_in_ticks() * 4

    def set_absolute_speed_limit(self, max_speed_in_ticks: int) -> None:
        if not self._profile.abs_speed_limit:
            raise UnsupportedError("set_absolute_speed_limit()", self._profile.name,
                                   "on AVR, ESP32 and the Pico")
        self._queue.max_speed_in_ticks = max_speed_in_ticks & 0xFFFF

    def set_speed_in_ticks(self, min_step_ticks: int) -> int:
        if self._qs is None:
            if min_step_ticks < self.get_max_speed_in_ticks():
                return -1
        elif min_step_ticks <= 0:
            return -1  # (QuickStep runs a speed beyond its timer at the nearest allowed)
        if min_step_ticks >= TICKS_FOR_STOPPED_MOTOR:
            return -1
        self._rg.set_speed_in_ticks(min_step_ticks)
        return 0

    def set_speed_in_us(self, min_step_us: int) -> int:
        p = self._profile
        min_step_us &= 0xFFFFFFFF
        if min_step_us >= p.ticks_to_us(0xFFFFFFFF):
            return -1
        return self.set_speed_in_ticks(p.us_to_ticks(min_step_us))

    def set_speed_in_hz(self, speed_hz: int) -> int:
        speed_hz &= 0xFFFFFFFF
        if speed_hz == 0:
            return -1
        return self.set_speed_in_ticks(self._rg.div_for_hz(speed_hz))

    def set_speed_in_milli_hz(self, speed_mhz: int) -> int:
        speed_mhz &= 0xFFFFFFFF
        limit = 1000 * self._profile.ticks_per_s // 0xFFFFFFFF + 1
        if speed_mhz <= limit:
            return -1
        return self.set_speed_in_ticks(self._rg.div_for_milli_hz(speed_mhz))

    def get_speed_in_us(self) -> int:
        return self._rg.speed_in_us()

    def get_speed_in_ticks(self) -> int:
        return self._rg.speed_in_ticks()

    def get_speed_in_milli_hz(self) -> int:
        return self._rg.speed_in_milli_hz()

    def _current_speed_ticks(self, realtime: bool) -> tuple[int, bool]:
        if self._qs is not None:
            ticks, _, up = self._qs.running_info()
            return ticks, up
        valid = False
        ticks, count_up = 0, True
        if realtime:
            valid, ticks, count_up = self._queue.actual_ticks_with_direction()
        if not valid:
            if self._rg.is_ramp_generator_active():
                ticks = self._rg.current_period_in_ticks()
                count_up = (self._rg.ramp_state() & RAMP_DIRECTION_COUNT_UP) != 0
            else:
                ticks = 0
        return ticks, count_up

    def get_current_speed_in_us(self, realtime: bool = True) -> int:
        ticks, count_up = self._current_speed_ticks(realtime)
        us = ticks // self._profile.ticks_per_us
        return us if count_up else -us

    def get_current_speed_in_milli_hz(self, realtime: bool = True) -> int:
        ticks, count_up = self._current_speed_ticks(realtime)
        if ticks <= 0:
            return 0
        mhz = (250 * self._profile.ticks_per_s) // ticks * 4
        return mhz if count_up else -mhz

    def get_period_in_ticks_after_commands_completed(self) -> int:
        if self._qs is not None:
            return self._qs.current_period_ticks()
        if self._rg.is_ramp_generator_active():
            return self._rg.current_period_in_ticks()
        return 0

    def get_period_in_us_after_commands_completed(self) -> int:
        if self._qs is not None:
            return self._qs.current_period_ticks() // self._profile.ticks_per_us
        if self._rg.is_ramp_generator_active():
            return self._rg.current_period_in_us()
        return 0

    # --------------------------------------------------------- acceleration
    def set_acceleration(self, step_s_s: int) -> int:
        step_s_s = i32(step_s_s)
        return self._rg.set_acceleration(step_s_s)

    def get_acceleration(self) -> int:
        return self._rg.acceleration

    def get_current_acceleration(self) -> int:
        if self._qs is not None:
            return self._qs.current_acceleration()
        return self._rg.current_acceleration()

    def set_linear_acceleration(self, linear_acceleration_steps: int) -> None:
        self._rg.set_linear_acceleration(linear_acceleration_steps & 0xFFFFFFFF)

    def set_jump_start(self, jump_step: int) -> None:
        self._rg.set_jump_start(jump_step & 0xFFFFFFFF)

    def apply_speed_acceleration(self) -> None:
        self._rg.apply_speed_acceleration()
        self._engine.kick()

    def set_forward_planning_time_in_ms(self, ms: int) -> None:
        self._forward_planning_in_ticks = (ms & 0xFF) * self._profile.ticks_per_ms

    # ----------------------------------------------------------------- moves
    def _block(self, blocking: bool) -> None:
        if blocking:
            self._engine.backend.wait_until(lambda: not self.is_running(), 0)

    def _hold(self, fn, blocking: bool = False, check: bool = True) -> MoveResult | None:
        """Motion while a synchronized output waits (:mod:`fas.sync`): checked now, made
        after the output has changed.  None: nothing waits, go ahead."""
        sync = self._engine.sync
        if not sync.holding():
            return None
        if check and self._qs is None:  # QuickStep checks its move when it is made
            res = self._rg.check_valid_config()
            if res != MoveResult.OK:
                return res
        call = sync.hold(fn, self.index)
        if blocking:
            self._engine.backend.wait_until(lambda: call.done and not self.is_running(), 0)
        return MoveResult.OK

    def move(self, move: int, blocking: bool = False) -> MoveResult:
        move = i32(move)
        if self._qs is None and move < 0 and self._dir_pin == PIN_UNDEFINED:
            return MoveResult.ERR_NO_DIRECTION_PIN
        held = self._hold(lambda: self.move(move), blocking)
        if held is not None:
            return held
        if self._qs is not None:
            res = self._qs.move(move)
            if res == MoveResult.OK:
                self._block(blocking)
            return res
        res = self._rg.move(move)
        self._engine.kick()
        if res == MoveResult.OK:
            self._block(blocking)
        return res

    def move_to(self, position: int, blocking: bool = False) -> MoveResult:
        held = self._hold(lambda: self.move_to(position), blocking)
        if held is not None:
            return held
        if self._qs is not None:
            res = self._qs.move_to(i32(position))
            if res == MoveResult.OK:
                self._block(blocking)
            return res
        res = self._rg.move_to(i32(position), self._queue.queue_end_pos)
        self._engine.kick()
        if res == MoveResult.OK:
            self._block(blocking)
        return res

    def keep_running(self) -> None:
        if self._hold(self.keep_running, check=False) is not None:
            return
        if self._qs is not None:
            self._qs.keep_running()
            return
        self._rg.set_keep_running()
        self._engine.kick()

    def run_forward(self) -> MoveResult:
        held = self._hold(self.run_forward)
        if held is not None:
            return held
        if self._qs is not None:
            return self._qs.run(True)
        res = self._rg.start_run(True)
        self._engine.kick()
        return res

    def run_backward(self) -> MoveResult:
        held = self._hold(self.run_backward)
        if held is not None:
            return held
        if self._qs is not None:
            return self._qs.run(False)
        res = self._rg.start_run(False)
        self._engine.kick()
        return res

    def move_by_acceleration(self, acceleration: int, allow_reverse: bool = True) -> MoveResult:
        held = self._hold(lambda: self.move_by_acceleration(acceleration, allow_reverse),
                          check=False)
        if held is not None:
            return held
        res = MoveResult.OK
        if acceleration > 0:
            self.set_acceleration(acceleration)
            res = self.run_forward()
        elif acceleration < 0:
            self.set_acceleration(-acceleration)
            if allow_reverse and self._dir_pin != PIN_UNDEFINED:
                res = self.run_backward()
            else:
                self.apply_speed_acceleration()
                self.stop_move()
        elif self._qs is not None:
            self._qs.keep_running()
        else:
            max_speed = self._rg.speed_in_ticks()
            self._rg.set_speed_in_ticks(self.get_period_in_ticks_after_commands_completed())
            self.set_acceleration(1)  # keeps the current speed
            self.apply_speed_acceleration()
            self._rg.set_speed_in_ticks(max_speed)
        return res

    def stop_move(self) -> None:
        if self._qs is not None:
            self._qs.stop()
            return
        self._rg.initiate_stop()
        self._cut_queue(immediate=False)
        self._engine.kick()

    def force_stop(self) -> None:
        if self._qs is not None:
            self._qs.force_stop()
            self._queue.force_stop()
            return
        self._queue.ignore_commands = True
        self._rg.immediate_stop()
        self._cut_queue(immediate=True)
        self._engine.kick()

    def _cut_queue(self, immediate: bool) -> None:
        """On a backend with a deep queue: drop the planned commands the motor has not
        reached yet, back to the first point the backend can still cut at, and plan the
        stop from there (see :meth:`fas.backend.QueueChannel.cut`)."""
        snaps = self._snapshots
        if snaps is None:
            return
        q = self._queue
        ch = q.channel
        first = ch.cut_index()
        if first is None:
            return
        w = q.next_write_idx
        added = q.entries_added
        c = first
        while c != w:
            snap = snaps[c]
            if snap is not None and added - snap[0] == (w - c) & 0xFF:
                break
            c = (c + 1) & 0xFF
        else:
            return  # no command boundary before the end: the queue ends soon enough
        rg = self._rg
        before = rg.snapshot()

        def refused() -> None:  # the cut came too late: stop from the queue's end
            rg.restore(before)
            if immediate:
                q.ignore_commands = True
                rg.immediate_stop()
            self._engine.kick()

        ch.cut(c, refused)
        rg.restore(snap[1])

    def force_stop_and_new_position(self, new_pos: int) -> None:
        q = self._queue
        q.ignore_commands = True
        self._rg.stop_ramp()
        if self._qs is not None:
            self._qs.force_stop()
            q.ignore_commands = False
        q.force_stop()
        q.queue_end_pos = i32(new_pos)
        self._rg.set_target_position(new_pos)

    def forward_step(self, blocking: bool = False) -> None:
        self._perform_one_step(True, blocking)

    def backward_step(self, blocking: bool = False) -> None:
        self._perform_one_step(False, blocking)

    def _perform_one_step(self, count_up: bool, blocking: bool) -> None:
        if self._hold(lambda: self._perform_one_step(count_up, False), blocking,
                      check=False) is not None:
            return
        if self.is_running():
            return
        if count_up or self._dir_pin != PIN_UNDEFINED:
            if self._qs is not None:
                self._qs.single_step(count_up)
                self._block(blocking)
                return
            self._queue.ignore_commands = False
            self._add_queue_entry(self._profile.min_cmd_ticks, 1, count_up)
            self._block(blocking)

    # ------------------------------------------------------------- raw queue
    def add_queue_entry(self, ticks: int | None, steps: int = 0, count_up: bool = True,
                        start: bool = True) -> AqeResult:
        """Queue one raw command; ``ticks=None`` only starts a filled queue.

        While a synchronized output waits (:mod:`fas.sync`) a new command is motion
        commanded after it: ``QUEUE_FULL`` until the output has changed."""
        if ticks is not None and self._engine.sync.holding():
            return AqeResult.QUEUE_FULL
        return self._add_queue_entry(ticks, steps, count_up, start)

    def _add_queue_entry(self, ticks: int | None, steps: int = 0, count_up: bool = True,
                         start: bool = True) -> AqeResult:
        q = self._queue
        if self._qs is not None:
            return AqeResult.QUEUE_FULL  # the queue holds QuickStep's orders now
        if ticks is None:
            return q.add_queue_entry(None, start=start)
        if not (0 <= steps <= 255) or not (0 <= ticks <= 65535):
            return AqeResult.ERROR_TICKS_TOO_LOW
        if ticks < q.max_speed_in_ticks:
            return AqeResult.ERROR_TICKS_TOO_LOW
        if self._dir_pin != PIN_UNDEFINED:
            if not q.is_running() and self._engine.is_dir_pin_busy(self._dir_pin, q.index):
                return AqeResult.DIR_PIN_IS_BUSY
        elif not count_up:
            return AqeResult.ERROR_NO_DIR_PIN_TO_TOGGLE

        res = AQE_OK
        if self._auto_enable and self._auto_disable_delay_counter == 0:
            if not self.enable_outputs():
                return AqeResult.WAIT_FOR_ENABLE_PIN_ACTIVE
            if self._on_delay_ticks > 0:
                delay = self._on_delay_ticks
                if delay < self._dir_change_delay_ticks and q.queue_end_count_up != count_up:
                    delay = self._dir_change_delay_ticks
                while delay > 0:
                    half = delay >> 1
                    if half > 65535:
                        chunk = 65535
                    elif half < 32768:
                        chunk = delay & 0xFFFF
                    else:
                        chunk = half
                    q.add_queue_entry(chunk, 0, count_up, start=False)
                    delay -= chunk
                res = q.add_queue_entry(None, start=start)
                if res != AQE_OK:
                    return res

        dir_change_needed = self._dir_pin != PIN_UNDEFINED and q.queue_end_count_up != count_up
        if self._dir_pin != PIN_UNDEFINED and self._dir_pin & PIN_EXTERNAL_FLAG:
            if dir_change_needed and not self._handle_external_direction_pin(count_up):
                res = q.add_queue_entry(self._profile.us_to_ticks(2000), 0, count_up,
                                        start=start)
                return AqeResult.DIR_PIN_2MS_PAUSE_ADDED if res == AQE_OK else res
        elif dir_change_needed and steps != 0:
            pool = self._pool
            before_delay = pool.before_dir_change_ticks if pool is not None else 0
            after_delay = self._dir_change_delay_ticks
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

        res = q.add_queue_entry(ticks, steps, count_up, start=start)
        if res == AQE_OK and self._auto_enable:
            self._auto_disable_delay_counter = self._off_delay_count
        self._engine.kick()
        return res

    def _handle_external_direction_pin(self, count_up: bool) -> bool:
        engine = self._engine
        if self._pending_external_dir is not None:
            desired = self._pending_external_dir
            if engine.call_external_pin(self._dir_pin, desired) == desired:
                self._pending_external_dir = None
            if self._pending_external_dir is not None:
                return False
        if self._queue.queue_end_count_up != count_up:
            if self._queue.has_steps_in_queue():
                return False
            desired = HIGH if count_up == self._dir_high_counts_up else LOW
            if engine.call_external_pin(self._dir_pin, desired) != desired:
                self._pending_external_dir = desired
                return False
        return True

    def is_queue_empty(self) -> bool:
        return self._queue.is_queue_empty()

    def is_queue_full(self) -> bool:
        return self._queue.is_queue_full()

    def is_queue_running(self) -> bool:
        return self._queue.is_running()

    def queue_entries(self) -> int:
        return self._queue.queue_entries()

    def ticks_in_queue(self) -> int:
        return self._queue.ticks_in_queue()

    def has_ticks_in_queue(self, min_ticks: int) -> bool:
        return self._queue.has_ticks_in_queue(min_ticks)

    def move_timed(self, steps: int, duration: int, start: bool = True) -> TimedMove:
        """``steps`` (signed) within ``duration`` ticks, past the ramp generator.

        Returns ``(result, actual_duration)``: a :class:`~fas.codes.MoveTimedResult`
        and the ticks the queued commands really last (see :mod:`fas.timed`)."""
        return move_timed(self, steps, duration, start)

    # ------------------------------------------------------------ pin control
    def detach_from_pin(self) -> None:
        self._engine.backend.detach_step_pin(self._queue, True)

    def reattach_to_pin(self) -> None:
        self._engine.backend.detach_step_pin(self._queue, False)

    # ------------------------------------------------------- driver type (ESP32)
    def driver_kind(self) -> int | None:
        """The step generator's FasDriver value (None where the chip has no pools)."""
        return None if self._pool is None else FasDriver(self._pool.driver)

    def driver_type(self) -> FasDriver:
        if not self._profile.driver_select:
            raise UnsupportedError("driver_type()", self._profile.name,
                                   "on ESP32 builds with two or more driver types")
        return FasDriver(self._pool.driver) if self._pool is not None else FasDriver.DONT_CARE

    def driver_type_string(self) -> str:
        if not self._profile.driver_select:
            raise UnsupportedError("driver_type_string()", self._profile.name,
                                   "on ESP32 builds with two or more driver types")
        return DRIVER_NAMES.get(self.driver_type(), "UNSPECIFIED")

    # ---------------------------------------------------------- pulse counter
    def attach_to_pulse_counter(self, pcnt_unit: int = 0, low_value: int = -16384,
                                high_value: int = 16384,
                                dir_pin_readback: int = PIN_UNDEFINED) -> bool:
        """Count this stepper's pulses in a free pcnt unit (ESP32 only).

        Counts up towards ``high_value`` and down (direction pin at its counting-down
        level) towards ``low_value``, resetting to 0 there; 0/0 wraps like an int16.
        The direction comes from the direction pin, or from ``dir_pin_readback`` - a
        GPIO that shows the level of an external direction pin; without either, every
        pulse counts up.  ESP-IDF 4: ``pcnt_unit`` is the unit (units of MCPWM/PCNT
        steppers are taken); ESP-IDF 5 picks a free unit itself."""
        p = self._profile
        if not p.has_pulse_counter:
            raise UnsupportedError("attach_to_pulse_counter()", p.name,
                                   "on ESP32 builds with a pulse counter (ESP-IDF < 5.5)")
        if not (-32768 <= low_value <= 0 <= high_value <= 32767):
            return False
        if not self._engine.claim_pulse_counter(pcnt_unit, self):
            return False
        readback = None
        dir_pin = dir_pin_readback if dir_pin_readback != PIN_UNDEFINED else self._dir_pin
        if dir_pin == PIN_UNDEFINED or dir_pin & PIN_EXTERNAL_FLAG:
            follow = False
        else:
            follow = True
            if dir_pin != self._dir_pin:
                backend = self._engine.backend
                readback = lambda: backend.read_pin(dir_pin)  # noqa: E731
        counter = PulseCounter(low_value, high_value, self._dir_high_counts_up,
                               follow_direction=follow, readback=readback)
        if not self._engine.backend.attach_pulse_counter(self._queue, counter):
            return False
        self._pulse_counter = counter
        return True

    def pulse_counter_attached(self) -> bool:
        return self._pulse_counter is not None

    def read_pulse_counter(self) -> int:
        if self._pulse_counter is None:
            return 0
        self._queue.channel.sync()
        return self._pulse_counter.read()

    def clear_pulse_counter(self) -> None:
        if self._pulse_counter is not None:
            self._queue.channel.sync()
            self._pulse_counter.clear()

    # ------------------------------------------------------ QuickStep planner
    @property
    def planner(self) -> int:
        return PLANNER_FAS if self._qs is None else PLANNER_QUICKSTEP

    @property
    def quickstep(self) -> QuickStepPlanner | None:
        """The QuickStep planner while it is selected (its FIFO, plateaus, moves)."""
        return self._qs

    def set_planner(self, planner: int, depth: int | None = None,
                    plateaus: int | None = None) -> QsConfigResult:
        """Select FastAccelStepper's ramp (PLANNER_FAS) or QuickStep (PLANNER_QUICKSTEP)
        with a FIFO of ``depth`` orders and ``plateaus`` acceleration plateaus (None:
        keep the current or default figures).  Only while the stepper is at rest."""
        from .quickstep import setup
        return setup.select(self, planner, depth, plateaus)

    def engine_now(self) -> int:
        return self._engine.backend.now()

    def has_direction_pin(self) -> bool:
        return self._dir_pin != PIN_UNDEFINED

    def wait_backend(self, predicate) -> None:
        self._engine.backend.wait_until(predicate, 0)

    def prepare_order(self) -> int:
        """Before an order goes into an idle QuickStep FIFO: auto enable switches the
        driver on; returns the delay (ticks) the first step must wait for it."""
        q = self._queue
        if q.is_running() or not q.is_queue_empty():
            return 0
        if self._auto_enable and self._auto_disable_delay_counter == 0:
            self.enable_outputs()
            return self._on_delay_ticks
        return 0

    def order_added(self) -> None:
        if self._auto_enable:
            self._auto_disable_delay_counter = self._off_delay_count
        self._engine.kick()

    # ----------------------------------------------------------- ramp task
    def fill_queue(self) -> int:
        """Plan commands until the queue holds the forward-planning time; returns count."""
        if self._qs is not None:
            return self._qs.pump()
        rg = self._rg
        if not rg.is_ramp_generator_active() or not rg.has_valid_config():
            return 0
        q = self._queue
        q.ignore_commands = False
        self.fill_calls += 1
        delayed_start = not q.is_running()
        need_delayed_start = False
        ticks_prepared = q.ticks_in_queue()
        planning = self._forward_planning_in_ticks
        if not delayed_start:  # a running queue: what the backend's link needs, too
            planning += self._engine.backend.planning_extra_ticks
        snaps = self._snapshots
        generated = 0
        queue_len = q.queue_len
        # ticks_in_queue() brought the channel's view up to date; the task runs at one
        # instant and only appends, so the count follows from the indices
        while True:
            entries = (q.next_write_idx - q.read_idx) & 0xFF
            if (entries >= queue_len or (ticks_prepared >= planning and entries > 1)
                    or not rg.is_ramp_generator_active()):
                break
            if snaps is not None and q.channel.cut_pending and rg.apply_pending():
                break  # a new request waits until the cut is confirmed or undone
            res = AQE_OK
            cmd = rg.get_next_command(q.queue_end_pos, q.queue_end_count_up)
            if cmd.ticks != 0:
                res = self._add_queue_entry(cmd.ticks, cmd.steps, cmd.count_up,
                                            start=not delayed_start)
                generated += 1
            if res == AQE_OK:
                rg.after_command_enqueued(cmd)
                if snaps is not None:
                    snaps[q.next_write_idx] = (q.entries_added, rg.snapshot())
                need_delayed_start = delayed_start
                ticks_prepared += cmd.ticks * cmd.steps if cmd.steps > 1 else cmd.ticks
            if cmd.ticks == 0:
                break
            if res != AQE_OK:
                if res.retry:
                    break
                self._engine.report_ramp_abort(self, res, cmd)
                rg.stop_ramp()
                delayed_start = False
        if need_delayed_start:
            self._add_queue_entry(None, start=True)
        self.commands_generated += generated
        return generated
