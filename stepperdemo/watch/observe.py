"""Watching a simulated run: VCD trace, per-step CSV, timing report and plots.

``attach(backend, vcd=..., csv=...)`` subscribes recorders to a :class:`SimBackend`
before (or while) StepperDemo runs on it; ``finish()`` closes the files.  The timing
report and the plots are available afterwards (and, for the console, at any time
while recording: :meth:`Observers.flush` brings the figures up to date).

The signals follow StepperDemo's wiring of the profile (``DemoBuild.steppers``):
``StepA``/``DirA``/``EnableA`` for stepper 1, ``B`` for stepper 2 and so on, plus
``IrqBlocked`` for the interrupt-blocked windows of the ``e`` injection.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import tempfile
from collections.abc import Sequence
from typing import IO

from fas.sim import SimBackend
from fas.sim.trace import (
    IRQ_BLOCKED,
    IRQ_BLOCKED_NAME,
    EdgeStream,
    VcdWriter,
    pin_levels,
)

from .. import messages as msg
from .motion import MotionAnalysis, Wiring, demo_wiring
from .outputs import OutputAnalysis, OutputPin, output_pins


def vcd_signals(wiring: Sequence[Wiring],
                outputs: Sequence[OutputPin] = ()) -> dict[int, list[str]]:
    """Pin -> VCD names; a pin shared by several steppers gets every name (aliases).

    ``outputs``: the user outputs (issue 12), ``Dout0..3`` and ``Aout0..3``."""
    signals: dict[int, list[str]] = {}
    for w in wiring:
        for pin, name in ((w.step, "Step"), (w.direction, "Dir"), (w.enable_low, "Enable"),
                          (w.enable_high, "EnableHigh")):
            if pin is not None:
                signals.setdefault(pin, []).append(name + w.label)
    for out in outputs:
        signals.setdefault(out.pin, []).append(out.name)
    signals[IRQ_BLOCKED] = [IRQ_BLOCKED_NAME]
    return signals


def recorded_signals(wiring: Sequence[Wiring], profile,
                     extra_signals: dict[int, list[str]] | None = None) -> dict[int, list[str]]:
    """The pins a recording keeps, with their VCD names: the steppers', the user
    outputs, the interrupt-blocked windows and a program's own pins (``extra_signals``)."""
    signals = vcd_signals(wiring, output_pins(profile))
    for pin, names in (extra_signals or {}).items():
        signals.setdefault(pin, []).extend(names)
    return signals


class Observers:
    """Recorders on one simulated backend: an ordered edge stream and its consumers."""

    def __init__(self, backend: SimBackend, *, vcd: str | None = None,
                 spool_vcd: bool = False, csv: str | None = None, analyse: bool = True,
                 positions: Sequence[int | None] | None = None,
                 timescale: str | None = None,
                 extra_signals: dict[int, list[str]] | None = None) -> None:
        self.backend = backend
        self.profile = backend.profile
        self.wiring = demo_wiring(self.profile)
        self.signals = recorded_signals(self.wiring, self.profile, extra_signals)
        self.stream = EdgeStream(backend)
        self.vcd_path = vcd
        self._spool = spool_vcd and vcd is None
        self._vcd_file: IO[str] | None = None
        self._csv_file: IO[str] | None = None
        self.csv_path = csv
        self.vcd: VcdWriter | None = None
        self.analysis: MotionAnalysis | None = None
        self.outputs: OutputAnalysis | None = None  # user outputs (issue 12)
        self._analyse = analyse or csv is not None
        self._positions = positions
        self._timescale = timescale
        self.end_tick: int | None = None

    # ------------------------------------------------------------ lifecycle
    def start(self) -> Observers:
        """Open the files and subscribe (raises OSError for a file that cannot be written)."""
        start = self.stream.start()
        levels = pin_levels(self.backend, self.signals)
        try:
            if self.vcd_path is not None or self._spool:
                if self._spool:
                    fd, self.vcd_path = tempfile.mkstemp(prefix="stepperdemo-", suffix=".vcd")
                    os.close(fd)
                self._vcd_file = open(self.vcd_path, "w", encoding="ascii",  # noqa: SIM115 - until finish()
                                      newline="\n", buffering=1 << 20)
                self.vcd = VcdWriter(self._vcd_file, self.signals, self.profile.ticks_per_s,
                                     start_tick=start, initial=levels,
                                     timescale=self._timescale,
                                     comment=msg.VCD_COMMENT.format(profile=self.profile.name))
                self.stream.add(self.vcd)
            if self.csv_path is not None:
                self._csv_file = open(self.csv_path, "w", encoding="ascii",  # noqa: SIM115 - until finish()
                                      newline="\n", buffering=1 << 20)
        except OSError:
            self._abort()
            raise
        if self._analyse:
            self.analysis = MotionAnalysis(self.backend, self.wiring, positions=self._positions,
                                           csv=self._csv_file, initial=levels)
            self.stream.add(self.analysis)
            self.outputs = OutputAnalysis(self.profile, initial=pin_levels(
                self.backend, [o.pin for o in output_pins(self.profile)]))
            self.stream.add(self.outputs)
        return self

    def _abort(self) -> None:
        self.stream.stop()
        for f in (self._vcd_file, self._csv_file):
            if f is not None:
                f.close()
        if self._spool and self.vcd_path:
            _remove(self.vcd_path)

    @property
    def active(self) -> bool:
        return self.end_tick is None

    @property
    def start_tick(self) -> int:
        return self.stream.start_tick

    def flush(self) -> None:
        """Hand on every edge that can no longer change (figures up to date)."""
        if self.active:
            self.stream.flush(settle=True)

    def finish(self) -> None:
        """Stop recording: hand on everything, close the files.  Idempotent."""
        if not self.active:
            return
        self.end_tick = end = self.stream.stop()
        if self.analysis is not None:
            self.analysis.finish(end)
        if self.outputs is not None:
            self.outputs.finish(end)
        if self.vcd is not None:
            self.vcd.close(end)
            self._vcd_file.close()
        if self._csv_file is not None:
            self._csv_file.close()

    def discard(self) -> None:
        """Finish and remove a spooled VCD file."""
        self.finish()
        if self._spool and self.vcd_path:
            _remove(self.vcd_path)
            self.vcd_path = None

    # --------------------------------------------------------------- output
    def now_tick(self) -> int:
        return self.end_tick if self.end_tick is not None else max(self.stream.last_tick,
                                                                    self.backend.now())

    def export_vcd(self, path: str, timescale: str | None = None) -> tuple[int, int]:
        """Copy the VCD recorded so far to ``path``, in another ``timescale`` if one is
        given; returns the number of edges in it and how many of them have no width
        (``VcdWriter.zero_width``)."""
        if self.vcd is None or not self.vcd_path:
            raise ValueError("no VCD is being recorded")
        self.flush()
        zero = self.vcd.copy_to(path, self.now_tick(), timescale)
        return self.vcd.changes, zero

    def edges(self) -> int:
        return self.stream.edges_out


