"""Grbl 1.1's ``$`` commands and settings on the G-code machine.

:func:`dollar` takes a filtered ``$`` line (upper case, no spaces) and either
prints its answer lines and returns None (the caller answers ``ok``), returns
actions to execute before the ``ok`` (``$J=``: a jog), or returns a callable to run
after the ``ok`` (``$C`` off, ``$RST=``: a soft reset; ``$SLP``).  A refusal raises
:class:`~.parser.GcodeError` with Grbl's number.  Which states allow what is
Grbl's (its ``system.c``): ``$$`` not in Run/Hold, ``$J=`` only in Idle/Jog, ``$C``
only in Idle (or to leave Check), the rest that changes something only in Idle or
Alarm.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable
from typing import TYPE_CHECKING

from fas.outputs import OutputResult

from .. import messages as msg
from . import reports
from .codes import Err
from .interp import Action
from .parser import GcodeError, parse_line
from .settings import (
    FIXED,
    KEEP_ENABLED,
    KEPT,
    PLAIN_CORNER_MAX,
    SWITCHES,
    GcodeSettings,
    axis_setting,
    output_setting,
)

if TYPE_CHECKING:  # pragma: no cover
    from .machine import GcodeMachine

Outcome = Callable[[], None] | list[Action] | None
_SETTING = re.compile(r"(\d+(?:\.\d*)?)=(.*)")
_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)")
STARTUP_LINES = 2
MAX_STORED = 79  # characters of a startup line or the build info (Grbl's EEPROM room)


def _idle_or_alarm(m: GcodeMachine) -> None:
    if m.state_name() not in ("Idle", "Alarm"):
        raise GcodeError(Err.IDLE_ERROR, msg.GCODE_ERR_NOT_IDLE.format(
            state=m.state_name()))


def dollar(m: GcodeMachine, text: str) -> Outcome:
    """Execute one ``$`` line (see the module text)."""
    body = text[1:]
    state = m.state_name()
    if body == "":
        m.write(msg.GRBL_HELP)
        return None
    if body.startswith("J"):
        return _jog(m, body, state)
    if body[0] in "$GCX":  # Grbl: these take nothing after the letter
        if len(body) > 1:
            raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_DOLLAR.format(text=text))
        return _simple(m, body, state)
    _idle_or_alarm(m)
    first = body[0]
    if first == "#":
        if body != "#":
            raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_DOLLAR.format(text=text))
        for line in reports.parameters(m):
            m.write(line)
        return None
    if first == "H":
        if body != "H":
            raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_DOLLAR.format(text=text))
        raise GcodeError(Err.SETTING_DISABLED, msg.GCODE_ERR_HOMING.format(
            profile=m.backend.profile.name))
    if first == "S":
        if body != "SLP":
            raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_DOLLAR.format(text=text))
        return m.sleep
    if first == "I":
        if body == "I":
            for line in reports.build_info(m):
                m.write(line)
            return None
        if not body.startswith("I="):
            raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_DOLLAR.format(text=text))
        info = text[3:]
        if len(info) > MAX_STORED:
            raise GcodeError(Err.LINE_LENGTH_EXCEEDED, msg.GCODE_ERR_STORED_LONG.format(
                n=MAX_STORED))
        m.settings.build_info = info
        return None
    if first == "R":
        what = body[4:] if body.startswith("RST=") else ""
        if what not in ("$", "#", "*"):
            raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_DOLLAR.format(text=text))
        m.write(msg.GRBL_RESTORING)
        if what in ("$", "*"):
            m.restore_settings(startup=(what == "*"))
        if what in ("#", "*"):
            m.interp.clear_coordinates()  # G54-G59, G28, G30
        return m.soft_reset
    if first == "N":
        if body == "N":
            for n, line in enumerate(m.settings.startup):
                m.write(f"$N{n}={line}")
            return None
        return _startup_line(m, body, text)
    match = _SETTING.fullmatch(body)
    if match is None:
        if not _NUMBER.match(body):
            raise GcodeError(Err.BAD_NUMBER_FORMAT, msg.GCODE_ERR_DOLLAR.format(text=text))
        raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_DOLLAR.format(text=text))
    number_text, value_text = match.groups()
    if not _NUMBER.fullmatch(value_text):
        raise GcodeError(Err.BAD_NUMBER_FORMAT,
                         msg.GCODE_ERR_SETTING_VALUE.format(text=value_text or "?"))
    number = float(number_text)
    if number != int(number):
        raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_NO_SETTING.format(
            n=number_text))
    set_setting(m, int(number), float(value_text))
    return None


def _simple(m: GcodeMachine, body: str, state: str) -> Outcome:
    """``$$``, ``$G``, ``$C``, ``$X``."""
    if body == "$":
        if state.startswith(("Run", "Hold")):
            raise GcodeError(Err.IDLE_ERROR, msg.GCODE_ERR_NOT_IDLE.format(state=state))
        for line in reports.settings_lines(m):
            m.write(line)
        return None
    if body == "G":
        m.write(reports.parser_state(m))
        return None
    if body == "X":
        if m.alarm is not None:
            m.unlock()
        return None
    if m.check_mode:  # $C
        m.write(msg.GRBL_DISABLED)
        return m.soft_reset
    if state != "Idle":
        raise GcodeError(Err.IDLE_ERROR, msg.GCODE_ERR_NOT_IDLE.format(state=state))
    m.check_mode = True
    m.write(msg.GRBL_ENABLED)
    return None


def _jog(m: GcodeMachine, body: str, state: str) -> Outcome:
    if not body.startswith("J="):
        raise GcodeError(Err.INVALID_JOG_COMMAND, msg.GCODE_ERR_JOG_FORM)
    if state not in ("Idle", "Jog"):
        raise GcodeError(Err.IDLE_ERROR, msg.GCODE_ERR_JOG_STATE.format(state=state))
    move = m.interp.jog(parse_line(body[2:]))
    return [] if move is None else [move]


def _startup_line(m: GcodeMachine, body: str, text: str) -> Outcome:
    index, _, line = body[1:].partition("=")
    if not index.isdigit() or int(index) >= STARTUP_LINES:
        raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_DOLLAR.format(text=text))
    if m.state_name() != "Idle":
        raise GcodeError(Err.IDLE_ERROR, msg.GCODE_ERR_NOT_IDLE.format(state=m.state_name()))
    line = text[text.index("=") + 1:]
    if len(line) > MAX_STORED:
        raise GcodeError(Err.LINE_LENGTH_EXCEEDED, msg.GCODE_ERR_STORED_LONG.format(
            n=MAX_STORED))
    if line:
        m.check_line(line)  # refused lines are not stored (Grbl runs it once to see)
    m.settings.startup[int(index)] = line
    return None


# ------------------------------------------------------------------ settings
def set_setting(m: GcodeMachine, number: int, value: float) -> None:
    """``$number=value`` (raises :class:`GcodeError` with Grbl's number)."""
    if not math.isfinite(value):  # pragma: no cover - the pattern has no exponent
        raise GcodeError(Err.BAD_NUMBER_FORMAT, msg.GCODE_ERR_SETTING_VALUE.format(
            text=f"{value}"))
    if value < 0:
        raise GcodeError(Err.NEGATIVE_VALUE, msg.GCODE_ERR_SETTING_RANGE.format(
            n=number, range=">= 0"))
    st = m.settings
    if number in FIXED:
        if number == 0 and value < 3:
            raise GcodeError(Err.SETTING_STEP_PULSE_MIN, msg.GCODE_ERR_SETTING_RANGE.format(
                n=0, range=">= 3"))
        if value != FIXED[number]:
            raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_SETTING_FIXED.format(
                n=number, value=FIXED[number]))
        return
    if number in SWITCHES:
        if value == 0:
            return
        if number == 20:
            raise GcodeError(Err.SOFT_LIMIT_ERROR, msg.GCODE_ERR_SOFT_LIMITS)
        raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_HOMING.format(
            profile=m.backend.profile.name))
    if number == 32:
        if value not in (0, 1):
            raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_SETTING_RANGE.format(
                n=number, range="0 or 1"))
        if value and m.tooling.spindle_output() is None:
            raise GcodeError(Err.SETTING_DISABLED_LASER, msg.GCODE_ERR_LASER.format(
                profile=m.backend.profile.name))
    if number == 12 and value <= 0:
        raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_SETTING_RANGE.format(
            n=number, range="> 0"))
    if number in KEPT:
        st.kept[number] = value
        return
    if number == 1:
        if value != int(value) or value > KEEP_ENABLED:
            raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_SETTING_RANGE.format(
                n=number, range="0..255"))
        st.idle_delay_ms = int(value)
        return
    if number == 10:
        if value != int(value) or value > 3:
            raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_SETTING_RANGE.format(
                n=number, range="0..3"))
        st.status_mask = int(value)
        return
    if number == 170:
        if value not in (0, 1):
            raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_SETTING_RANGE.format(
                n=number, range="0 or 1"))
        st.report_outputs = bool(value)
        return
    if number == 171:  # issue 25: the executor
        if value not in (0, 1):
            raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_SETTING_RANGE.format(
                n=number, range="0 or 1"))
        st.motion = int(value)
        return
    if number == 172:  # corners: Grbl's junctions or blends (fas.path)
        if value not in (0, 1):
            raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_SETTING_RANGE.format(
                n=number, range="0 or 1"))
        st.corner_blends = bool(value)
        return
    if number == 173:  # with blends: corners no step tells from Grbl's (fas.path)
        if not 0.0 <= value <= PLAIN_CORNER_MAX:
            raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_SETTING_RANGE.format(
                n=number, range=f"0 .. {PLAIN_CORNER_MAX:g}"))
        st.plain_corner_steps = float(value)
        return
    axis = axis_setting(number)
    if axis is not None:
        base, i = axis
        if i >= max(reports.REPORT_AXES, m.axes):
            raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_NO_SETTING.format(n=number))
        if value <= 0 and base != 130:
            raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_SETTING_RANGE.format(
                n=number, range="> 0"))
        if m.executor.busy():
            raise GcodeError(Err.IDLE_ERROR, msg.GCODE_ERR_NOT_IDLE.format(
                state=m.state_name()))
        st.axis_values(base)[i] = value
        if base == 100:
            m.interp.sync_position(m.positions())
        return
    out = output_setting(number)
    if out is None:
        raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_NO_SETTING.format(n=number))
    base, n = out
    outputs = m.engine.outputs
    if base == 140:
        res = outputs.set_frequency(n, value)
        if res != OutputResult.OK:
            raise GcodeError(Err.INVALID_STATEMENT, m.output_problem(res, True, n, hz=value))
        return
    if value != int(value) or not 0 <= value < 128:
        raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_SETTING_RANGE.format(
            n=number, range="0..127"))
    if base == 150:
        res = outputs.set_digital_pin(n, int(value))
    else:
        res = outputs.set_analog_pin(n, int(value))
    if res != OutputResult.OK:
        raise GcodeError(Err.INVALID_STATEMENT,
                         m.output_problem(res, base == 160, n, pin=int(value)))


def restore_defaults(st: GcodeSettings, startup: bool) -> None:
    """``$RST=$`` (and ``*``): the settings as at the start; ``*`` also the startup
    lines and the build info."""
    fresh = GcodeSettings()
    keep = (st.startup, st.build_info)
    st.__dict__.update(fresh.__dict__)
    if not startup:
        st.startup, st.build_info = keep
