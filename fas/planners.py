"""The registry of planners: each is found by name (``stepper.set_planner(name, ...)``).

A planner is one module with a factory and one entry here (:func:`register`).  A
factory is called as ``factory(host, current, kept, *options)``:

* ``host`` - what the stepper lends its planner (:class:`fas.planner.PlannerHost`);
* ``current`` - the stepper's planner in use;
* ``kept`` - the planner this factory made for the stepper before, if the stepper
  gave it up since (a factory may resume it);
* ``options`` - the figures the caller passed (QuickStep: FIFO depth, plateaus).

It returns ``(result, planner)``: result 0 and a planner to swap in; 0 and None when
there is nothing to swap (``current`` is already that planner, perhaps with new
figures); or a non-zero reason for refusing (:class:`fas.planner.PlannerChange`, or
the factory's own codes) and None.
"""

from __future__ import annotations

from collections.abc import Callable

from . import gear
from .path import axis as path
from .planner import Planner, PlannerHost
from .quickstep import setup as quickstep
from .ramp import planner as ramp

Factory = Callable[..., tuple[int, Planner | None]]

PLANNER_FAS = "ramp"  # FastAccelStepper's ramp generator (every stepper starts with it)
PLANNER_QUICKSTEP = "quickstep"  # QuickStep's plateau orders (fas.quickstep)
PLANNER_GEAR = gear.PLANNER_GEAR  # a follower of another stepper at n:m (fas.gear)
PLANNER_PATH = path.PLANNER_PATH  # an axis of a path group (fas.path)

_FACTORIES: dict[str, Factory] = {}


def register(name: str, factory: Factory) -> None:
    """Make a planner available as ``name`` (a name taken already is replaced)."""
    _FACTORIES[name] = factory


def unregister(name: str) -> None:
    if name in (PLANNER_FAS, PLANNER_QUICKSTEP, PLANNER_GEAR, PLANNER_PATH):
        raise ValueError(f"the planner {name!r} cannot be removed")
    _FACTORIES.pop(name, None)


def lookup(name: str) -> Factory:
    """The factory registered as ``name``; ValueError for an unknown name."""
    try:
        return _FACTORIES[name]
    except KeyError:
        known = ", ".join(sorted(_FACTORIES))
        raise ValueError(f"no planner named {name!r} (known: {known})") from None


def names() -> list[str]:
    return sorted(_FACTORIES)


register(PLANNER_FAS, ramp.make)
register(PLANNER_QUICKSTEP, quickstep.make)
register(PLANNER_GEAR, gear.make_follower)
register(PLANNER_PATH, path.make)

__all__ = ["PLANNER_FAS", "PLANNER_GEAR", "PLANNER_PATH", "PLANNER_QUICKSTEP", "Factory",
           "PlannerHost", "lookup", "names", "register", "unregister"]