def _remove(path: str) -> None:
    with contextlib.suppress(OSError):
        os.remove(path)


def attach(backend: SimBackend, *, vcd: str | None = None, csv: str | None = None,
           analyse: bool = True, positions: Sequence[int | None] | None = None,
           timescale: str | None = None,
           extra_signals: dict[int, list[str]] | None = None) -> Observers:
    """Start recording a simulated run (see :class:`Observers`); call ``finish()`` after."""
    return Observers(backend, vcd=vcd, csv=csv, analyse=analyse, positions=positions,
                     timescale=timescale, extra_signals=extra_signals).start()


# ----------------------------------------------------------- command line
# the options themselves live in .options (the command line loads them without the
# recorders); from_arguments/finish_arguments use them
from .options import add_arguments, check_arguments, vcd_unit, wanted  # noqa: E402,F401


def from_arguments(backend: SimBackend, args: argparse.Namespace,
                   extra_signals: dict[int, list[str]] | None = None) -> Observers | None:
    """Attach what the options ask for (None if nothing); OSError if a file can't be made."""
    if not wanted(args):
        return None
    return attach(backend, vcd=args.vcd, csv=args.steps_csv,
                  analyse=bool(args.report or args.plot or args.steps_csv),
                  timescale=vcd_unit(getattr(args, "vcd_timescale", None)),
                  extra_signals=extra_signals)


def finish_arguments(obs: Observers, args: argparse.Namespace, app=None,
                     title: str = "") -> tuple[list[str], str | None]:
    """Finish recording, write the plot; returns the report lines to print (maybe none)
    and the problem with the plot file (None: written, or none asked for)."""
    from . import plots, report

    obs.finish()
    if obs.vcd is not None and obs.vcd.zero_width:  # said where the file is named
        print(msg.VCD_ZERO_WIDTH.format(path=args.vcd, n=obs.vcd.zero_width,
                                        unit=obs.vcd.timescale), file=sys.stderr)
    out: list[str] = []
    problem = None
    if args.plot:
        series = plots.series_of(obs)
        units = getattr(app, "path_units", None)  # G-code: the feed along the path too
        feed = plots.path_feed(series, units()) if callable(units) else None
        problem = plots.write_png_or_problem(
            series, args.plot, plots.parse_size(args.plot_size),
            title=plots.plot_title(title), outputs=plots.outputs_of(obs), feed=feed)
    if args.report:
        out.extend(report.report_lines(obs, positions=report.library_positions(app)))
        if app is not None:
            out.extend(app.watch_report())  # the program's own figures
    return out, problem
