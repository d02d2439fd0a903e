"""The console's ``/trace``, ``/vcd``, ``/plot`` and ``/report`` commands.

On a simulated chip the console records the recent motion from the start (issue 16):
a :class:`~stepperdemo.watch.recent.RecentTrace` keeps the last
:data:`~stepperdemo.watch.recent.MAX_EDGES` pin edges, so ``/plot``, ``/report`` and
``/vcd`` work at once.  ``/trace on`` replaces it by an unbounded recording from now
(issue 6: recorders attached to the running chip, the VCD spooled to a file, so that
``/vcd FILE`` saves what was recorded so far); ``/trace off`` stops whichever is
recording and keeps what it holds for ``/vcd``, ``/plot`` and ``/report``;
``/trace recent`` goes back to the bounded recording.  Only one recording exists at a
time: starting one lets go of the last.  A new chip (``/arch``) gets the recent
recording unless the trace was turned off or on (an unbounded recording of the old
chip stays, as after ``/trace off``).  On a device (``--port``) or a board there are
no simulated pins: nothing is recorded.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable

from fas.sim import SimBackend

from .. import messages as msg
from ..watch.observe import Observers
from ..watch.options import is_vcd_unit, vcd_unit
from ..watch.recent import MAX_EDGES, RecentTrace, bound_seconds

META_COMMANDS = {
    "/trace": "record the pins: on|off|recent",
    "/vcd": "save the recorded pins as VCD",
    "/plot": "position/speed plot [FILE.png]",
    "/report": "timing report",
}

RECENT, ON, OFF = "recent", "on", "off"  # what the console records


def help_lines(max_edges: int = MAX_EDGES) -> list[str]:
    """The /help part of these commands, with the bound of the recent recording."""
    return msg.REPL_HELP_OBSERVE.format(bound=max_edges,
                                        seconds=bound_seconds(max_edges)).splitlines()


class TraceCommands:
    def __init__(self, get_app: Callable[[], object], *, recent: bool = True,
                 max_edges: int = MAX_EDGES, timescale: str | None = None) -> None:
        self.get_app = get_app  # the console's current program (changes with /arch)
        self.max_edges = max_edges
        # the unit of /vcd FILE without one: --vcd-timescale, else the console's default
        self.timescale = timescale
        self.mode = RECENT if recent else OFF
        # the one recording: the recent one, an unbounded one (/trace on), or the last
        # of either after /trace off; None before anything was recorded
        self.recording: RecentTrace | Observers | None = None

    @property
    def observers(self) -> Observers | None:
        """The unbounded recording (/trace on), if that is the one there is."""
        rec = self.recording
        return rec if isinstance(rec, Observers) else None

    @property
    def recent(self) -> RecentTrace | None:
        rec = self.recording
        return rec if isinstance(rec, RecentTrace) else None

    def handles(self, cmd: str) -> bool:
        return cmd in META_COMMANDS

    def command(self, cmd: str, args: list[str]) -> list[str]:
        """Run one meta command; returns the lines to show."""
        if cmd == "/trace":
            return self._trace(args)
        if self.recording is None:
            return [msg.REPL_TRACE_NOTHING]
        if cmd == "/vcd":
            return self._vcd(args)
        if cmd == "/plot":
            return self._plot(args)
        return self._report()

    # ------------------------------------------------------------ chips
    def new_chip(self) -> list[str]:
        """The console runs a new program (start, /arch): record it as the mode says."""
        if self.mode == RECENT and self._simulated():
            self._start_recent()
        return []

    def stop(self) -> list[str]:
        """The console leaves the chip (/arch): the recent recording goes with it, an
        unbounded one is kept (as after /trace off)."""
        rec = self.recording
        if rec is None or not rec.active:
            return []
        if self.mode == ON:
            rec.finish()
            self.mode = OFF
            return [msg.REPL_TRACE_ARCH_KEPT.format(profile=rec.profile.name)]
        self.close()
        return []

    def close(self) -> None:
        """Stop recording and let go of it (removes a spool file)."""
        if self.recording is not None:
            self.recording.discard()
            self.recording = None

    def _simulated(self) -> bool:
        return isinstance(getattr(self.get_app(), "backend", None), SimBackend)

    def _positions(self, app) -> list[int | None]:
        return [None if s is None else s.get_current_position() for s in app.steppers]

    def _start_recent(self) -> RecentTrace:
        self.close()
        app = self.get_app()
        rec = RecentTrace(app.backend, positions=self._positions(app),
                          extra_signals=app.trace_signals(), max_edges=self.max_edges)
        self.recording = rec.start()
        return rec

    # ----------------------------------------------------------- commands
    def _trace(self, args: list[str]) -> list[str]:
        what = args[0].lower() if args else ""
        rec = self.recording
        if what == ON:
            obs = self.observers
            if obs is not None and obs.active:
                return [msg.REPL_TRACE_ALREADY.format(t=self._s(obs.stream.start_tick))]
            self.close()
            app = self.get_app()
            obs = Observers(app.backend, spool_vcd=True, positions=self._positions(app),
                            extra_signals=app.trace_signals()).start()
            self.recording = obs
            self.mode = ON
            app.watch(obs)  # the program's own figures (the winder's interlock)
            return [msg.REPL_TRACE_ON.format(t=self._s(obs.stream.start_tick))]
        if what == RECENT:
            if self.recent is not None and self.recent.active:
                return [msg.REPL_TRACE_RECENT_ALREADY.format(bound=self.max_edges)]
            rec = self._start_recent()
            self.mode = RECENT
            return [msg.REPL_TRACE_RECENT_ON.format(bound=self.max_edges,
                                                    seconds=bound_seconds(self.max_edges),
                                                    t=self._s(rec.start_tick))]
        if what == OFF:
            self.mode = OFF
            if rec is None or not rec.active:
                return [msg.REPL_TRACE_NOT_ON]
            rec.finish()
            start, end = self._s(rec.start_tick), self._s(rec.end_tick)
            if isinstance(rec, RecentTrace):
                return [msg.REPL_TRACE_RECENT_OFF.format(held=rec.edges(), start=start, end=end)]
            return [msg.REPL_TRACE_OFF.format(edges=rec.edges(), start=start, end=end)]
        if what:
            return [msg.REPL_BAD_ARG.format(cmd="/trace", problem=msg.REPL_TRACE_BAD)]
        return [self._status()]

    def _status(self) -> str:
        rec = self.recording
        if rec is None:
            return msg.REPL_TRACE_NOT_ON
        rec.flush()
        start, end = self._s(rec.start_tick), self._s(rec.now_tick())
        if not rec.active:
            return msg.REPL_TRACE_OFF_KEPT.format(edges=rec.edges(), start=start, end=end)
        if isinstance(rec, RecentTrace):
            dropped = (msg.REPL_TRACE_RECENT_DROPPED.format(dropped=rec.dropped)
                       if rec.dropped else "")
            return msg.REPL_TRACE_RECENT_STATUS.format(held=rec.edges(), start=start, end=end,
                                                       bound=self.max_edges, dropped=dropped)
        return msg.REPL_TRACE_STATUS.format(state=ON, edges=rec.edges(), start=start)

    def _vcd(self, args: list[str]) -> list[str]:
        """``/vcd FILE [UNIT]``: the unit as one word (1us, exact) or two (1 us)."""
        if not args or len(args) > 3:
            return [msg.REPL_BAD_ARG.format(cmd="/vcd", problem=msg.REPL_VCD_USAGE)]
        path, given = args[0], " ".join(args[1:]) or self.timescale
        if given is not None and not is_vcd_unit(given):
            return [msg.REPL_BAD_ARG.format(cmd="/vcd",
                                            problem=msg.REPL_VCD_BAD_UNIT.format(unit=given))]
        unit = vcd_unit(given)  # None: exact
        rec = self.recording
        try:
            edges, zero = rec.export_vcd(path, unit)
        except OSError as exc:
            return [msg.OBSERVE_FILE_ERROR.format(path=path, error=exc)]
        text = msg.REPL_VCD_WROTE.format(path=path, edges=edges,
                                         start=self._s(rec.start_tick),
                                         end=self._s(rec.now_tick()))
        if isinstance(rec, RecentTrace) and rec.dropped:
            text += msg.REPL_VCD_START_DROPPED.format(bound=self.max_edges)
        if zero:
            text += msg.REPL_VCD_ZERO_WIDTH.format(n=zero, unit=unit, path=path)
        return [text]

    def _view(self, app=None):
        """What plots and reports read: the unbounded recording itself, or the recent
        one replayed (with ``app``'s own consumers)."""
        rec = self.recording
        return rec.window(app) if isinstance(rec, RecentTrace) else rec

    def _plot(self, args: list[str]) -> list[str]:
        from ..watch import plots

        view = self._view()
        series = plots.series_of(view)
        outputs = plots.outputs_of(view)
        if not args:
            width = max(20, min(shutil.get_terminal_size((80, 24)).columns - 14, 120))
            return plots.terminal_plot(series, width=width, outputs=outputs)
        if not plots.png_available():
            return [msg.PLOT_EXTRA_MISSING]
        problem = plots.write_png_or_problem(series, args[0], outputs=outputs)
        return [problem or msg.OBSERVE_WROTE.format(path=args[0])]

    def _report(self) -> list[str]:
        from ..watch import report

        app = self._app_of_trace()
        rec = self.recording
        view = self._view(app)
        lines = report.report_lines(view, positions=report.library_positions(app))
        if isinstance(rec, RecentTrace) and rec.dropped:
            lines.insert(1, msg.REPORT_RECENT_WINDOW.format(held=rec.edges(),
                                                            dropped=rec.dropped))
        return lines + (app.watch_report() if app is not None else [])

    # ------------------------------------------------------------ helpers
    def _app_of_trace(self):
        app = self.get_app()
        rec = self.recording
        return app if rec is not None and app.backend is rec.backend else None

    def _s(self, tick: int | None) -> float:
        rec = self.recording
        return (tick or 0) / rec.profile.ticks_per_s if rec is not None else 0.0
