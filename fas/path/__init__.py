"""Coordinated motion of several steppers along one path: look-ahead planning with
junction deviation, feed hold, arcs (Grbl's planner on FastAccelStepper queues).

* :mod:`fas.path.group` - :class:`PathGroup`, the API (``line``, ``hold`` ...);
* :mod:`fas.path.lookahead` - blocks, junction speeds, the reverse and forward passes;
* :mod:`fas.path.executor` - the speed along the path made final piece by piece;
* :mod:`fas.path.stepping` - each axis's steps as queue commands;
* :mod:`fas.path.blend` - corners taken as blends at constant acceleration;
* :mod:`fas.path.axis` - the per-stepper planner ``"path"`` (:mod:`fas.planners`);
* :mod:`fas.path.arc` - arcs as straight segments within the arc tolerance.

``docs/path-planner.md`` describes the model, the units and the limits.
"""

from .arc import ArcError, Plane, arc_center_from_radius, arc_points, check_arc_offsets
from .axis import PLANNER_PATH, PathAxis
from .group import PathGroup, PathStats
from .settings import AxisLimits, PathResult, PathSettings, PathState

__all__ = ["PLANNER_PATH", "ArcError", "AxisLimits", "PathAxis", "PathGroup", "PathResult",
           "PathSettings", "PathState", "PathStats", "Plane", "arc_center_from_radius",
           "arc_points", "check_arc_offsets"]
