"""The figures of a path group (Grbl's ``$11``, ``$12``, ``$100``-``$125``) and the codes
its calls return.

Units: a group works in *units* of its own (millimetres for a G-code machine);
``steps_per_unit`` turns them into each axis's steps.  With one step per unit (the
default) lengths are steps, feeds steps per minute.  Rates are per minute and
accelerations per second squared, as Grbl's settings are.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum

#: look-ahead blocks (Grbl: 16 on the ATmega328P, where RAM is the limit).  The host
#: keeps its blocks in its own memory, so the limit is the planning work per block
#: (incremental: see :mod:`fas.path.lookahead`) and how much motion a cancel drops.
#: 32 blocks hold the stopping distance of 1 000 mm/s^2 from 100 mm/s (5 mm) in
#: segments of 0.16 mm, the shortest a CAM program commonly emits at that feed.
DEFAULT_QUEUE_BLOCKS = 32
DEFAULT_JUNCTION_DEVIATION = 0.01  # units ($11; Grbl's default 0.010 mm)
DEFAULT_ARC_TOLERANCE = 0.002  # units ($12; Grbl's default 0.002 mm)
MINIMUM_FEED = 1.0  # units/min: a slower feed is raised to this (Grbl's MINIMUM_FEED_RATE)
#: a group waits this long after its first block before it starts moving, unless it is
#: flushed, its queue is full or it holds this much motion time already (more blocks
#: may follow at once: a start from rest that the next block would have joined)
DEFAULT_START_DELAY_MS = 50
#: position error (steps) allowed for steps grouped into one command at an even period
#: where the exact step times are not evenly spaced (accelerating, decelerating)
GROUP_TOLERANCE_STEPS = 0.125
#: with corner blends on (PathSettings.corner_blends; at Grbl's junctions the axis's
#: velocity jumps at a turn anyway): for this long after an axis's last step before
#: it turns round, its steps come on their own ticks, none early (seconds).  Early
#: steps put an axis ahead of the path on the side it moves to, so across a turn
#: their errors change sign: a divided difference over step edges >= W apart
#: (rigs.path.edge_accels) with its middle edge b before the turn and its last c
#: after would see up to 4 e / W^2 instead of the one-sided 2 e / W^2.  c is the
#: first step at or after t_b + W <= (the last step before the turn) + W; with every
#: step up to there exact (and the first step at or after it beginning a command, on
#: its tick) the bound 2 e / W^2 holds at every step for every window W up to this
#: one - the acceptance's 20 ms.
TURN_EXACT_S = 0.020
#: with corner blends on: a corner whose blend differs from Grbl's corner (at the
#: blend's clock) by at most this many steps in every axis is written as Grbl's corner
#: - the blocks' own steps, no blend (PathSettings.plain_corner_steps).  At most
#: GROUP_TOLERANCE_STEPS: the acceleration measured from the pins then keeps its
#: resolution 2 e / W^2 (e = GROUP_TOLERANCE_STEPS) because the grouping's tolerance
#: near such a corner shrinks by its offset (docs/path-planner.md, "Corners no step
#: can tell apart").  0: every turning corner is a blend.
PLAIN_CORNER_STEPS = 0.0


@dataclass(frozen=True)
class AxisLimits:
    """One axis: ``steps_per_unit`` ($100), ``max_rate`` in units/min ($110; also the
    rapid rate), ``acceleration`` in units/s^2 ($120)."""

    steps_per_unit: float = 1.0
    max_rate: float = 600_000.0
    acceleration: float = 10_000.0

    def problem(self) -> str | None:
        """Why these figures cannot be used (None: they can)."""
        for name in ("steps_per_unit", "max_rate", "acceleration"):
            value = getattr(self, name)
            if not (value > 0 and value < float("inf")):
                return f"{name} must be a positive number, not {value!r}"
        return None


#: corner blends (fas.path.blend): each within this share of either block
BLEND_SHARE = 0.5


@dataclass(frozen=True)
class PathSettings:
    """The figures of one group: its axes (in the order of its steppers), the junction
    deviation ($11) and the arc tolerance ($12) in units, and the look-ahead depth.

    ``corner_blends``: False (the default) runs Grbl's motion - the path is the
    commanded polyline, each corner passed at its junction speed on one tick with
    each axis's velocity jumping there; True takes every turning corner on whole
    steps as a blend at constant acceleration (:mod:`fas.path.blend`): every axis
    within its acceleration, the path up to ``junction_deviation`` inside the corner
    (docs/path-planner.md, "Corners: blends").  ``plain_corner_steps`` (with
    blends): a corner whose blend differs from Grbl's corner by at most that many
    steps in every axis is taken as Grbl's corner at the blend's clock
    (:data:`PLAIN_CORNER_STEPS`; docs/path-planner.md, "Corners no step can tell
    apart")."""

    axes: tuple[AxisLimits, ...] = field(default_factory=tuple)
    junction_deviation: float = DEFAULT_JUNCTION_DEVIATION
    arc_tolerance: float = DEFAULT_ARC_TOLERANCE
    queue_blocks: int = DEFAULT_QUEUE_BLOCKS
    start_delay_ms: int = DEFAULT_START_DELAY_MS
    corner_blends: bool = False
    plain_corner_steps: float = PLAIN_CORNER_STEPS

    def problem(self, axes: int) -> str | None:
        """Why these settings do not fit a group of ``axes`` axes (None: they do)."""
        if len(self.axes) != axes:
            return f"{len(self.axes)} axis limits for {axes} axes"
        for i, a in enumerate(self.axes):
            p = a.problem()
            if p is not None:
                return f"axis {i}: {p}"
        if not 0 <= self.junction_deviation < float("inf"):
            return "junction_deviation must be >= 0"
        if not 0 < self.arc_tolerance < float("inf"):
            return "arc_tolerance must be > 0"
        if not 2 <= self.queue_blocks <= 1024:
            return "queue_blocks must be 2 .. 1024"
        if not 0 <= self.start_delay_ms <= 60_000:
            return "start_delay_ms must be 0 .. 60000"
        if not 0.0 <= self.plain_corner_steps <= GROUP_TOLERANCE_STEPS:
            return f"plain_corner_steps must be 0 .. {GROUP_TOLERANCE_STEPS}"
        return None


class PathResult(IntEnum):
    """What a group's call did.  Positive values: not taken now, try again later."""

    OK = 0
    QUEUE_FULL = 1  # the look-ahead queue has no room: call again once a block ran
    EMPTY_BLOCK = 2  # the target is where the path already ends: nothing queued
    ERR_AXES = -1  # the target names a different number of axes
    ERR_FEED = -2  # the feed is not a positive number
    ERR_RANGE = -3  # a target position outside int32
    ERR_NO_DIRECTION_PIN = -4  # an axis without a direction pin would have to go down
    ERR_AXIS_BUSY = -5  # an axis moves on its own (its own planner): wait for it
    ERR_AUTO_ENABLE = -6  # an axis uses auto enable (its enable delay would shift steps)
    ERR_DIR_DELAY = -7  # an axis's driver pauses at a direction change (shifts steps)
    ERR_SHARED_DIR_PIN = -8  # two axes of the group share a direction pin
    ERR_SAME_STEPPER = -9  # a stepper named twice
    ERR_NOT_ATTACHED = -10  # the group is not attached to its steppers
    ERR_SETTINGS = -11  # the settings do not fit (PathSettings.problem says why)
    ERR_RUNNING = -12  # only while the group is idle

    @property
    def retry(self) -> bool:
        return self.value > 0


class PathState(IntEnum):
    """Where a group is (``PathGroup.state``)."""

    IDLE = 0  # nothing queued, nothing moving
    QUEUED = 1  # blocks wait for the start (start delay, or held)
    RUNNING = 2  # moving along the path
    HOLDING = 3  # a feed hold decelerates along the path
    HELD = 4  # stopped by a feed hold; resume() goes on, cancel() drops the rest
