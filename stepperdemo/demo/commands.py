"""StepperDemo's own commands, as the firmware has them (:data:`FIRMWARE`).

Numbers parse like C ``strtol`` (base 10, optional sign, empty means 0) and the whole
rest of the command must be the number (:mod:`.parsing`).  The table that the program
dispatches with is put together in :mod:`.command_registry`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable

from fas.codes import PIN_UNDEFINED

from .. import messages as msg
from . import quickstep as qs_console
from .command_table import CommandSet, Handler, Mode
from .parsing import parse_number as _number
from .parsing import parse_values as _values

if TYPE_CHECKING:  # pragma: no cover
    from fas.stepper import Stepper

    from .app import StepperDemo

FIRMWARE = CommandSet()
command = FIRMWARE.command
_NORMAL = (Mode.NORMAL,)


# ------------------------------------------------------------------ all modes
@command("M", Mode.NORMAL, Mode.TEST, Mode.CONFIG, hint="select stepper n", arg="<n>")
def cmd_select(app: StepperDemo, arg: bytes) -> bool:
    values = _values(arg)
    if values is None or len(values) != 1:
        return False
    n = values[0]
    if 0 < n <= app.profile.max_steppers and app.steppers[n - 1] is not None:
        app.print(msg.SELECT_STEPPER)
        app.selected = n - 1
        app.println_number(n)
        return True
    return False


@command("?", Mode.NORMAL, Mode.TEST, Mode.CONFIG, hint="usage and stepper table")
def cmd_usage(app: StepperDemo, arg: bytes) -> bool:
    if arg:
        return False
    app.usage()
    return True


@command("I", Mode.NORMAL, Mode.TEST, hint="status lines on/off")
def cmd_toggle_info(app: StepperDemo, arg: bytes) -> bool:
    if arg:
        return False
    app.print(msg.TOGGLE_MOTOR_INFO)
    app.verbose = not app.verbose
    return True


@command("Q", Mode.NORMAL, Mode.TEST, hint="usage after stop on/off")
def cmd_toggle_usage(app: StepperDemo, arg: bytes) -> bool:
    if arg:
        return False
    app.print(msg.TOGGLE_USAGE_INFO)
    app.usage_info = not app.usage_info
    return True


@command("W", Mode.NORMAL, Mode.TEST, hint="hold input until stopped")
def cmd_wait_stop(app: StepperDemo, arg: bytes) -> bool:
    if arg:
        return False
    s = app.selected_stepper
    if app.scripted:
        if s.is_running() or app.test_ongoing:
            unread = (app.write_ptr - app.read_ptr) & 0xFF
            if unread > 253:  # the ring wrote over this W: the firmware's rewind skips a ring
                app.input_dropped += unread + 2 - ((unread + 2) & 0xFF)
            app.read_ptr = (app.read_ptr - 2) & 0xFF
        return True
    # interactive, in both modes as the firmware: block on the selected stepper (the
    # loop, test sequences included, stands still meanwhile), then "STOPPED"
    app.print(msg.BLOCKING_WAIT)
    if not s.is_running_continuously() or s.is_stopping():
        if s.is_running():
            app.waiting_interactive = True
        else:
            app.println(msg.STOPPED)
    return True


@command("x", Mode.TEST, Mode.CONFIG, hint="back to the main menu")
def cmd_exit(app: StepperDemo, arg: bytes) -> bool:
    if arg:
        return False
    app.print(msg.EXIT_TO_MAIN_MENU)
    app.test_ongoing = False
    app.mode = Mode.NORMAL
    app.usage()
    return True


# ---------------------------------------------------------------- normal mode
@command("t", Mode.NORMAL, hint="test mode")
def cmd_test_mode(app: StepperDemo, arg: bytes) -> bool:
    if arg:
        return False
    app.print(msg.ENTER_TEST_MODE)
    app.mode = Mode.TEST
    app.usage()
    return True


@command("g", Mode.NORMAL, hint="G-code mode: a line is a block, x leaves")
def cmd_gcode_mode(app: StepperDemo, arg: bytes) -> bool:
    """Issue 12: not in the firmware (its usage text stays as it is)."""
    if arg:
        return False
    app.enter_gcode()
    return True


@command("c", Mode.NORMAL, hint="configuration mode")
def cmd_config_mode(app: StepperDemo, arg: bytes) -> bool:
    if arg:
        return False
    app.print(msg.ENTER_CONFIG_MODE)
    app.mode = Mode.CONFIG
    app.usage()
    return True


@command("r", Mode.NORMAL, hint="AVR: stray digitalRead() on/off; ESP32: restart/reset")
def cmd_stray_read(app: StepperDemo, arg: bytes) -> bool:
    if app.profile.family == "esp32":
        if arg == b"eset":
            app.println(msg.ESP_RESET)
            return _restart(app)
        if not arg:
            app.println(msg.ESP_RESTART)
            return _restart(app)
        return False
    if arg or not app.build.has_stray_digital_read:
        return False
    app.print(msg.STRAY_DIGITAL_READ_TOGGLE)
    app.simulate_digital_read_error = not app.simulate_digital_read_error
    return True


def _restart(app: StepperDemo) -> bool:
    try:
        app.restart()
    except NotImplementedError as exc:
        app.println(msg.RESTART_UNSUPPORTED.format(reason=exc))
    return True


def _i16(v: int) -> int:
    v &= 0xFFFF
    return v - 0x10000 if v & 0x8000 else v


@command("p", Mode.NORMAL, hint="ESP32: attach pulse counter n[,low,high] / pc clear",
         arg="<n>")
def cmd_pulse_counter(app: StepperDemo, arg: bytes) -> bool:
    if not app.profile.has_pulse_counter:
        return False
    s = app.selected_stepper
    if arg == b"c":
        app.print(msg.CLEAR_PULSE_COUNTER)
        s.clear_pulse_counter()
        return True
    values = _values(arg)
    if values is None or len(values) == 2:
        return False
    app.print(msg.ATTACH_PULSE_COUNTER)
    app.println_number(values[0])
    if len(values) == 3:
        ok = s.attach_to_pulse_counter(values[0] & 0xFF, _i16(values[1]), _i16(values[2]))
    else:
        ok = s.attach_to_pulse_counter(values[0] & 0xFF)
    if not ok:
        app.print(msg.PULSE_COUNTER_ERROR)
    return True


@command("e", Mode.NORMAL, hint="100 us interrupt block on/off")
def cmd_irq_block(app: StepperDemo, arg: bytes) -> bool:
    if arg:
        return False
    app.print(msg.LONG_INTERRUPT_BLOCK_TOGGLE)
    app.simulate_blocked_isr = not app.simulate_blocked_isr
    return True


def _setter(text: str, apply: Callable, *, milli_hz: bool | None = None,
            check: bool = True) -> Handler:
    def handler(app: StepperDemo, arg: bytes) -> bool:
        value = _number(arg)
        if value is None:
            return False
        if milli_hz is not None:
            app.speed_in_milli_hz = milli_hz
        app.print(text)
        app.println_number(value)
        res = apply(app.selected_stepper, value)
        if check and res is not None and res < 0:
            app.print(msg.ERROR_INVALID_VALUE)
        return True
    return handler


FIRMWARE.add("A", _NORMAL, _setter(msg.SET_ACCELERATION_TO, lambda s, v: s.set_acceleration(v)),
             "acceleration in steps/s^2", "A<accel>")
FIRMWARE.add("V", _NORMAL, _setter(msg.SET_SPEED_TO_US, lambda s, v: s.set_speed_in_us(v),
                                   milli_hz=False), "speed as us/step", "V<us>")
FIRMWARE.add("H", _NORMAL, _setter(msg.SET_SPEED_TO_HZ, lambda s, v: s.set_speed_in_hz(v),
                                   milli_hz=True), "speed in steps/s", "H<hz>")
FIRMWARE.add("h", _NORMAL, _setter(msg.SET_SPEED_TO_MILLI_HZ,
                                   lambda s, v: s.set_speed_in_milli_hz(v), milli_hz=True),
             "speed in steps/1000s", "h<mhz>")
FIRMWARE.add("J", _NORMAL, _setter(msg.LINEAR_ACCELERATION,
                                   lambda s, v: s.set_linear_acceleration(v), check=False),
             "linear acceleration steps", "J<steps>")
FIRMWARE.add("j", _NORMAL, _setter(msg.JUMP_START, lambda s, v: s.set_jump_start(v),
                                   check=False), "jump start step", "j<steps>")
FIRMWARE.add("@", _NORMAL, _setter(msg.SET_POSITION, lambda s, v: s.set_current_position(v),
                                   check=False), "set position", "@<pos>")
FIRMWARE.add("D", _NORMAL, _setter(msg.SET_DISABLE_TIME,
                                   lambda s, v: s.set_delay_to_disable(v), check=False),
             "delay to disable", "D<ms>")


def _mover(text: str, apply: Callable, letter: str = "") -> Handler:
    def handler(app: StepperDemo, arg: bytes) -> bool:
        value = _number(arg)
        if value is None:
            return False
        app.print(text)
        app.println_number(value)
        res = int(apply(app.selected_stepper, value))
        app.print(msg.MOVE_RESULT[res])
        if letter in "RP":
            qs_console.after_move(app)
        return True
    return handler


FIRMWARE.add("a", _NORMAL, _mover(msg.SET_ACCELERATION_TO,
                                  lambda s, v: s.move_by_acceleration(v)),
             "run by acceleration (+/-)", "a<accel>")
FIRMWARE.add("R", _NORMAL, _mover(msg.MOVE_STEPS, lambda s, v: qs_console.move(s, v, False), "R"),
             "move by n steps", "R<n>")
FIRMWARE.add("P", _NORMAL, _mover(msg.MOVE_TO_POSITION,
                                  lambda s, v: qs_console.move(s, v, True), "P"),
             "move to position", "P<pos>")


@command("E", Mode.NORMAL, hint="delay from enable to first step", arg="<us>")
def cmd_enable_delay(app: StepperDemo, arg: bytes) -> bool:
    value = _number(arg)
    if value is None:
        return False
    app.print(msg.SET_ENABLE_TIME)
    app.println_number(value)
    res = int(app.selected_stepper.set_delay_to_enable(value))
    app.print(msg.RETURN_CODE)
    app.println_number(res & 0xFF)
    return True


@command("w", Mode.NORMAL, hint="hold input for ms", arg="<ms>")
def cmd_wait_ms(app: StepperDemo, arg: bytes) -> bool:
    if app.mode == Mode.TEST and not app.test_mode_wait:
        return False  # the firmware knows `w` in normal mode only
    value = _number(arg)
    if value is None:
        return False
    app.print_number(value)
    app.print(msg.WAIT_MS)
    app.pause_ms = value & 0xFFFFFFFF
    app.pause_start = app.backend.millis()
    return True


FIRMWARE.add("w", (Mode.TEST,), cmd_wait_ms)  # answers only with app.test_mode_wait


def _simple(letter: str, text: str, action: Callable, hint: str) -> None:
    def handler(app: StepperDemo, arg: bytes) -> bool:
        if arg:
            return False
        app.print(text)
        action(app.selected_stepper)
        return True
    FIRMWARE.add(letter, _NORMAL, handler, hint)


def _driver_on(s: Stepper) -> None:
    s.set_auto_enable(False)
    s.enable_outputs()


def _driver_off(s: Stepper) -> None:
    s.set_auto_enable(False)
    s.disable_outputs()


_simple("N", msg.OUTPUT_DRIVER_ON, _driver_on, "driver on, auto enable off")
_simple("F", msg.OUTPUT_DRIVER_OFF, _driver_off, "driver off, auto enable off")
_simple("O", msg.OUTPUT_DRIVER_AUTO, lambda s: s.set_auto_enable(True), "auto enable")
_simple("S", msg.STOP, lambda s: s.stop_move(), "stop with deceleration")
_simple("K", msg.KEEP_RUNNING, lambda s: s.keep_running(), "keep running")
_simple("X", msg.IMMEDIATE_STOP, lambda s: s.force_stop_and_new_position(0),
        "immediate stop, position 0")
_simple("U", msg.UPDATE_SPEED_ACCELERATION, lambda s: s.apply_speed_acceleration(),
        "apply speed/acceleration")
_simple("u", msg.SET_UNIDIRECTIONAL_STEPPER, lambda s: s.set_direction_pin(PIN_UNDEFINED),
        "unidirectional (no dir pin)")


def _runner(letter: str, text: str, forward: bool, hint: str) -> None:
    def handler(app: StepperDemo, arg: bytes) -> bool:
        if arg:
            return False
        app.print(text)
        s = app.selected_stepper
        res = int(s.run_forward() if forward else s.run_backward())
        app.print(msg.RETURN_CODE)
        app.println_number(res & 0xFF)
        return True
    FIRMWARE.add(letter, _NORMAL, handler, hint)


_runner("f", msg.RUN_FORWARD, True, "run forward")
_runner("b", msg.RUN_BACKWARD, False, "run backward")


def _one_step(letter: str, text: str, forward: bool, hint: str) -> None:
    def handler(app: StepperDemo, arg: bytes) -> bool:
        if arg:
            return False
        s = app.selected_stepper
        if not s.is_running():
            if forward:
                s.forward_step(blocking=True)
            else:
                s.backward_step(blocking=True)
            app.print(text)
        return True
    FIRMWARE.add(letter, _NORMAL, handler, hint)


_one_step("+", msg.STEPPED_FORWARD, True, "one step forward")
_one_step("-", msg.STEPPED_BACKWARD, False, "one step backward")


@command("T", Mode.NORMAL, hint="direct-drive self test")
def cmd_direct_drive(app: StepperDemo, arg: bytes) -> bool:
    if arg or app.build.small_build:
        return False
    s = app.selected_stepper
    if not s.is_running():
        app.print(msg.TEST_DIRECT_DRIVE)
        s.detach_from_pin()
        from .direct_drive import test_direct_drive
        test_direct_drive(app, app.demo_steppers[app.selected])
        s.reattach_to_pin()
    return True


# ------------------------------------------------------------------ test mode
@command("R", Mode.TEST, hint="run the assigned sequences")
def cmd_run_tests(app: StepperDemo, arg: bytes) -> bool:
    if arg:
        return False
    app.print(msg.RUN_TESTS)
    app.test_ongoing = True
    return True


def _select_sequence(first: str) -> Handler:
    def handler(app: StepperDemo, arg: bytes) -> bool:
        from .testseq import sequences_for
        code = first + arg.decode("latin-1")
        seq = sequences_for(app.profile).get(code)
        if seq is None:
            return False
        app.print(msg.SELECT_TEST_SEQUENCE)
        app.println(code)
        app.test_slots[app.selected].assign(seq)
        return True
    return handler


FIRMWARE.add("0", (Mode.TEST,), _select_sequence("0"))
FIRMWARE.add("1", (Mode.TEST,), _select_sequence("1"), "assign a test sequence", "01..13")


# ---------------------------------------------------------------- config mode
@command("d", Mode.CONFIG, hint="direction pin p[,n[,t]] or dc", arg="<p,n,t>")
def cmd_direction_pin(app: StepperDemo, arg: bytes) -> bool:
    if app.build.small_build:
        return False  # not in the ATmega32U4 build
    s = app.selected_stepper
    if arg == b"c":
        app.print(msg.DISABLED)
        s.set_direction_pin(PIN_UNDEFINED)
        return True
    values = _values(arg)
    if values is None:
        return False
    pin = values[0] & 0xFF
    app.print(msg.DIRECTION_PIN)
    app.print(msg.SET_TO_PIN)
    app.println_number(values[0])
    if len(values) == 1:
        s.set_direction_pin(pin)
        return True
    app.print(msg.DIRECTION_PIN)
    # sic: the firmware prints "down" for n != 0 although n != 0 means high counts up
    app.print(msg.HIGH_COUNT_DOWN if values[1] != 0 else msg.HIGH_COUNT_UP)
    app.println()
    if len(values) == 2:
        s.set_direction_pin(pin, values[1] != 0)
    else:
        app.print(msg.DELAY_IN_US)
        app.println_number(values[2])
        s.set_direction_pin(pin, values[1] != 0, values[2] & 0xFFFF)
    return True
