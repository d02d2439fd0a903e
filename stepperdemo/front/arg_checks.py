"""Arguments that argparse lets through but nothing can run with.

argparse turns ``--speed nan``, ``--max-time inf`` or ``--speed -2`` into floats; the
front ends would then divide by zero, run time backwards or overflow.  A ``--link`` in
a folder that does not exist cannot be made once the pty is open.  Every program and
subcommand checks these here, before anything starts, and says what it takes in one
line (exit code 2).
"""

from __future__ import annotations

import argparse
import math
import os

from .. import messages as msg

SPEED_MAX = 1000.0  # as the console's /speed
MAX_TIME_S = 10_000_000.0  # --max-time: 115 days of simulated time is plenty


def speed_problem(value: float, option: str = "--speed") -> str | None:
    """A clock factor: 0 < f <= SPEED_MAX."""
    if math.isfinite(value) and 0 < value <= SPEED_MAX:
        return None
    return msg.CLI_BAD_NUMBER.format(option=option, value=value,
                                     what=f"a factor 0 < f <= {SPEED_MAX:g}")


def max_time_problem(value: float, option: str = "--max-time") -> str | None:
    """Seconds: 0 < s <= MAX_TIME_S."""
    if math.isfinite(value) and 0 < value <= MAX_TIME_S:
        return None
    return msg.CLI_BAD_NUMBER.format(option=option, value=value,
                                     what=f"seconds 0 < s <= {MAX_TIME_S:.0f}")


def number_problem(args: argparse.Namespace) -> str | None:
    """The first problem with ``args.max_time`` and ``args.speed`` (where present)."""
    if getattr(args, "max_time", None) is not None:
        problem = max_time_problem(args.max_time)
        if problem:
            return problem
    if getattr(args, "speed", None) is not None:
        return speed_problem(args.speed)
    return None


def link_problem(path: str | None) -> str | None:
    """``--link PATH``: a symbolic link can be made there (its folder exists, no folder
    is in its place); None when it can, or when no link is asked for."""
    if not path:
        return None
    folder = os.path.dirname(path) or "."
    if not os.path.isdir(folder):
        return msg.LINK_NO_FOLDER.format(path=path, folder=folder)
    if os.path.isdir(path) and not os.path.islink(path):
        return msg.LINK_IS_FOLDER.format(path=path)
    return None
