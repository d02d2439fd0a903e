"""One stepper: the public API of FastAccelStepper in snake_case.

A stepper keeps its pins, the driver's enable handling (:mod:`fas.drive`), its
position and the API.  Motion - ``move``, ``move_to``, ``run_forward``, stops, and
filling the queue in the periodic task - comes from its *planner* (:mod:`fas.planner`:
FastAccelStepper's ramp by default, QuickStep, or any planner registered in
:mod:`fas.planners`), which it calls without knowing which one it is.  Raw commands
go straight into the command queue (``add_queue_entry``, ``move_timed``), past the
planner, with what the driver needs around them (auto enable with its delays, the
pause before the first step after a direction change, external direction pins).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

from . import planners
from .channel import PulseCounter
from .codes import (
    PIN_EXTERNAL_FLAG,
    PIN_UNDEFINED,
    AqeResult,
    DelayResult,
    FasDriver,
    MoveResult,
)
from .drive import Drive
from .errors import UnsupportedError
from .motion import MotionSettings, div_for_hz, div_for_milli_hz, milli_hz_of_ticks
from .planner import Planner, PlannerHost
from .planners import PLANNER_FAS, PLANNER_QUICKSTEP
from .queue import StepperQueue, i32
from .timed import TimedMove, move_timed

if TYPE_CHECKING:  # pragma: no cover
    from .arch import DriverPool
    from .engine import Engine

__all__ = ["Stepper", "PLANNER_FAS", "PLANNER_QUICKSTEP", "DRIVER_NAMES"]

DRIVER_NAMES = {FasDriver.MCPWM_PCNT: "MCPWM_PCNT", FasDriver.RMT: "RMT",
                FasDriver.I2S_DIRECT: "I2S_DIRECT", FasDriver.I2S_MUX: "I2S_MUX"}


class Stepper:
    def __init__(self, engine: Engine, queue: StepperQueue,
                 pool: DriverPool | None = None) -> None:
        profile = engine.profile
        self._engine = engine
        self._profile = profile
        self._commands = queue  # the command queue (FastAccelStepper's)
        self._queue = queue  # the queue of the planner in use
        self._step_pin = queue.step_pin
        # direction and enable inputs of the driver, and writing a command (fas.drive)
        self._drive = drive = Drive(engine, pool, queue, lambda: self._queue, self.is_running)
        #: the same, read only: the engine's periodic task reads its auto disable counter
        self.drive: Drive = drive
        # the engine's periodic task asks these of every stepper (its Drive answers)
        self.count_down_auto_disable: Callable[[], None] = drive.count_down_auto_disable
        self.agrees_to_auto_disable: Callable[[], bool] = drive.agrees_to_auto_disable
        self.auto_disable_due: Callable[[], bool] = drive.auto_disable_due
        self.uses_enable_pin: Callable[[int], bool] = drive.uses_enable_pin
        self._pulse_counter: PulseCounter | None = None
        self._settings = MotionSettings(forward_planning_ticks=profile.ticks_per_s // 50)
        backend = engine.backend
        self._host = PlannerHost(
            index=queue.index, profile=profile, backend=backend, settings=self._settings,
            queue=queue, write=drive.write, wake=engine.kick,
            wait_until=lambda predicate: backend.wait_until(predicate, 0),
            has_direction_pin=self.has_direction_pin,
            start_delay=drive.start_delay, command_written=drive.command_written,
            report_abort=lambda res, cmd: engine.report_ramp_abort(self, res, cmd),
            allocator=engine.allocator, shared=engine.shared)
        # planners made for this stepper, by name (one given up is kept: selected again,
        # it goes on with its state); those not in use
        self._planners: dict[str, Planner] = {}
        self._idle: list[Planner] = []
        self._planner_name = PLANNER_FAS
        _, planner = planners.lookup(PLANNER_FAS)(self._host, None, None)
        assert planner is not None
        self._planner: Planner = planner
        #: the planner in use (:mod:`fas.planner`); read only (:meth:`use_planner` sets
        #: it, with ``_planner``): a plain attribute, read per G-code move
        self.planner: Planner = planner
        self._planners[PLANNER_FAS] = planner
        planner.attach(None)

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
        self._drive.set_direction_pin(dir_pin, dir_high_counts_up, dir_change_delay_us)

    def get_direction_pin(self) -> int:
        return self._drive.dir_pin

    def direction_pin_high_counts_up(self) -> bool:
        return self._drive.dir_high_counts_up

    def get_dir_change_delay_ticks(self) -> int:
        """The direction-change delay of :meth:`set_direction_pin` (0: none)."""
        return self._drive.dir_change_delay_ticks

    def has_direction_pin(self) -> bool:
        return self._drive.dir_pin != PIN_UNDEFINED

    def set_enable_pin(self, enable_pin: int, low_active_enables_stepper: bool = True) -> None:
        self._drive.set_enable_pin(enable_pin, low_active_enables_stepper)

    def get_enable_pin_high_active(self) -> int:
        return self._drive.enable_pin_high_active

    def get_enable_pin_low_active(self) -> int:
        return self._drive.enable_pin_low_active

    def set_auto_enable(self, auto_enable: bool) -> None:
        self._drive.set_auto_enable(auto_enable)

    def get_auto_enable(self) -> bool:
        """Is auto enable on (not in upstream's API; a front end that switches the
        drivers itself for a while restores it afterwards)."""
        return self._drive.auto_enable

    def set_delay_to_enable(self, delay_us: int) -> DelayResult:
        return self._drive.set_delay_to_enable(delay_us)

    def get_delay_to_enable_ticks(self) -> int:
        """The enable delay set with :meth:`set_delay_to_enable` (not in upstream's API:
        a front end that enables drivers itself waits this long before a step)."""
        return self._drive.on_delay_ticks

    def set_delay_to_disable(self, delay_ms: int) -> None:
        self._drive.set_delay_to_disable(delay_ms)

    def enable_outputs(self) -> bool:
        return self._drive.enable_outputs()

    def disable_outputs(self) -> bool:
        return self._drive.disable_outputs()

    def outputs_enabled(self) -> bool | None:
        """Level of the driver's enable input(s) as seen on the pins (None: no pin)."""
        return self._drive.outputs_enabled()

    # ------------------------------------------------------------- auto disable
    def needs_task(self) -> bool:
        """The next runs of the periodic task must not be skipped for this stepper."""
        if self._drive.auto_disable_delay_counter > 0 or self._planner.needs_task():
            return True
        for planner in self._idle:  # noqa: SIM110 - every task run: a loop, no generator
            if planner.wants_task_at_rest():
                return True
        return False

    # ------------------------------------------------------------- position
    def get_current_position(self) -> int:
        return self._queue.current_position()

    def set_current_position(self, new_pos: int) -> None:
        self._shift_positions(i32(new_pos - self.get_current_position()))

    def get_position_after_commands_completed(self) -> int:
        return self._queue.queue_end_pos

    def set_position_after_commands_completed(self, new_pos: int) -> None:
        self._shift_positions(i32(new_pos - self._queue.queue_end_pos))

    def _shift_positions(self, delta: int) -> None:
        if delta != 0:
            self._queue.shift_positions(delta)
            self._planner.positions_shifted(delta)

    def target_pos(self) -> int:
        return self._planner.target_pos()

    # ---------------------------------------------------------------- state
    def is_running(self) -> bool:
        return self._planner.is_running()

    def is_running_continuously(self) -> bool:
        return self._planner.is_running_continuously()

    def is_stopping(self) -> bool:
        return self._planner.is_stopping()

    def is_ramp_generator_active(self) -> bool:
        return self._planner.is_active()

    def ramp_state(self) -> int:
        return self._planner.ramp_state()

    def steps_to_stop(self) -> int:
        return self._planner.steps_to_stop()

    # ---------------------------------------------------------------- speed
    def get_max_speed_in_ticks(self) -> int:
        return self._queue.max_speed_in_ticks

    def get_max_speed_in_us(self) -> int:
        return self.get_max_speed_in_ticks() // self._profile.ticks_per_us

    def get_max_speed_in_hz(self) -> int:
        return self._profile.ticks_per_s // self.get_max_speed_in_ticks()

    def get_max_speed_in_milli_hz(self) -> int:
        # uint32_t arithmetic as in the C++: 250 * TICKS_PER_S wraps where
        # TICKS_PER_S > 17 179 869 (SAM Due: 21 MHz -> 9 095 548 at 420 ticks)
        return milli_hz_of_ticks(self._profile.ticks_per_s, self.get_max_speed_in_ticks())

    def set_absolute_speed_limit(self, max_speed_in_ticks: int) -> None:
        if not self._profile.abs_speed_limit:
            raise UnsupportedError("set_absolute_speed_limit()", self._profile.name,
                                   "on AVR, ESP32 and the Pico")
        self._queue.max_speed_in_ticks = max_speed_in_ticks & 0xFFFF

    def set_speed_in_ticks(self, min_step_ticks: int) -> int:
        return self._settings.set_speed_checked(min_step_ticks,
                                                self._planner.fastest_period_ticks())

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
        return self.set_speed_in_ticks(div_for_hz(self._profile.ticks_per_s, speed_hz))

    def set_speed_in_milli_hz(self, speed_mhz: int) -> int:
        speed_mhz &= 0xFFFFFFFF
        limit = 1000 * self._profile.ticks_per_s // 0xFFFFFFFF + 1
        if speed_mhz <= limit:
            return -1
        return self.set_speed_in_ticks(div_for_milli_hz(self._profile.ticks_per_s, speed_mhz))

    def get_speed_in_us(self) -> int:
        return self._settings.min_travel_ticks // self._profile.ticks_per_us

    def get_speed_in_ticks(self) -> int:
        return self._settings.min_travel_ticks

    def get_speed_in_milli_hz(self) -> int:
        ticks = self._settings.min_travel_ticks
        return 0 if ticks == 0 else div_for_milli_hz(self._profile.ticks_per_s, ticks)

    def get_current_speed_in_us(self, realtime: bool = True) -> int:
        ticks, count_up = self._planner.current_speed(realtime)
        us = ticks // self._profile.ticks_per_us
        return us if count_up else -us

    def get_current_speed_in_milli_hz(self, realtime: bool = True) -> int:
        ticks, count_up = self._planner.current_speed(realtime)
        if ticks <= 0:
            return 0
        mhz = i32(milli_hz_of_ticks(self._profile.ticks_per_s, ticks))  # int32_t speed_in_mhz
        return mhz if count_up else i32(-mhz)

    def get_period_in_ticks_after_commands_completed(self) -> int:
        return self._planner.planned_period_ticks()

    def get_period_in_us_after_commands_completed(self) -> int:
        return self._planner.planned_period_ticks() // self._profile.ticks_per_us

    # --------------------------------------------------------- acceleration
    def set_acceleration(self, step_s_s: int) -> int:
        return self._settings.set_acceleration(i32(step_s_s))

    def get_acceleration(self) -> int:
        return self._settings.acceleration

    def get_current_acceleration(self) -> int:
        return self._planner.current_acceleration()

    def set_linear_acceleration(self, linear_acceleration_steps: int) -> None:
        self._settings.set_cubic_acceleration_steps(linear_acceleration_steps & 0xFFFFFFFF)

    def set_jump_start(self, jump_step: int) -> None:
        self._settings.set_jump_start(jump_step & 0xFFFFFFFF)

    def apply_speed_acceleration(self) -> None:
        self._planner.apply_settings()
        self._engine.kick()

    def set_forward_planning_time_in_ms(self, ms: int) -> None:
        self._settings.forward_planning_ticks = (ms & 0xFF) * self._profile.ticks_per_ms

    def get_forward_planning_ticks(self) -> int:
        """How far ahead the planner fills the queue (``set_forward_planning_time_in_ms``)."""
        return self._settings.forward_planning_ticks

    def set_forward_planning_ticks(self, ticks: int) -> None:
        """Restore a figure :meth:`get_forward_planning_ticks` returned."""
        self._settings.forward_planning_ticks = ticks

    # ----------------------------------------------------------------- moves
    def _block(self, blocking: bool) -> None:
        if blocking:
            self._engine.backend.wait_until(lambda: not self.is_running(), 0)

    def _hold(self, fn: Callable[[], object], blocking: bool = False,
              check: bool = True) -> MoveResult | None:
        """Motion while a synchronized output waits (:mod:`fas.sync`): checked now, made
        after the output has changed.  None: nothing waits, go ahead."""
        sync = self._engine.sync
        if not sync.holding():
            return None
        if check:
            res = self._planner.check_held()
            if res != MoveResult.OK:
                return res
        call = sync.hold(fn, self.index)
        if blocking:
            self._engine.backend.wait_until(lambda: call.done and not self.is_running(), 0)
        return MoveResult.OK

    def move(self, move: int, blocking: bool = False) -> MoveResult:
        move = i32(move)
        res = self._planner.check_move(move)
        if res != MoveResult.OK:
            return res
        held = self._hold(lambda: self.move(move), blocking)
        if held is not None:
            return held
        res = self._planner.move(move)
        if res == MoveResult.OK:
            self._block(blocking)
        return res

    def move_to(self, position: int, blocking: bool = False) -> MoveResult:
        held = self._hold(lambda: self.move_to(position), blocking)
        if held is not None:
            return held
        res = self._planner.move_to(i32(position))
        if res == MoveResult.OK:
            self._block(blocking)
        return res

    def keep_running(self) -> None:
        if self._hold(self.keep_running, check=False) is not None:
            return
        self._planner.keep_running()

    def run_forward(self) -> MoveResult:
        held = self._hold(self.run_forward)
        if held is not None:
            return held
        return self._planner.run(True)

    def run_backward(self) -> MoveResult:
        held = self._hold(self.run_backward)
        if held is not None:
            return held
        return self._planner.run(False)

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
            if allow_reverse and self._drive.dir_pin != PIN_UNDEFINED:
                res = self.run_backward()
            else:
                self.apply_speed_acceleration()
                self.stop_move()
        else:
            self._planner.keep_speed()
        return res

    def stop_move(self) -> None:
        self._planner.stop()

    def force_stop(self) -> None:
        self._planner.force_stop()

    def force_stop_and_new_position(self, new_pos: int) -> None:
        self._planner.force_stop_at(new_pos)

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
        if count_up or self._drive.dir_pin != PIN_UNDEFINED:
            self._planner.single_step(count_up)
            self._block(blocking)

    # ------------------------------------------------------------- raw queue
    def add_queue_entry(self, ticks: int | None, steps: int = 0, count_up: bool = True,
                        start: bool = True) -> AqeResult:
        """Queue one raw command; ``ticks=None`` only starts a filled queue.

        While a synchronized output waits (:mod:`fas.sync`) a new command is motion
        commanded after it: ``QUEUE_FULL`` until the output has changed."""
        if ticks is not None and self._engine.sync.holding():
            return AqeResult.QUEUE_FULL
        if self._queue is not self._commands:
            return AqeResult.QUEUE_FULL  # the planner in use runs a queue of its own
        return self._drive.write(ticks, steps, count_up, start)

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
        pool = self._drive.pool
        return None if pool is None else FasDriver(pool.driver)

    def driver_type(self) -> FasDriver:
        if not self._profile.driver_select:
            raise UnsupportedError("driver_type()", self._profile.name,
                                   "on ESP32 builds with two or more driver types")
        kind = self.driver_kind()
        return FasDriver.DONT_CARE if kind is None else FasDriver(kind)

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
        dir_pin = dir_pin_readback if dir_pin_readback != PIN_UNDEFINED else self._drive.dir_pin
        if dir_pin == PIN_UNDEFINED or dir_pin & PIN_EXTERNAL_FLAG:
            follow = False
        else:
            follow = True
            if dir_pin != self._drive.dir_pin:
                backend = self._engine.backend
                readback = lambda: backend.read_pin(dir_pin)  # noqa: E731
        counter = PulseCounter(low_value, high_value, self._drive.dir_high_counts_up,
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

    # --------------------------------------------------------------- planner
    @property
    def planner_name(self) -> str:
        """The registry name of the planner in use (:mod:`fas.planners`)."""
        return self._planner_name

    def set_planner(self, name: str, *options: object) -> int:
        """Choose the planner registered as ``name`` (:mod:`fas.planners`), with the
        options its factory takes (QuickStep: FIFO depth, plateaus; None keeps the
        current or default figure).  Returns 0 (OK) or the factory's reason for
        refusing; nothing changes then.  A planner given up earlier is handed back to
        its factory, which may resume it (the ramp does)."""
        factory = planners.lookup(name)
        res, planner = factory(self._host, self._planner, self._planners.get(name), *options)
        if res == 0 and planner is not None and planner is not self._planner:
            self._planners[name] = planner
            self.use_planner(planner, name)
        return res

    def use_planner(self, planner: Planner, name: str = "") -> Planner:
        """Make ``planner`` this stepper's and return the one it replaces (which has no
        motion left to plan).  The new planner's queue takes over position and
        direction (:meth:`fas.queue.StepperQueue.take_over`)."""
        old = self._planner
        if planner is old:
            return old
        planner.queue.take_over(old.queue)
        old.detach()
        self._planner = self.planner = planner
        self._planner_name = name or next(
            (n for n, p in self._planners.items() if p is planner), type(planner).__name__)
        self._queue = planner.queue
        self._idle = [p for p in self._planners.values() if p is not planner]
        if old not in self._idle:
            self._idle.append(old)
        planner.attach(old)
        self._engine.planners_changed()
        return old

    def fill_queue(self) -> int:
        """One run of the periodic task for this stepper: the planner fills its queue;
        returns the commands written."""
        return self._planner.fill()
