"""G-code blocks -> actions, with the modal state (RS274/NGC as Grbl 1.1 keeps it).

Words (``docs/gcode.md`` has the table and the differences from Grbl):

* **Motion** (modal): G0 rapid, G1 line at F, G2/G3 arc clockwise / counter-clockwise
  in the plane G17 (XY), G18 (ZX) or G19 (YZ) - centre by I/J/K offsets or by R
  (negative: the arc of more than 180 degrees), the plane's third axis moving in
  proportion (a helix); the arc becomes straight segments within the arc tolerance
  ``$12`` (:func:`fas.path.arc.arc_points`), each an ordinary :class:`Move`.  G80
  (motion off).  G38.2-G38.5 (probing, :mod:`.probe`) are read and checked; the
  machine refuses them where the profile has no probe input.
* **Units, distances, feed**: G20 inches / G21 mm (every length and F of the block
  times 25.4 inside), G90 / G91 absolute / incremental, G91.1 (I/J/K are always
  incremental), G93 inverse time (each G1/G2/G3 block in 1/F minutes: its moves get
  the feed length x F) / G94 units per minute.
* **Coordinates**: G54-G59 (six work coordinate systems, set by G10 L2 P0-6 to values
  or by G10 L20 so that the present position gets the values), G92 / G92.1 (an offset
  on top), G43.1 Z / G49 (tool length offset on Z), G53 (this block in machine
  coordinates), G28 / G30 (rapid to a stored position, through the axis words'
  point if given) and G28.1 / G30.1 (store the present position).  The coordinate
  systems and G28/G30 are kept over a reset (Grbl keeps them in EEPROM) until
  ``$RST=#``; G92 and the tool length offset are not.
* **Spindle and coolant**: S, M3 / M4 / M5, M7 / M8 / M9 - actions for the outputs
  that :mod:`.tooling` maps per profile; in laser mode (``$32=1``) each move carries
  the laser power it runs with (:class:`Laser`), Grbl 1.1's rules: only G1/G2/G3
  moves are powered, M4 power follows the speed.  T (tool number) is kept, M6 is
  accepted and does nothing (Grbl_ESP32).
* **Program**: G4 P dwell, M0 pause, M1 (ignored), M2 / M30 end; G40 G61 (what is
  already so); M62-M65 P / M67-M68 E Q (user outputs, synchronized or at once).

Anything else is refused with Grbl's number (:mod:`.codes`).  Within one block the
actions come in the order Grbl executes them: spindle, coolant, user outputs, dwell,
offsets (G10 G92 G43.1 G54...), motion (G28/G30 too), program flow.  Positions are
tracked at the end of everything queued before (in units, as Grbl's parser does, and
in steps), so G91, G92 and arcs refer to where the machine will be when the block
runs.  ``$J=`` jogs (:meth:`Interpreter.jog`) use the same words and change no modal
state.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from fas.path.arc import (
    ArcError,
    Plane,
    arc_center_from_radius,
    arc_end_approach,
    arc_end_cut,
    arc_points,
    arc_segments,
    arc_travel,
    check_arc_offsets,
)

from .. import messages as msg
from .codes import Err
from .parser import AXES, Block, GcodeError, code_name
from .settings import GcodeSettings

OUTPUTS = 4
INT32 = 2**31 - 1
MAX_TOOL = 255  # Grbl's MAX_TOOL_NUMBER
MM_PER_INCH = 25.4
COORD_SYSTEMS = 6  # G54 .. G59
TLO_AXIS = 2  # the tool length offset is on Z (Grbl's TOOL_LENGTH_OFFSET_AXIS)
LASER_MODE = 32  # the setting
ARC_TOLERANCE = 12
MAX_ARC_SEGMENTS = 65535  # Grbl counts them in 16 bits; a larger arc gets longer chords

# every G code this interpreter reads -> its modal group (Grbl's groups)
_G_GROUPS: dict[float, str] = {
    **{g: "motion" for g in (0.0, 1.0, 2.0, 3.0, 38.2, 38.3, 38.4, 38.5, 80.0)},
    **{g: "non-modal" for g in (4.0, 10.0, 28.0, 28.1, 30.0, 30.1, 53.0, 92.0, 92.1)},
    17.0: "plane", 18.0: "plane", 19.0: "plane",
    90.0: "distance", 91.0: "distance", 91.1: "arc distance",
    93.0: "feed mode", 94.0: "feed mode", 20.0: "units", 21.0: "units", 40.0: "cutter compensation",
    43.1: "tool length", 49.0: "tool length",
    **{float(g): "coordinate system" for g in range(54, 60)},
    61.0: "path control",
}
# G codes that take the axis words (Grbl's axis commands; G28.1 G30.1 G92.1 do not)
_AXIS_NON_MODAL = {10.0, 28.0, 30.0, 92.0}
_PROBES = {38.2, 38.3, 38.4, 38.5}
_M_GROUPS: dict[float, str] = {
    0.0: "flow", 1.0: "flow", 2.0: "flow", 30.0: "flow",
    3.0: "spindle", 4.0: "spindle", 5.0: "spindle",
    6.0: "tool change",
    7.0: "coolant", 8.0: "coolant", 9.0: "coolant",
    **{m: "output" for m in (62.0, 63.0, 64.0, 65.0, 67.0, 68.0)},
}
_JOG_G = {20.0, 21.0, 53.0, 90.0, 91.0}
_POWERED = (1, 2, 3)  # motion modes that may power a laser
SPINDLE_OFF, SPINDLE_CW, SPINDLE_CCW = 5, 3, 4


@dataclass(frozen=True)
class Laser:
    """The laser power a move runs with in laser mode (``$32=1``, Grbl 1.1's rules)."""

    dynamic: bool  # M4: the power follows the speed along the path (S at the feed F)
    speed: float  # S for this move (0: unpowered - a G0, or S0)
    feed: float  # the programmed feed, units/min (the speed at which M4 gives S)


@dataclass(frozen=True)
class Move:
    target: tuple[int, ...]  # machine position in steps per axis after the move
    start: tuple[int, ...]  # ... before it
    rapid: bool
    feed: float | None  # units/min (G1, G2/G3 segments, jog)
    line: str
    jog: bool = False
    laser: Laser | None = None  # laser mode: the power of this move (None: leave it)
    #: an arc's chord end as it is, in steps (not rounded: ``target`` rounds it) - the
    #: point the path goes through; None: ``target``
    exact: tuple[float, ...] | None = None


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
    """G92 G10 G43.1 G49 G54..: the work coordinate offset (units, machine position
    minus work position, per axis) from now on (after the motion before)."""

    offset: tuple[float, ...]
    line: str


@dataclass(frozen=True)
class SetSpindle:
    """M3/M4/M5 or a new S: after the motion before it, the spindle runs ``state``
    (3 CW, 4 CCW, 5 off) at ``speed`` (S, before the spindle override)."""

    state: int
    speed: float
    line: str


@dataclass(frozen=True)
class SetCoolant:
    """M7/M8/M9: after the motion before it, mist and flood on or off."""

    mist: bool
    flood: bool
    line: str


@dataclass(frozen=True)
class Probe:
    """G38.2-G38.5: move towards ``move.target`` until the probe input changes."""

    move: Move
    toward: bool  # G38.2/G38.3: until it touches; G38.4/G38.5: until it leaves
    fail_is_error: bool  # G38.2/G38.4: no contact is an alarm
    code: float
    line: str


@dataclass(frozen=True)
class Pause:
    """M0: once the motion before it is done, a feed hold until cycle start (~)."""

    line: str


@dataclass(frozen=True)
class End:
    """M2/M30: after the motion before it - spindle and coolant off, G54's offset."""

    line: str
    offset: tuple[float, ...] = ()


Action = Move | Dwell | SetOutput | SetOffset | SetSpindle | SetCoolant | Probe | Pause | End


@dataclass
class CoordData:
    """What Grbl keeps in EEPROM (``$#``): G54-G59 and the G28/G30 positions, in
    machine units; kept over a reset, zeroed by ``$RST=#``."""

    axes: int
    systems: list[list[float]] = field(default_factory=list)
    g28: list[float] = field(default_factory=list)
    g30: list[float] = field(default_factory=list)

    def __post_init__(self) -> None:
        if not self.systems:
            self.clear()

    def clear(self) -> None:
        self.systems = [[0.0] * self.axes for _ in range(COORD_SYSTEMS)]
        self.g28 = [0.0] * self.axes
        self.g30 = [0.0] * self.axes


def _unsupported(letter: str, value: float, why: str = "") -> GcodeError:
    name = code_name(letter, value)
    return GcodeError(Err.UNSUPPORTED_COMMAND,
                      why or msg.GCODE_ERR_UNSUPPORTED.format(code=name))


def _modal(groups: dict[str, float], group: str, letter: str, value: float) -> None:
    if group in groups:
        raise GcodeError(Err.MODAL_GROUP_VIOLATION, msg.GCODE_ERR_MODAL.format(
            a=code_name(letter, groups[group]), b=code_name(letter, value)))
    groups[group] = value


def _g_code_name(motion: float) -> str:
    return code_name("G", motion)


class Interpreter:
    """The modal state of the program and the translation of blocks into actions."""

    def __init__(self, axes: int, settings: GcodeSettings,
                 check: Callable[[Action], None] | None = None) -> None:
        self.axes = axes
        self.settings = settings
        self.check = check  # refuses an action (GcodeError) before the block takes effect
        self.position_steps = [0] * axes  # machine position at the end of the queue
        self.position = [0.0] * axes  # ... in units (as Grbl's parser keeps it)
        self.coords = CoordData(axes)
        self.reset()

    def reset(self) -> None:
        """Power-on / soft-reset modal state: G0 G54 G17 G21 G90 G94 M5 M9 T0 F0 S0,
        no G92 offset, no tool length offset (G54-G59, G28, G30 are kept)."""
        self.motion = 0.0  # G0 (G38.2 ... as 38.2, G80 as 80.0)
        self.absolute = True
        self.plane = 17
        self.inches = False
        self.coord_select = 0  # G54
        self.feed = 0.0  # units/min (G93: 1/min, for this block only)
        self.inverse_time = False  # G93
        self.spindle_speed = 0.0
        self.spindle = SPINDLE_OFF
        self.mist = self.flood = False
        self.tool = 0
        self.offset = [0.0] * self.axes  # G92, in units
        self.tlo = 0.0  # G43.1, on Z
        self.program_end = False  # the last block ended the program (M2/M30)

    def end_of_program(self) -> None:
        """M2/M30 as Grbl: G1 G17 G90 G94 G54 M5 M9; the G92 offsets, the tool length
        offset, G20/G21, F, S and T are kept."""
        self.motion = 1
        self.absolute = True
        self.plane = 17
        self.inverse_time = False
        self.coord_select = 0
        self.spindle = SPINDLE_OFF
        self.mist = self.flood = False

    def sync_position(self, steps: list[int]) -> None:
        """The machine is where its steppers are (after an abort, a reset, a jog cancel)."""
        self.position_steps = list(steps)
        self.position = [self._units(i, s) for i, s in enumerate(steps)]

    def snapshot(self) -> dict:
        """Everything :meth:`interpret` may change (``restore`` puts it back)."""
        return copy.deepcopy({k: v for k, v in self.__dict__.items()
                              if k not in ("settings", "check")})

    def restore(self, saved: dict) -> None:
        self.__dict__.update(saved)

    def clear_coordinates(self) -> None:
        """``$RST=#``: G54-G59, G28 and G30 zero."""
        self.coords.clear()

    # ----------------------------------------------------------------- facts
    @property
    def laser_mode(self) -> bool:
        return bool(self.settings.kept.get(LASER_MODE, 0))

    def work_offset(self, system: list[float] | None = None,
                    offset: list[float] | None = None, tlo: float | None = None
                    ) -> tuple[float, ...]:
        """Machine minus work position per axis: the coordinate system + G92 + TLO."""
        if system is None:
            system = self.coords.systems[self.coord_select]
        g92 = self.offset if offset is None else offset
        t = self.tlo if tlo is None else tlo
        return tuple([system[i] + g92[i] + (t if i == TLO_AXIS else 0.0)
                      for i in range(self.axes)])

    def work_position(self, steps: list[int]) -> list[float]:
        wco = self.work_offset()
        return [self._units(i, s) - wco[i] for i, s in enumerate(steps)]

    # ----------------------------------------------------------------- blocks
    def interpret(self, block: Block) -> list[Action]:
        """The actions of one block, in execution order (raises :class:`GcodeError`).

        The modal state changes only if the whole block is valid."""
        plain = self._plain_move(block)
        if plain is not None:
            return plain
        groups: dict[str, float] = {}
        axis_command: float | None = None  # the G code that takes the axis words
        axis_kind = ""  # "motion", "non-modal", "tool length"
        for g in block.g:
            group = _G_GROUPS.get(g)
            if group is None:
                raise _unsupported("G", g)
            _modal(groups, group, "G", g)
            kind = ("non-modal" if g in _AXIS_NON_MODAL else
                    "motion" if group == "motion" and g != 80.0 else
                    "tool length" if group == "tool length" else None)
            if kind is not None:
                if axis_command is not None:
                    raise GcodeError(Err.AXIS_COMMAND_CONFLICT, msg.GCODE_ERR_AXIS_CONFLICT
                                     .format(a=code_name("G", axis_command),
                                             b=code_name("G", g)))
                axis_command = g
                axis_kind = kind
        m_groups: dict[str, float] = {}
        for m in block.m:
            group = _M_GROUPS.get(m)
            if group is None:
                raise _unsupported("M", m)
            _modal(m_groups, group, "M", m)

        values = dict(block.values)
        values.pop("N", None)
        axis_words = self._axis_words(values)
        if axis_words and axis_command is None:
            axis_kind = "motion"  # implicit: the modal motion mode takes them
        nonmodal = groups.get("non-modal")
        m_output = m_groups.get("output")
        m_flow = m_groups.get("flow")
        inches = self.inches if "units" not in groups else groups["units"] == 20.0
        scale = MM_PER_INCH if inches else 1.0

        # P: dwell time, G10's system or digital output number - one of them
        uses_p = [name for name, used in (
            ("G4", nonmodal == 4.0), ("G10", nonmodal == 10.0),
            ("M", m_output in (62.0, 63.0, 64.0, 65.0))) if used]
        if len(uses_p) > 1:
            uses_p = [code_name("M", m_output or 0) if n == "M" else n for n in uses_p]
            raise GcodeError(Err.VALUE_WORD_MISSING,
                             msg.GCODE_ERR_P_CONFLICT.format(a=uses_p[0], b=uses_p[1]))

        inverse = (self.inverse_time if "feed mode" not in groups
                   else groups["feed mode"] == 93.0)
        if "F" in values:  # G93: 1/minutes, never scaled by G20
            feed = values.pop("F") * (1.0 if inverse else scale)
        else:  # G93 (and leaving it): F is not modal - undefined until given
            feed = 0.0 if inverse or self.inverse_time else self.feed
        spindle_speed = values.pop("S", self.spindle_speed)
        tool = self.tool
        if "T" in values:
            t = values.pop("T")
            if t > MAX_TOOL:
                raise GcodeError(Err.MAX_VALUE_EXCEEDED,
                                 msg.GCODE_ERR_TOOL.format(tool=f"{t:g}", most=MAX_TOOL))
            if t != int(t):
                raise GcodeError(Err.COMMAND_VALUE_NOT_INTEGER,
                                 msg.GCODE_ERR_NOT_INTEGER.format(word=f"T{t:g}"))
            tool = int(t)
        absolute = self.absolute if "distance" not in groups else groups["distance"] == 90.0
        plane = self.plane if "plane" not in groups else int(groups["plane"])
        motion = groups.get("motion", self.motion)
        spindle = self.spindle if "spindle" not in m_groups else int(m_groups["spindle"])
        mist, flood = self.mist, self.flood
        if "coolant" in m_groups:
            c = m_groups["coolant"]
            mist = mist or c == 7.0
            flood = flood or c == 8.0
            if c == 9.0:
                mist = flood = False
        # units: every axis word in units (mm) from here on
        words = {k: v * scale for k, v in axis_words.items()}

        # tool length offset
        tlo = self.tlo
        if axis_kind == "tool length":
            if groups["tool length"] == 43.1:
                if set(words) != {"Z"}:
                    raise GcodeError(Err.G43_DYNAMIC_AXIS_ERROR, msg.GCODE_ERR_G43)
                tlo = words["Z"]
            else:
                tlo = 0.0
        # coordinate system
        coord_select = self.coord_select
        if "coordinate system" in groups:
            coord_select = int(groups["coordinate system"]) - 54
        coords = self.coords
        new_coords: tuple[str, int, list[float]] | None = None  # ("system"/"g28"..., n, values)

        actions: list[Action] = []
        dwell: Dwell | None = None
        if nonmodal == 4.0:
            if "P" not in values:
                raise GcodeError(Err.VALUE_WORD_MISSING, msg.GCODE_ERR_DWELL_P)
            dwell = Dwell(values.pop("P"), block.line)

        offset = list(self.offset)
        if nonmodal == 10.0:
            new_coords = self._g10(values, words, coord_select, offset)
        elif nonmodal == 92.0:
            if not words:
                raise GcodeError(Err.NO_AXIS_WORDS, msg.GCODE_ERR_G92_AXES)
            system = coords.systems[coord_select]
            for letter, v in words.items():
                i = AXES.index(letter)
                offset[i] = self.position[i] - system[i] - v - (tlo if i == TLO_AXIS else 0)
        elif nonmodal == 92.1:
            offset = [0.0] * self.axes
        elif nonmodal in (28.1, 30.1):
            new_coords = ("g28" if nonmodal == 28.1 else "g30", 0, list(self.position))

        system = list(coords.systems[coord_select])
        if new_coords is not None and new_coords[0] == "system" and new_coords[1] == coord_select:
            system = new_coords[2]
        wco = self.work_offset(system, offset, tlo)
        position = list(self.position)
        targets: list[tuple[list[float], bool]] = []  # (target in units, rapid)
        arc: tuple | None = None
        probe: float | None = None
        if nonmodal in (28.0, 30.0):
            home = list(coords.g28 if nonmodal == 28.0 else coords.g30)
            if words:
                via = self._target(words, absolute, wco, machine=False)
                targets.append((via, True))
                home = [home[i] if AXES[i] in words else via[i] for i in range(self.axes)]
                targets.append((home, True))
            else:
                targets.append((home, True))
        if motion == 80.0:
            if words:
                raise GcodeError(Err.AXIS_WORDS_EXIST, msg.GCODE_ERR_G80_AXES)
        elif axis_kind == "motion":
            machine = nonmodal == 53.0
            if machine and motion not in (0, 1):
                raise GcodeError(Err.G53_INVALID_MOTION_MODE, msg.GCODE_ERR_G53.format(
                    code=_g_code_name(motion)))
            target = self._target(words, absolute, wco, machine=machine)
            if motion != 0 and feed <= 0:
                raise GcodeError(Err.UNDEFINED_FEED_RATE, msg.GCODE_ERR_NO_FEED.format(
                    code=_g_code_name(motion)))
            if motion in (0, 1):
                if words:
                    targets.append((target, motion == 0))
            elif motion in (2, 3):
                arc = self._arc(words, values, target, plane, motion == 2, scale)
                targets.append((target, False))
            else:
                if not words:
                    raise GcodeError(Err.NO_AXIS_WORDS, msg.GCODE_ERR_PROBE_AXES.format(
                        code=_g_code_name(motion)))
                if self._steps(target) == self.position_steps:
                    raise GcodeError(Err.INVALID_TARGET, msg.GCODE_ERR_PROBE_TARGET)
                probe = motion
                targets.append((target, False))
        elif nonmodal == 53.0:
            raise GcodeError(Err.G53_INVALID_MOTION_MODE, msg.GCODE_ERR_G53.format(
                code="no motion"))

        if m_output is not None:
            actions.append(self._output(m_output, values, block.line))
        unused = sorted(w for w in values if w not in AXES)
        if unused:
            raise GcodeError(Err.UNUSED_WORDS, msg.GCODE_ERR_UNUSED.format(
                words=" ".join(unused)))

        # ----- laser mode (Grbl 1.1): which moves are powered, when S syncs
        laser = self.laser_mode
        laser_disable = laser and motion not in _POWERED
        is_motion = laser and bool(words) and axis_kind == "motion"
        force_sync = False
        if laser and not is_motion and self.spindle == SPINDLE_CW:
            was_powered = self.motion in _POWERED
            force_sync = was_powered == laser_disable
        spindle_actions: list[Action] = []
        if ((spindle_speed != self.spindle_speed or force_sync)
                and self.spindle != SPINDLE_OFF and not is_motion):
            spindle_actions.append(SetSpindle(
                self.spindle, 0.0 if laser_disable else spindle_speed, block.line))
        if spindle != self.spindle:
            spindle_actions.append(SetSpindle(
                spindle, 0.0 if laser_disable else spindle_speed, block.line))
        actions[:0] = spindle_actions
        if (mist, flood) != (self.mist, self.flood):
            actions.insert(len(spindle_actions), SetCoolant(mist, flood, block.line))
        if dwell is not None:
            actions.append(dwell)
        if wco != self.work_offset() or nonmodal in (92.0, 92.1, 10.0):
            actions.append(SetOffset(wco, block.line))

        power: Laser | None = None
        if laser and spindle != SPINDLE_OFF:
            power = Laser(spindle == SPINDLE_CCW, 0.0 if laser_disable else spindle_speed,
                          feed)
        steps = list(self.position_steps)
        for target, rapid in targets:
            points = [target] if arc is None or probe is not None else arc_points(
                position, target, arc[0], arc[1], arc[2], arc[3])
            move_feed = feed
            if inverse and not rapid:  # the whole block in 1/F minutes: its length * F
                ends = [position, *points]
                move_feed = feed * sum(math.dist(a, b) for a, b in zip(ends, ends[1:],
                                                                       strict=False))
                if power is not None:
                    power = Laser(power.dynamic, power.speed, move_feed)
            if arc is not None and probe is None:
                points = self._cut_arc_end(position, points, arc)
            if probe is not None:
                move = Move(tuple(self._steps(target)), tuple(steps), False, move_feed,
                            block.line)
                actions.append(Probe(move, probe in (38.2, 38.3), probe in (38.2, 38.4),
                                     probe, block.line))
                steps = list(move.target)
                position = target
                continue
            last = len(points) - 1
            for k, point in enumerate(points):
                t = self._steps(list(point))
                if t != steps:
                    actions.append(Move(tuple(t), tuple(steps), rapid,
                                        None if rapid else move_feed, block.line,
                                        laser=None if power is None else
                                        (Laser(power.dynamic, 0.0, move_feed) if rapid
                                         else power),
                                        exact=None if k == last else
                                        self._exact_steps(point)))
                    steps = t
            position = list(target)

        if m_flow == 0.0:
            actions.append(Pause(block.line))
        elif m_flow in (2.0, 30.0):
            g54 = system if coord_select == 0 else coords.systems[0]
            actions.append(End(block.line, self.work_offset(g54, offset, tlo)))
        if self.check is not None:
            for action in actions:
                self.check(action)
        # the block is valid: take its modal state
        self.feed = feed
        self.inverse_time = inverse
        self.spindle_speed = spindle_speed
        self.spindle = spindle
        self.mist, self.flood = mist, flood
        self.tool = tool
        self.absolute = absolute
        self.motion = motion
        self.plane = plane
        self.inches = inches
        self.coord_select = coord_select
        self.offset = offset
        self.tlo = tlo
        if new_coords is not None:
            kind, n, vals = new_coords
            if kind == "system":
                coords.systems[n] = vals
            elif kind == "g28":
                coords.g28 = vals
            else:
                coords.g30 = vals
        self.position = position
        self.position_steps = steps
        self.program_end = m_flow in (2.0, 30.0)
        if self.program_end:
            self.end_of_program()
        return actions

    def _plain_move(self, block: Block) -> list[Action] | None:
        """:meth:`interpret` of the commonest block - G0/G1 (or the modal G0/G1) with
        axis words, perhaps F and N, no laser mode, no G93 - with the same actions,
        checks and modal state; None for every other block (and where it would be an
        error), which :meth:`interpret` then reads word by word."""
        if block.m or self.inverse_time:
            return None
        g = block.g
        if g:
            if len(g) > 1:
                return None
            motion = g[0]
        else:
            motion = self.motion
        if motion != 0.0 and motion != 1.0:
            return None
        axes = self.axes
        feed = self.feed
        inches = self.inches
        # the target (_target's and work_offset's, written out: not a machine position)
        # as the axis words come; nothing of the state changes before the block is valid
        position = self.position
        target = list(position)
        absolute = self.absolute
        if absolute:
            system = self.coords.systems[self.coord_select]
            offset = self.offset
            tlo = self.tlo
        moved = False
        for letter, v in block.values.items():
            i = AXES.find(letter)
            if 0 <= i < axes:
                if inches:
                    v = v * MM_PER_INCH
                if absolute:
                    target[i] = v + (system[i] + offset[i] + (tlo if i == TLO_AXIS else 0.0))
                else:
                    target[i] = position[i] + v
                moved = True
            elif letter == "F":
                feed = v * MM_PER_INCH if inches else v
            elif letter != "N":
                return None
        if (not moved or (motion != 0 and feed <= 0)
                or self.settings.kept.get(LASER_MODE, 0)):  # (laser_mode)
            return None
        steps = self.position_steps
        t = self._steps(target)  # (reads it only)
        if t != steps:
            rapid = motion == 0
            move = Move(tuple(t), tuple(steps), rapid, None if rapid else feed, block.line)
            if self.check is not None:
                self.check(move)
            actions: list[Action] = [move]
            steps = t
        else:
            actions = []
        self.feed = feed
        self.motion = motion
        self.position = target  # (a list of its own)
        self.position_steps = steps
        self.program_end = False
        return actions

    def jog(self, block: Block) -> Move | None:
        """A ``$J=`` line's words -> the jog move (None: already there).  Jogs change no
        modal state except the position; F is required (units/min, inches/min with
        G20)."""
        g_distance = None
        g_units = None
        machine = False
        for g in block.g:
            if g not in _JOG_G:
                raise GcodeError(Err.INVALID_JOG_COMMAND,
                                 msg.GCODE_ERR_JOG_CODE.format(code=code_name("G", g)))
            if g in (90.0, 91.0):
                if g_distance is not None:
                    raise GcodeError(Err.MODAL_GROUP_VIOLATION, msg.GCODE_ERR_MODAL.format(
                        a=code_name("G", g_distance), b=code_name("G", g)))
                g_distance = g
            if g in (20.0, 21.0):
                if g_units is not None:
                    raise GcodeError(Err.MODAL_GROUP_VIOLATION, msg.GCODE_ERR_MODAL.format(
                        a=code_name("G", g_units), b=code_name("G", g)))
                g_units = g
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
        inches = self.inches if g_units is None else g_units == 20.0
        scale = MM_PER_INCH if inches else 1.0
        words = {k: v * scale for k, v in axis_words.items()}
        absolute = self.absolute if g_distance is None else g_distance == 90.0
        target = self._target(words, absolute, self.work_offset(), machine=machine)
        steps = self._steps(target)
        if steps == self.position_steps:
            return None
        move = Move(tuple(steps), tuple(self.position_steps), False, feed * scale,
                    block.line, jog=True)
        if self.check is not None:
            self.check(move)
        self.position_steps = steps
        self.position = target
        return move

    # ---------------------------------------------------------------- helpers
    def _axis_words(self, values: dict[str, float]) -> dict[str, float]:
        words = {k: v for k, v in values.items() if k in AXES}
        for letter in words:
            if AXES.index(letter) >= self.axes:
                raise GcodeError(Err.UNSUPPORTED_COMMAND, msg.GCODE_ERR_NO_AXIS.format(
                    letter=letter, n=AXES.index(letter) + 1, axes=AXES[:self.axes]))
        return words

    def _target(self, words: dict[str, float], absolute: bool, wco: tuple[float, ...],
                machine: bool) -> list[float]:
        """The machine position (units) the axis words name."""
        target = list(self.position)
        for letter, v in words.items():
            i = AXES.index(letter)
            if machine:
                target[i] = v
            elif absolute:
                target[i] = v + wco[i]
            else:
                target[i] = self.position[i] + v
        return target

    def _exact_steps(self, point: Sequence[float]) -> tuple[float, ...]:
        """A point in steps, not rounded (an arc's chord end; in range: its rounding
        passed :meth:`_steps`).  Kept to 1/1024 step so that one arc given by R and
        by I/J/K goes through the same points in spite of the last bits."""
        return tuple(round(v * spu * 1024.0) / 1024.0
                     for v, spu in zip(point, self.settings.steps_per_unit, strict=False))

    def _cut_arc_end(self, start: Sequence[float], points: list[tuple[float, ...]],
                     arc: tuple) -> list[tuple[float, ...]]:
        """The arc's points with one more on its last chord where the end rule would
        force a point beyond `$12` + one step (:func:`fas.path.arc.arc_end_cut`; a
        plane whose two axes have equal steps per unit)."""
        offset, plane, clockwise, tolerance = arc
        a0, a1, _lin = plane.axes
        spu = self.settings.steps_per_unit
        if len(points) < 2 or spu[a0] != spu[a1]:
            return points
        k = spu[a0]
        centre = ((start[a0] + offset[0]) * k, (start[a1] + offset[1]) * k)
        radius = math.hypot(*offset) * k
        last = self._exact_steps(points[-2])
        target = self._steps(list(points[-1]))
        later = arc_end_approach(last, target, centre, radius, tolerance * k + 1.0, plane,
                                 clockwise)
        if later is not None:  # the last chord begins later on the circle
            units = tuple(v / s for v, s in zip(later, spu, strict=False))
            points = [*points[:-1], units, points[-1]]
            last = self._exact_steps(units)
        cut = arc_end_cut(last, target, centre, radius, tolerance * k + 1.0, plane)
        if cut is None:
            return points
        units = tuple(v / s for v, s in zip(cut, spu, strict=False))
        return [*points[:-1], units, points[-1]]

    def _steps(self, target: list[float]) -> list[int]:
        out = []
        spu = self.settings.steps_per_unit
        floor = math.floor
        for i, v in enumerate(target):
            steps = v * spu[i]
            if not -INT32 <= steps <= INT32:
                raise GcodeError(Err.INVALID_TARGET, msg.GCODE_ERR_RANGE.format(
                    letter=AXES[i]))
            out.append(floor(steps + 0.5))  # (an int already)
        return out

    def _g10(self, values: dict[str, float], words: dict[str, float], coord_select: int,
             offset: list[float]) -> tuple[str, int, list[float]]:
        """G10 L2 / L20: the new values of a coordinate system."""
        if not words:
            raise GcodeError(Err.NO_AXIS_WORDS, msg.GCODE_ERR_G10_AXES)
        if "P" not in values or "L" not in values:
            raise GcodeError(Err.VALUE_WORD_MISSING, msg.GCODE_ERR_G10_PL)
        p = int(values.pop("P"))
        if p > COORD_SYSTEMS:
            raise GcodeError(Err.UNSUPPORTED_COORD_SYS, msg.GCODE_ERR_G10_P.format(p=p))
        lvalue = values.pop("L")
        if lvalue not in (2.0, 20.0):
            raise GcodeError(Err.UNSUPPORTED_COMMAND, msg.GCODE_ERR_G10_L.format(
                l=f"{lvalue:g}"))
        if lvalue == 2.0 and "R" in values:
            raise GcodeError(Err.UNSUPPORTED_COMMAND, msg.GCODE_ERR_G10_R)
        n = p - 1 if p > 0 else coord_select
        system = list(self.coords.systems[n])
        for letter, v in words.items():
            i = AXES.index(letter)
            if lvalue == 20.0:
                system[i] = self.position[i] - offset[i] - v - (
                    self.tlo if i == TLO_AXIS else 0.0)
            else:
                system[i] = v
        return ("system", n, system)

    def _arc(self, words: dict[str, float], values: dict[str, float], target: list[float],
             plane_code: int, clockwise: bool, scale: float) -> tuple:
        """Grbl's checks of a G2/G3 block; (centre offset, plane, clockwise, tolerance)."""
        plane = Plane(plane_code)
        a0, a1, _lin = plane.axes
        if max(a0, a1) >= self.axes:
            raise GcodeError(Err.UNSUPPORTED_COMMAND, msg.GCODE_ERR_ARC_PLANE.format(
                plane=f"G{plane_code}", axes=AXES[:self.axes]))
        if not words:
            raise GcodeError(Err.NO_AXIS_WORDS, msg.GCODE_ERR_ARC_AXES)
        if AXES[a0] not in words and AXES[a1] not in words:
            raise GcodeError(Err.NO_AXIS_WORDS_IN_PLANE, msg.GCODE_ERR_ARC_PLANE_AXES.format(
                a=AXES[a0], b=AXES[a1], plane=f"G{plane_code}"))
        start = self.position
        if "R" in values:
            r = values.pop("R") * scale
            if target == start:
                raise GcodeError(Err.INVALID_TARGET, msg.GCODE_ERR_ARC_R_TARGET)
            err, offset = arc_center_from_radius(start, target, r, plane, clockwise)
            if err == ArcError.ARC_RADIUS_ERROR:
                raise GcodeError(Err.ARC_RADIUS_ERROR, msg.GCODE_ERR_ARC_RADIUS.format(
                    r=f"{abs(r) / scale:g}", d=f"{math.dist(start, target) / scale / 2:g}"))
            if err != ArcError.OK:
                raise GcodeError(Err.INVALID_TARGET, msg.GCODE_ERR_ARC_R_TARGET)
        else:
            letters = "IJK"
            named = {letters[a0], letters[a1]} & set(values)
            if not named:
                raise GcodeError(Err.NO_OFFSETS_IN_PLANE, msg.GCODE_ERR_ARC_OFFSETS.format(
                    a=letters[a0], b=letters[a1], plane=f"G{plane_code}"))
            offset = (values.get(letters[a0], 0.0) * scale, values.get(letters[a1], 0.0) * scale)
            for letter in letters:
                values.pop(letter, None)
            err = check_arc_offsets(start, target, offset, plane)
            if err != ArcError.OK:
                r0 = math.hypot(*offset)
                r1 = math.hypot(target[a0] - start[a0] - offset[0],
                                target[a1] - start[a1] - offset[1])
                raise GcodeError(Err.INVALID_TARGET, msg.GCODE_ERR_ARC_IJK.format(
                    r0=f"{r0 / scale:.4f}", r1=f"{r1 / scale:.4f}"))
        tolerance = float(self.settings.kept.get(ARC_TOLERANCE, 0.002))
        radius = math.hypot(*offset)
        travel = arc_travel(start, target, offset, plane, clockwise)
        if arc_segments(radius, travel, tolerance) > MAX_ARC_SEGMENTS:
            # an arc of kilometres: the chords of at most 65535 segments
            tolerance = radius * (1.0 - math.cos(abs(travel) / (2 * MAX_ARC_SEGMENTS)))
            tolerance *= 1.0 + 1e-9
        return (offset, plane, clockwise, tolerance)

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


def _output_number(letter: str, value: float) -> int:
    if value != int(value) or not 0 <= value < OUTPUTS:
        raise GcodeError(Err.PARAMETER_OUT_OF_RANGE, msg.GCODE_ERR_OUTPUT_RANGE.format(
            letter=letter, value=f"{value:g}", last=OUTPUTS - 1))
    return int(value)
