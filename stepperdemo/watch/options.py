"""The command-line options for watching a run (``--vcd``, ``--plot``, ``--report``,
``--steps-csv``), apart from the recorders (:mod:`.observe`) so that the command line
starts without loading them."""

from __future__ import annotations

import argparse

from .. import messages as msg


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The observer options of ``stepperdemo -c`` (and ``stepperdemo run``)."""
    g = ap.add_argument_group("watching the run (simulated backend)")
    g.add_argument("--vcd", metavar="FILE",
                   help="write the step/dir/enable pins of every stepper, the user outputs "
                        "(Dout0-3, Aout0-3 as PWM waveforms) and the interrupt-blocked "
                        "windows as a VCD file (GTKWave, PulseView)")
    g.add_argument("--vcd-timescale", metavar="UNIT",
                   help="VCD time unit, e.g. '1 us' (default: the coarsest standard unit "
                        "in which every tick is exact, 100 ps at 16 MHz; a coarser unit "
                        "rounds the times but keeps PulseView imports small)")
    g.add_argument("--plot", metavar="FILE.png",
                   help="plot position and speed over time per stepper as PNG "
                        "(needs the 'plot' extra: matplotlib)")
    g.add_argument("--plot-size", metavar="WxH", default="1200x800",
                   help="pixel size of the --plot image (default 1200x800)")
    g.add_argument("--report", action="store_true",
                   help="print a timing report per stepper after the transcript")
    g.add_argument("--steps-csv", metavar="FILE",
                   help="write one row per step: time_us,stepper,direction,position,tick")


def wanted(args: argparse.Namespace) -> bool:
    return bool(getattr(args, "vcd", None) or getattr(args, "plot", None)
                or getattr(args, "report", False) or getattr(args, "steps_csv", None))


def check_arguments(args: argparse.Namespace) -> str | None:
    """A problem with the observer options (before anything runs), else None."""
    if getattr(args, "command", "") is None and wanted(args):
        return msg.OBSERVE_NOT_INTERACTIVE
    timescale = getattr(args, "vcd_timescale", None)
    if timescale is not None:
        from fas.sim.trace import timescale_factor
        try:
            timescale_factor(timescale, 1_000_000)
        except (ValueError, KeyError):
            return msg.OBSERVE_BAD_TIMESCALE.format(timescale=timescale)
    if getattr(args, "plot", None):
        from . import plots
        if plots.parse_size(args.plot_size) is None:
            return msg.OBSERVE_BAD_SIZE.format(size=args.plot_size)
        problem = plots.path_problem(args.plot)  # the file is written after the run
        if problem is not None:
            return problem
        if not plots.png_available():
            return msg.PLOT_EXTRA_MISSING
    return None
