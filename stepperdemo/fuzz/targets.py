"""The fuzz targets: one per console program, each on the profiles that host it.

A :class:`Target` makes inputs (``generate(rng, arch) -> Case``) and checks one on a
fresh simulated chip (``check(case, arch, max_time_s) -> FuzzResult``).
:func:`fuzz_program` runs ``runs`` cases of one target, the profiles taken in turn,
each case from its own seed (``seed``, program, run number): a failing run is
reproduced by :func:`replay` from those three numbers alone.
"""

from __future__ import annotations

import random
from collections.abc import Callable, Iterator
from dataclasses import dataclass

from fas.arch import PROFILES

from . import demo, gcode, winder
from .common import Case, FuzzResult


@dataclass(frozen=True)
class Target:
    name: str
    generate: Callable[[random.Random, str], Case]
    check: Callable[..., FuzzResult]
    profiles: Callable[[], tuple[str, ...]]
    max_time_s: float  # simulated seconds a run may take


def _all_profiles() -> tuple[str, ...]:
    return tuple(PROFILES)


TARGETS: dict[str, Target] = {
    "demo": Target("demo", demo.demo_case, demo.check_demo, _all_profiles, 20.0),
    "gcode": Target("gcode", gcode.gcode_case, gcode.check_gcode, _all_profiles, 5.0),
    "winder": Target("winder", winder.winder_case, winder.check_winder,
                     winder.hosting_profiles, 4.0),
}


def case_rng(seed: int, program: str, run: int) -> random.Random:
    return random.Random(f"{seed}:{program}:{run}")


def case_of(program: str, seed: int, run: int,
            archs: tuple[str, ...] | None = None) -> tuple[str, Case]:
    """Run ``run``'s profile and input (profiles in turn, the input from its own seed)."""
    target = TARGETS[program]
    archs = archs or target.profiles()
    arch = archs[run % len(archs)]
    return arch, target.generate(case_rng(seed, program, run), arch)


def replay(program: str, seed: int, run: int, archs: tuple[str, ...] | None = None,
           max_time_s: float | None = None) -> FuzzResult:
    arch, case = case_of(program, seed, run, archs)
    target = TARGETS[program]
    return target.check(case, arch, target.max_time_s if max_time_s is None else max_time_s)


def fuzz_program(program: str, runs: int, seed: int, *, first: int = 0,
                 archs: tuple[str, ...] | None = None,
                 max_time_s: float | None = None) -> Iterator[tuple[int, FuzzResult]]:
    """``(run number, result)`` of runs ``first .. first + runs - 1`` of a target."""
    for run in range(first, first + runs):
        yield run, replay(program, seed, run, archs, max_time_s)
