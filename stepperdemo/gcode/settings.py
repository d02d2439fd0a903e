"""The G-code program's settings, Grbl 1.1 style: ``$$`` lists them, ``$N=value`` sets one.

``$$`` lists Grbl 1.1's numbers in its order (senders read ``$10``, ``$13``,
``$100``-``$132`` ...) with the values this machine really has, then the project's
own (``$140``-``$173``).  The axis groups always show X, Y and Z (senders expect
three), and A, B, C when the machine has those axes.

=========  ==========================================================  ===========
 setting    meaning                                                     default
=========  ==========================================================  ===========
 $0         step pulse, us (the chip's step generator makes it: fixed)  10
 $1         step idle delay, ms: drivers off this long after motion     25
            (255: keep them on)
 $2-$6      step/dir/enable/limit/probe inversion masks (fixed)         0
 $10        status report: 1 MPos (else WPos), +2 ``Bf:`` buffer state  3
 $11        junction deviation, units: how far a corner's arc may stay  0.010
            from the corner - the look-ahead's corner speed (0: stop at
            every corner)
 $12        arc tolerance, units: largest distance of an arc's chords   0.002
            from the arc (G2/G3)
 $13        report inches (fixed: no inches)                            0
 $20-$27    soft limits, hard limits, homing (no limit inputs: 0)       Grbl's
 $30 $31    spindle speed (S) of full / of the least duty (.tooling)    1000 0
 $32        laser mode: 1 needs a spindle PWM output (.tooling)         0
 $100-105   steps per unit, axes X Y Z A B C                            1 (steps)
 $110-115   maximum rate, units/min (also the G0 rate)                  600000
 $120-125   acceleration, units/s² (per axis)                           10000
 $130-135   maximum travel, units (kept: no soft limits without homing) 200
 $140-143   PWM frequency of Aout0-3, Hz (seed 003 default)             5000
 $150-153   pin of Dout0-3                                              profile
 $160-163   pin of Aout0-3 (a PWM pin of the profile)                   profile
 $170       status report shows the user outputs (``Dout:``/``Aout:``)  0
 $171       motion: 0 look-ahead (``fas.path``), 1 exact stop at every   0
            block (issue 24's executor, for comparison)
 $172       corners: 0 Grbl's junctions (the commanded polyline, each    0
            axis's velocity jumps at a corner), 1 corner blends (every
            axis within its acceleration, the path up to $11 inside
            the corner; docs/path-planner.md "Corners: blends")
 $173       with $172=1: a corner whose blend no axis's step tells     0
            from Grbl's corner by more than this many steps (0 ..
            0.125) is taken as Grbl's corner at the blend's clock
            (docs/path-planner.md "Corners no step can tell apart")
=========  ==========================================================  ===========

The machine executes its blocks with look-ahead (:mod:`.lookahead_exec`) unless
``$171=1`` or its steppers cannot form a path group (two axes on one direction pin,
as StepperDemo's ESP32 wiring has: then every block stops, :mod:`.exact_stop`).

With the default of one step per unit, axis words and F are in steps and steps per
minute (F600000 = 10 000 steps/s).  A rate above what the stepper can do is limited
to the stepper's top speed.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from fas.path.settings import GROUP_TOLERANCE_STEPS, PLAIN_CORNER_STEPS

from .parser import AXES

AXIS_COUNT = len(AXES)
DEFAULT_STEPS_PER_UNIT = 1.0
DEFAULT_MAX_RATE = 600_000.0  # units/min: 10 000 steps/s at one step per unit
DEFAULT_ACCELERATION = 10_000.0  # units/s²
DEFAULT_MAX_TRAVEL = 200.0  # units (Grbl's default)
DEFAULT_IDLE_DELAY_MS = 25  # Grbl's $1
DEFAULT_STATUS_MASK = 3  # MPos and Bf: (Grbl's default is 1; issue 24 wants Bf shown)
KEEP_ENABLED = 255

#: settings shown with Grbl's value that this machine cannot change: number -> value
FIXED = {0: 10, 2: 0, 3: 0, 4: 0, 5: 0, 6: 0, 13: 0, 21: 0, 23: 0}
#: settings kept and shown (the arc tolerance, the spindle range and laser mode are
#: read from here; the homing figures are only kept): number -> (default, decimals)
KEPT = {11: (0.010, 3), 12: (0.002, 3), 24: (25.0, 3), 25: (500.0, 3), 26: (250.0, 0),
        27: (1.0, 3), 30: (1000.0, 0), 31: (0.0, 0), 32: (0.0, 0)}
#: flags a machine without limit inputs can only keep at 0
SWITCHES = (20, 22)
JUNCTION_DEVIATION, ARC_TOLERANCE = 11, 12
#: $171: how blocks are executed
MOTION_LOOKAHEAD, MOTION_EXACT_STOP = 0, 1
#: $173's largest value (steps): the grouping's tolerance, the acceleration line's budget
PLAIN_CORNER_MAX = GROUP_TOLERANCE_STEPS


@dataclass
class GcodeSettings:
    steps_per_unit: list[float] = field(
        default_factory=lambda: [DEFAULT_STEPS_PER_UNIT] * AXIS_COUNT)
    max_rate: list[float] = field(default_factory=lambda: [DEFAULT_MAX_RATE] * AXIS_COUNT)
    acceleration: list[float] = field(
        default_factory=lambda: [DEFAULT_ACCELERATION] * AXIS_COUNT)
    max_travel: list[float] = field(default_factory=lambda: [DEFAULT_MAX_TRAVEL] * AXIS_COUNT)
    idle_delay_ms: int = DEFAULT_IDLE_DELAY_MS
    status_mask: int = DEFAULT_STATUS_MASK
    report_outputs: bool = False  # $170
    motion: int = MOTION_LOOKAHEAD  # $171
    corner_blends: bool = False  # $172: Grbl's junctions (0) or corner blends (1)
    #: $173: with blends, a corner within this many steps of its blend is Grbl's corner
    plain_corner_steps: float = PLAIN_CORNER_STEPS
    kept: dict[int, float] = field(
        default_factory=lambda: {n: v for n, (v, _d) in KEPT.items()})
    startup: list[str] = field(default_factory=lambda: ["", ""])  # $N0, $N1
    build_info: str = ""  # $I=text

    @property
    def junction_deviation(self) -> float:
        """``$11``, units (the look-ahead's corner speeds)."""
        return self.kept[JUNCTION_DEVIATION]

    @property
    def arc_tolerance(self) -> float:
        """``$12``, units (G2/G3 cut into chords within it)."""
        return self.kept[ARC_TOLERANCE]

    def axis_values(self, base: int) -> list[float]:
        """The list behind ``$100``/``$110``/``$120``/``$130``."""
        return {100: self.steps_per_unit, 110: self.max_rate, 120: self.acceleration,
                130: self.max_travel}[base]


def axis_setting(number: int) -> tuple[int, int] | None:
    """``(base, axis)`` of an axis setting number ($100..$135), else None."""
    for base in (100, 110, 120, 130):
        if base <= number < base + AXIS_COUNT:
            return base, number - base
    return None


def output_setting(number: int) -> tuple[int, int] | None:
    """``(base, output)`` of an output setting number ($140..$163), else None."""
    for base in (140, 150, 160):
        if base <= number < base + 4:
            return base, number - base
    return None
