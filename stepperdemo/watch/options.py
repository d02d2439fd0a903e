"""The command-line options for watching a run (``--vcd``, ``--plot``, ``--report``,
``--steps-csv``), apart from the recorders (:mod:`.observe`) so that the command line
starts without loading them."""

from __future__ import annotations

import argparse
import re

from .. import messages as msg

#: the time unit of the VCD files the console writes.  PulseView and sigrok-cli expand a
#: VCD into samples of this unit, so their time grows with duration / unit: at 1 us a
#: 100 s recording opens in a second, at the chip's exact 100 ps (16 MHz) in hours.
#: 1 us keeps every step, dir and enable edge (the shortest step pulse of any profile is
#: 1 us, 16 ticks) and rounds times down to the microsecond; shorter PWM highs or lows
#: lose their width.  "exact" is the coarsest unit in which every tick is exact.
DEFAULT_VCD_TIMESCALE = "1 us"
EXACT_VCD_TIMESCALE = "exact"


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The observer options of ``stepperdemo -c`` (and ``stepperdemo run``)."""
    g = ap.add_argument_group("watching the run (simulated backend)")
    g.add_argument("--vcd", metavar="FILE",
                   help="write the step/dir/enable pins of every stepper, the user outputs "
                        "(Dout0-3, Aout0-3 as PWM waveforms) and the interrupt-blocked "
                        "windows as a VCD file (GTKWave, PulseView)")
    g.add_argument("--vcd-timescale", metavar="UNIT",
                   help=f"VCD time unit (default '{DEFAULT_VCD_TIMESCALE}': PulseView, "
                        "sigrok-cli and GTKWave open long recordings at once; every step, "
                        "dir and enable edge is kept, times rounded down to the unit; PWM "
                        "highs or lows shorter than it lose their width), e.g. '100 ns', "
                        "or 'exact': every tick exact (100 ps at 16 MHz; PulseView then "
                        "takes minutes for a recording of seconds)")
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
    if timescale is not None and not is_vcd_unit(timescale):
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


def vcd_unit(text: str | None) -> str | None:
    """The timescale a :class:`fas.sim.trace.VcdWriter` gets for a unit as given on the
    command line or to ``/vcd``: None (not given) is :data:`DEFAULT_VCD_TIMESCALE`,
    ``exact`` is None (the writer's exact unit), anything else itself."""
    if text is None:
        return DEFAULT_VCD_TIMESCALE
    if text.strip().lower() == EXACT_VCD_TIMESCALE:
        return None
    spaced = re.fullmatch(r"\s*(\d+)\s*([a-zA-Z]+)\s*", text)  # "1us" -> "1 us", as in VCD
    return f"{spaced[1]} {spaced[2]}" if spaced else text


def is_vcd_unit(text: str) -> bool:
    """``exact`` or a VCD timescale: 1, 10 or 100 and s, ms, us, ns, ps or fs."""
    unit = vcd_unit(text)
    if unit is None:
        return True
    from fas.sim.trace import timescale_fs
    try:
        timescale_fs(unit)
    except (ValueError, KeyError):
        return False
    return True
