"""G-code blocks -> actions, with the modal state (RS274/NGC as Grbl keeps it).

Supported: G0 G1 (motion, modal), G4 P<seconds> (dwell), G90 G91 (absolute /
incremental), G92 (set the current position: an offset) and G92.1 (clear it);
G17 G21 G54 G94 are accepted as what they already are (XY plane, units as set,
the one coordinate system, feed per minute); M62 M63 M64 M65 P<n> (digital output
n on/off, synchronized/immediate), M67 M68 E<n> Q<percent> (analog output,
synchronized/immediate), M2 M30 (end of program); F (units per minute, modal).

Within one block the actions happen in this order: feed rate, distance mode,
output changes, dwell, G92, motion, end of program (the order of execution of
RS274/NGC).  Positions are tracked at the end of everything queued before, so
G91 and G92 refer to where the machine will be when the block runs.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from .. import messages as msg
from .parser import AXES, Block, GcodeError, code_name
from .settings import GcodeSettings

OUTPUTS = 4
INT32 = 2**31 - 1

# G codes accepted without effect: they state what is already so
_G_NOOP = {17.0, 21.0, 54.0, 94.0}
_G_KNOWN = {0.0, 1.0, 4.0, 90.0, 91.0, 92.0, 92.1} | _G_NOOP
_M_OUTPUT = {62.0, 63.0, 64.0, 65.0, 67.0, 68.0}
_M_END = {2.0, 30.0}


@dataclass(frozen=True)
class Move:
    target: tuple[int, ...]  # machine position in steps per axis after the move
    start: tuple[int, ...]  # ... before it
    rapid: bool
    feed: float | None  # units/min (G1)
    line: str


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
class End:
    line: str


Action = Move | Dwell | SetOutput | End


class Interpreter:
    """The modal state of the program and the translation of blocks into actions."""

    def __init__(self, axes: int, settings: GcodeSettings,
                 check: Callable[[Action], None] | None = None) -> None:
        self.axes = axes
        self.settings = settings
        self.check = check  # refuses an action (GcodeError) before the block takes effect
        self.reset()
        self.position_steps = [0] * axes  # machine position at the end of the queue

    def reset(self) -> None:
        """Power-on / end-of-program modal state (G0 G90 G94, no offset kept by M2)."""
        self.motion = 0  # G0
        self.absolute = True
        self.feed: float | None = None
        self.offset = [0.0] * self.axes  # G92, in units

    def end_of_program(self) -> None:
        """M2/M30: Grbl's reset of the modal state (motion, distance, feed; G92 offsets
        are cleared as by G92.1)."""
        self.motion = 1
        self.absolute = True
        self.offset = [0.0] * self.axes

    def sync_position(self, steps: list[int]) -> None:
        """The machine is where its steppers are (after an abort or a reset)."""
        self.position_steps = list(steps)

    # ----------------------------------------------------------------- blocks
    def interpret(self, block: Block) -> list[Action]:
        """The actions of one block, in execution order (raises :class:`GcodeError`).

        The modal state changes only if the whole block is valid."""
        g_motion = None
        g_distance = None
        g_dwell = False
        g_92 = None
        for g in block.g:
            if g not in _G_KNOWN:
                if g == 20.0:
                    raise GcodeError(msg.GCODE_ERR_INCHES)
                raise GcodeError(msg.GCODE_ERR_UNSUPPORTED.format(code=code_name("G", g)))
            if g in (0.0, 1.0):
                if g_motion is not None:
                    raise GcodeError(msg.GCODE_ERR_MODAL.format(
                        a=code_name("G", g_motion), b=code_name("G", g)))
                g_motion = g
            elif g in (90.0, 91.0):
                if g_distance is not None:
                    raise GcodeError(msg.GCODE_ERR_MODAL.format(
                        a=code_name("G", g_distance), b=code_name("G", g)))
                g_distance = g
            elif g == 4.0:
                g_dwell = True
            elif g in (92.0, 92.1):
                if g_92 is not None:
                    raise GcodeError(msg.GCODE_ERR_MODAL.format(
                        a=code_name("G", g_92), b=code_name("G", g)))
                g_92 = g
        m_output = None
        m_end = None
        for m in block.m:
            if m in _M_OUTPUT:
                if m_output is not None:
                    raise GcodeError(msg.GCODE_ERR_MODAL.format(
                        a=code_name("M", m_output), b=code_name("M", m)))
                m_output = m
            elif m in _M_END:
                if m_end is not None:
                    raise GcodeError(msg.GCODE_ERR_MODAL.format(
                        a=code_name("M", m_end), b=code_name("M", m)))
                m_end = m
            else:
                raise GcodeError(msg.GCODE_ERR_UNSUPPORTED.format(code=code_name("M", m)))

        values = dict(block.values)
        values.pop("N", None)
        axis_words = {k: v for k, v in values.items() if k in AXES}
        for letter in axis_words:
            if AXES.index(letter) >= self.axes:
                raise GcodeError(msg.GCODE_ERR_NO_AXIS.format(
                    letter=letter, n=AXES.index(letter) + 1, axes=AXES[:self.axes]))
        if g_92 == 92.0 and g_motion is not None and axis_words:
            raise GcodeError(msg.GCODE_ERR_AXIS_CONFLICT.format(
                a="G92", b=code_name("G", g_motion)))
        if g_92 == 92.1 and axis_words:
            raise GcodeError(msg.GCODE_ERR_UNUSED.format(words=" ".join(sorted(axis_words))))

        # P: dwell time or digital output number, not both
        uses_p = [name for name, used in (("G4", g_dwell),
                                          (code_name("M", m_output or 0),
                                           m_output in (62.0, 63.0, 64.0, 65.0))) if used]
        if len(uses_p) > 1:
            raise GcodeError(msg.GCODE_ERR_P_CONFLICT.format(a=uses_p[0], b=uses_p[1]))
        unused = []
        if "P" in values and not uses_p:
            unused.append("P")
        if m_output not in (67.0, 68.0):
            unused += [w for w in ("E", "Q") if w in values]
        if unused:
            raise GcodeError(msg.GCODE_ERR_UNUSED.format(words=" ".join(unused)))

        feed = self.feed
        if "F" in values:
            if values["F"] <= 0:
                raise GcodeError(msg.GCODE_ERR_FEED_POSITIVE)
            feed = values["F"]
        absolute = self.absolute if g_distance is None else g_distance == 90.0

        actions: list[Action] = []
        if m_output is not None:
            actions.append(self._output(m_output, values, block.line))
        if g_dwell:
            if "P" not in values:
                raise GcodeError(msg.GCODE_ERR_DWELL_P)
            if values["P"] < 0:
                raise GcodeError(msg.GCODE_ERR_DWELL_NEGATIVE)
            actions.append(Dwell(values["P"], block.line))

        offset = list(self.offset)
        if g_92 == 92.0:
            if not axis_words:
                raise GcodeError(msg.GCODE_ERR_G92_AXES)
            for letter, v in axis_words.items():
                i = AXES.index(letter)
                offset[i] = self._units(i, self.position_steps[i]) - v
        elif g_92 == 92.1:
            offset = [0.0] * self.axes

        motion = self.motion if g_motion is None else int(g_motion)
        move = None
        if axis_words and g_92 is None:
            if motion == 1 and feed is None:
                raise GcodeError(msg.GCODE_ERR_NO_FEED)
            target = list(self.position_steps)
            for letter, v in axis_words.items():
                i = AXES.index(letter)
                work = v if absolute else self._units(i, self.position_steps[i]) - offset[i] + v
                steps = (work + offset[i]) * self.settings.steps_per_unit[i]
                if not -INT32 <= steps <= INT32:
                    raise GcodeError(msg.GCODE_ERR_RANGE.format(letter=letter))
                target[i] = int(math.floor(steps + 0.5))
            if target != self.position_steps:
                move = Move(tuple(target), tuple(self.position_steps), motion == 0,
                            feed, block.line)

        if move is not None:
            actions.append(move)
        if m_end is not None:
            actions.append(End(block.line))
        if self.check is not None:
            for action in actions:
                self.check(action)
        # the block is valid: take its modal state
        self.feed = feed
        self.absolute = absolute
        self.motion = motion
        self.offset = offset
        if move is not None:
            self.position_steps = list(move.target)
        if m_end is not None:
            self.end_of_program()
        return actions

    def _output(self, code: float, values: dict[str, float], line: str) -> SetOutput:
        name = code_name("M", code)
        if code in (62.0, 63.0, 64.0, 65.0):
            if "P" not in values:
                raise GcodeError(msg.GCODE_ERR_NEEDS_P.format(code=name))
            number = _output_number("P", values["P"])
            return SetOutput(False, number, 1.0 if code in (62.0, 64.0) else 0.0,
                             code in (62.0, 63.0), line)
        missing = [w for w in ("E", "Q") if w not in values]
        if missing:
            raise GcodeError(msg.GCODE_ERR_NEEDS_EQ.format(code=name,
                                                           missing=" and ".join(missing)))
        number = _output_number("E", values["E"])
        return SetOutput(True, number, values["Q"], code == 67.0, line)

    def _units(self, axis: int, steps: int) -> float:
        return steps / self.settings.steps_per_unit[axis]

    def work_position(self, steps: list[int]) -> list[float]:
        return [self._units(i, s) - self.offset[i] for i, s in enumerate(steps)]


def _output_number(letter: str, value: float) -> int:
    if value != int(value) or not 0 <= value < OUTPUTS:
        raise GcodeError(msg.GCODE_ERR_OUTPUT_RANGE.format(
            letter=letter, value=f"{value:g}", last=OUTPUTS - 1))
    return int(value)
