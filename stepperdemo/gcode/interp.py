"""G-code blocks -> actions, with the modal state (RS274/NGC as Grbl 1.1 keeps it).

Supported: G0 G1 (motion, modal), G4 P<seconds> (dwell), G90 G91 (absolute /
incremental), G92 (set the current position: an offset) and G92.1 (clear it);
G17 G18 G19 (plane: kept and reported; no arcs yet), G21 G54 G94 (what is already
so); M0 (pause: a feed hold once the motion before it is done) and M1 (optional
stop: ignored, as Grbl); M2 M30 (end of program); M62 M63 M64 M65 P<n> (digital
output n on/off, synchronized/immediate), M67 M68 E<n> Q<percent> (analog output,
synchronized/immediate); F (units per minute), S (spindle speed) and T (tool):
kept and reported.  Anything else is refused with Grbl's number (:mod:`.codes`):
G2/G3 arcs, G20, M3-M9 ... come with issue 25.

Within one block the actions happen in the order Grbl_ESP32 executes them: user
outputs, dwell, G92, motion, program flow (M0/M2).  Positions are tracked at the
end of everything queued before, so G91 and G92 refer to where the machine will be
when the block runs.  ``$J=`` jogs (:meth:`Interpreter.jog`) use the same words
and change no modal state.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from .. import messages as msg
from .codes import Err
from .parser import AXES, Block, GcodeError, code_name
from .settings import GcodeSettings

OUTPUTS = 4
INT32 = 2**31 - 1
MAX_TOOL = 255  # Grbl's MAX_TOOL_NUMBER

_G_MOTION = {0.0, 1.0}
_G_DISTANCE = {90.0, 91.0}
_G_PLANE = {17.0, 18.0, 19.0}
_G_OFFSET = {92.0, 92.1}
# accepted without effect: they state what is already so
_G_NOOP = {21.0: "units", 54.0: "coordinate system", 94.0: "feed mode"}
_M_OUTPUT = {62.0, 63.0, 64.0, 65.0, 67.0, 68.0}
_M_FLOW = {0.0, 1.0, 2.0, 30.0}
_M_SPINDLE = {3.0, 4.0, 5.0}
_M_COOLANT = {7.0, 8.0, 9.0}
_JOG_G = {20.0, 21.0, 53.0, 90.0, 91.0}


@dataclass(frozen=True)
class Move:
    target: tuple[int, ...]  # machine position in steps per axis after the move
    start: tuple[int, ...]  # ... before it
    rapid: bool
    feed: float | None  # units/min (G1, jog)
    line: str
    jog: bool = False


@dataclass(frozen=True)
class Dwell:
    seconds: float
    line: str


@dataclass(frozen=True)
class SetOutput:
    analog: bool
    number: int
    value: float  # digital: 1/0; analog: duty percent (clamped by the library)
    synchronized: bool
    line: str


@dataclass(frozen=True)
class SetOffset:
    """G92 / G92.1: the work offsets (units) from now on (after the motion before)."""

    offset: tuple[float, ...]
    line: str


@dataclass(frozen=True)
class Pause:
    """M0: once the motion before it is done, a feed hold until cycle start (~)."""

    line: str


@dataclass(frozen=True)
class End:
    line: str


Action = Move | Dwell | SetOutput | SetOffset | Pause | End


def _unsupported(letter: str, value: float) -> GcodeError:
    name = code_name(letter, value)
    if letter == "G" and value in (2.0, 3.0):
        return GcodeError(Err.UNSUPPORTED_COMMAND, msg.GCODE_ERR_ARCS.format(code=name))
    if letter == "G" and value == 20.0:
        return GcodeError(Err.UNSUPPORTED_COMMAND, msg.GCODE_ERR_INCHES)
    return GcodeError(Err.UNSUPPORTED_COMMAND, msg.GCODE_ERR_UNSUPPORTED.format(code=name))


def _modal(groups: dict[str, float], group: str, letter: str, value: float) -> None:
    if group in groups:
        raise GcodeError(Err.MODAL_GROUP_VIOLATION, msg.GCODE_ERR_MODAL.format(
            a=code_name(letter, groups[group]), b=code_name(letter, value)))
    groups[group] = value


class Interpreter:
    """The modal state of the program and the translation of blocks into actions."""

    def __init__(self, axes: int, settings: GcodeSettings,
                 check: Callable[[Action], None] | None = None) -> None:
        self.axes = axes
        self.settings = settings
        self.check = check  # refuses an action (GcodeError) before the block takes effect
        self.position_steps = [0] * axes  # machine position at the end of the queue
        self.reset()

    def reset(self) -> None:
        """Power-on / soft-reset modal state: G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0,
        no G92 offset."""
        self.motion = 0  # G0
        self.absolute = True
        self.plane = 17
        self.feed = 0.0
        self.spindle_speed = 0.0
        self.tool = 0
        self.offset = [0.0] * self.axes  # G92, in units
        self.program_end = False  # the last block ended the program (M2/M30)

    def end_of_program(self) -> None:
        """M2/M30 as Grbl: G1 G17 G90 G94 G54 M5 M9; the G92 offsets, F, S and T are
        kept (only a reset or G92.1 clears the offsets)."""
        self.motion = 1
        self.absolute = True
        self.plane = 17

    def sync_position(self, steps: list[int]) -> None:
        """The machine is where its steppers are (after an abort, a reset, a jog cancel)."""
        self.position_steps = list(steps)

    # ----------------------------------------------------------------- blocks
    def interpret(self, block: Block) -> list[Action]:
        """The actions of one block, in execution order (raises :class:`GcodeError`).

        The modal state changes only if the whole block is valid."""
        groups: dict[str, float] = {}
        for g in block.g:
            if g in _G_MOTION:
                _modal(groups, "motion", "G", g)
            elif g in _G_DISTANCE:
                _modal(groups, "distance", "G", g)
            elif g in _G_PLANE:
                _modal(groups, "plane", "G", g)
            elif g == 4.0 or g in _G_OFFSET:
                _modal(groups, "non-modal", "G", g)
            elif g in _G_NOOP:
                _modal(groups, _G_NOOP[g], "G", g)
            else:
                raise _unsupported("G", g)
        m_groups: dict[str, float] = {}
        for m in block.m:
            if m in _M_OUTPUT:
                _modal(m_groups, "output", "M", m)
            elif m in _M_FLOW:
                _modal(m_groups, "flow", "M", m)
            elif m in _M_SPINDLE or m in _M_COOLANT:
                raise _unsupported("M", m)  # issue 25
            else:
                raise _unsupported("M", m)
        g_motion = groups.get("motion")
        g_distance = groups.get("distance")
        g_nonmodal = groups.get("non-modal")
        g_dwell = g_nonmodal == 4.0
        g_92 = g_nonmodal if g_nonmodal in _G_OFFSET else None
        m_output = m_groups.get("output")
        m_flow = m_groups.get("flow")

        values = dict(block.values)
        values.pop("N", None)
        axis_words = self._axis_words(values)
        if g_92 == 92.0 and g_motion is not None and axis_words:
            raise GcodeError(Err.AXIS_COMMAND_CONFLICT, msg.GCODE_ERR_AXIS_CONFLICT.format(
                a="G92", b=code_name("G", g_motion)))

        # P: dwell time or digital output number, not both
        uses_p = [name for name, used in (("G4", g_dwell),
                                          (code_name("M", m_output or 0),
                                           m_output in (62.0, 63.0, 64.0, 65.0))) if used]
        if len(uses_p) > 1:
            raise GcodeError(Err.VALUE_WORD_MISSING,
                             msg.GCODE_ERR_P_CONFLICT.format(a=uses_p[0], b=uses_p[1]))

        feed = values.pop("F", self.feed)
        spindle = values.pop("S", self.spindle_speed)
        tool = self.tool
        if "T" in values:
            t = values.pop("T")
            if t != int(t):
                raise GcodeError(Err.COMMAND_VALUE_NOT_INTEGER,
                                 msg.GCODE_ERR_NOT_INTEGER.format(word=f"T{t:g}"))
            if t > MAX_TOOL:
                raise GcodeError(Err.MAX_VALUE_EXCEEDED,
                                 msg.GCODE_ERR_TOOL.format(tool=f"{t:g}", most=MAX_TOOL))
            tool = int(t)
        absolute = self.absolute if g_distance is None else g_distance == 90.0
        plane = self.plane if "plane" not in groups else int(groups["plane"])

        actions: list[Action] = []
        if m_output is not None:
            actions.append(self._output(m_output, values, block.line))
        if g_dwell:
            if "P" not in values:
                raise GcodeError(Err.VALUE_WORD_MISSING, msg.GCODE_ERR_DWELL_P)
            actions.append(Dwell(values.pop("P"), block.line))

        offset = list(self.offset)
        if g_92 == 92.0:
            if not axis_words:
                raise GcodeError(Err.NO_AXIS_WORDS, msg.GCODE_ERR_G92_AXES)
            for letter, v in axis_words.items():
                i = AXES.index(letter)
                offset[i] = self._units(i, self.position_steps[i]) - v
            actions.append(SetOffset(tuple(offset), block.line))
        elif g_92 == 92.1:
            offset = [0.0] * self.axes
            actions.append(SetOffset(tuple(offset), block.line))

        motion = self.motion if g_motion is None else int(g_motion)
        move = None
        if axis_words and g_92 != 92.0:
            if motion == 1 and feed <= 0:
                raise GcodeError(Err.UNDEFINED_FEED_RATE, msg.GCODE_ERR_NO_FEED)
            target = self._target(axis_words, absolute, offset)
            if target != self.position_steps:
                move = Move(tuple(target), tuple(self.position_steps), motion == 0,
                            feed if motion == 1 else None, block.line)
        elif g_motion == 1.0 and feed <= 0 and not axis_words:
            pass  # G1 alone sets the mode; the feed is checked when it moves
        unused = sorted(w for w in values if w not in AXES)
        if unused:
            raise GcodeError(Err.UNUSED_WORDS, msg.GCODE_ERR_UNUSED.format(
                words=" ".join(unused)))

        if move is not None:
            actions.append(move)
        if m_flow == 0.0:
            actions.append(Pause(block.line))
        elif m_flow in (2.0, 30.0):
            actions.append(End(block.line))
        if self.check is not None:
            for action in actions:
                self.check(action)
        # the block is valid: take its modal state
        self.feed = feed
        self.spindle_speed = spindle
        self.tool = tool
        self.absolute = absolute
        self.motion = motion
        self.plane = plane
        self.offset = offset
        if move is not None:
            self.position_steps = list(move.target)
        self.program_end = m_flow in (2.0, 30.0)
        if self.program_end:
            self.end_of_program()
        return actions

    def jog(self, block: Block) -> Move | None:
        """A ``$J=`` line's words -> the jog move (None: already there).  Jogs change no
        modal state except the position; F is required and always units/min."""
        g_distance = None
        machine = False
        for g in block.g:
            if g not in _JOG_G:
                raise GcodeError(Err.INVALID_JOG_COMMAND,
                                 msg.GCODE_ERR_JOG_CODE.format(code=code_name("G", g)))
            if g == 20.0:
                raise _unsupported("G", g)
            if g in _G_DISTANCE:
                if g_distance is not None:
                    raise GcodeError(Err.MODAL_GROUP_VIOLATION, msg.GCODE_ERR_MODAL.format(
                        a=code_name("G", g_distance), b=code_name("G", g)))
                g_distance = g
            machine = machine or g == 53.0
        if block.m:
            raise GcodeError(Err.INVALID_JOG_COMMAND,
                             msg.GCODE_ERR_JOG_CODE.format(code=code_name("M", block.m[0])))
        values = dict(block.values)
        values.pop("N", None)
        axis_words = self._axis_words(values)
        feed = values.pop("F", None)
        unused = sorted(w for w in values if w not in AXES)
        if unused:
            raise GcodeError(Err.UNUSED_WORDS, msg.GCODE_ERR_UNUSED.format(
                words=" ".join(unused)))
        if not axis_words:
            raise GcodeError(Err.NO_AXIS_WORDS, msg.GCODE_ERR_JOG_AXES)
        if feed is None or feed <= 0:
            raise GcodeError(Err.UNDEFINED_FEED_RATE, msg.GCODE_ERR_JOG_FEED)
        absolute = self.absolute if g_distance is None else g_distance == 90.0
        offset = [0.0] * self.axes if machine else self.offset
        target = self._target(axis_words, absolute or machine, offset)
        if target == self.position_steps:
            return None
        move = Move(tuple(target), tuple(self.position_steps), False, feed, block.line,
                    jog=True)
        if self.check is not None:
            self.check(move)
        self.position_steps = list(target)
        return move

    # ---------------------------------------------------------------- helpers
    def _axis_words(self, values: dict[str, float]) -> dict[str, float]:
        words = {k: v for k, v in values.items() if k in AXES}
        for letter in words:
            if AXES.index(letter) >= self.axes:
                raise GcodeError(Err.UNSUPPORTED_COMMAND, msg.GCODE_ERR_NO_AXIS.format(
                    letter=letter, n=AXES.index(letter) + 1, axes=AXES[:self.axes]))
        return words

    def _target(self, axis_words: dict[str, float], absolute: bool,
                offset: list[float]) -> list[int]:
        target = list(self.position_steps)
        for letter, v in axis_words.items():
            i = AXES.index(letter)
            work = v if absolute else self._units(i, self.position_steps[i]) - offset[i] + v
            steps = (work + offset[i]) * self.settings.steps_per_unit[i]
            if not -INT32 <= steps <= INT32:
                raise GcodeError(Err.INVALID_TARGET, msg.GCODE_ERR_RANGE.format(letter=letter))
            target[i] = int(math.floor(steps + 0.5))
        return target

    def _output(self, code: float, values: dict[str, float], line: str) -> SetOutput:
        name = code_name("M", code)
        if code in (62.0, 63.0, 64.0, 65.0):
            if "P" not in values:
                raise GcodeError(Err.VALUE_WORD_MISSING, msg.GCODE_ERR_NEEDS_P.format(code=name))
            number = _output_number("P", values.pop("P"))
            return SetOutput(False, number, 1.0 if code in (62.0, 64.0) else 0.0,
                             code in (62.0, 63.0), line)
        missing = [w for w in ("E", "Q") if w not in values]
        if missing:
            raise GcodeError(Err.VALUE_WORD_MISSING, msg.GCODE_ERR_NEEDS_EQ.format(
                code=name, missing=" and ".join(missing)))
        number = _output_number("E", values.pop("E"))
        return SetOutput(True, number, values.pop("Q"), code == 67.0, line)

    def _units(self, axis: int, steps: int) -> float:
        return steps / self.settings.steps_per_unit[axis]

    def work_position(self, steps: list[int]) -> list[float]:
        return [self._units(i, s) - self.offset[i] for i, s in enumerate(steps)]


def _output_number(letter: str, value: float) -> int:
    if value != int(value) or not 0 <= value < OUTPUTS:
        raise GcodeError(Err.PARAMETER_OUT_OF_RANGE, msg.GCODE_ERR_OUTPUT_RANGE.format(
            letter=letter, value=f"{value:g}", last=OUTPUTS - 1))
    return int(value)
