"""The console's ``/trace``, ``/vcd``, ``/plot`` and ``/report`` commands.

``/trace on`` attaches recorders to the running simulated chip (switchable at run
time: the edge stream is added to and removed from the pin bank's sinks); the VCD
goes to a spool file so that ``/vcd FILE`` can save what was recorded so far, while
recording goes on or after ``/trace off``.  The last recording stays available for
``/vcd``, ``/plot`` and ``/report`` until the next ``/trace on``.
"""

from __future__ import annotations

import shutil
from collections.abc import Callable

from .. import messages as msg
from ..watch.observe import Observers

META_COMMANDS = {
    "/trace": "record the pins: on|off",
    "/vcd": "save the recorded pins as VCD",
    "/plot": "position/speed plot [FILE.png]",
    "/report": "timing report",
}


class TraceCommands:
    def __init__(self, get_app: Callable[[], object]) -> None:
        self.get_app = get_app  # the console's current StepperDemo (changes with /arch)
        self.observers: Observers | None = None

    def handles(self, cmd: str) -> bool:
        return cmd in META_COMMANDS

    def command(self, cmd: str, args: list[str]) -> list[str]:
        """Run one meta command; returns the lines to show."""
        if cmd == "/trace":
            return self._trace(args)
        if self.observers is None:
            return [msg.REPL_TRACE_NOTHING]
        if cmd == "/vcd":
            return self._vcd(args)
        if cmd == "/plot":
            return self._plot(args)
        return self._report()

    # ----------------------------------------------------------- commands
    def _trace(self, args: list[str]) -> list[str]:
        obs = self.observers
        what = args[0].lower() if args else ""
        if what == "on":
            if obs is not None and obs.active:
                return [msg.REPL_TRACE_ALREADY.format(t=self._s(obs.stream.start_tick))]
            self.close()
            app = self.get_app()
            positions = [None if s is None else s.get_current_position() for s in app.steppers]
            self.observers = obs = Observers(app.backend, spool_vcd=True, positions=positions,
                                             extra_signals=app.trace_signals()).start()
            app.watch(obs)  # the program's own figures (the winder's interlock)
            return [msg.REPL_TRACE_ON.format(t=self._s(obs.stream.start_tick))]
        if what == "off":
            if obs is None or not obs.active:
                return [msg.REPL_TRACE_NOT_ON]
            obs.finish()
            start = self._s(obs.stream.start_tick)
            return [msg.REPL_TRACE_OFF.format(edges=obs.edges(), start=start,
                                              end=self._s(obs.end_tick))]
        if what:
            return [msg.REPL_BAD_ARG.format(cmd="/trace", problem="on or off")]
        if obs is None:
            return [msg.REPL_TRACE_NOT_ON]
        obs.flush()
        return [msg.REPL_TRACE_STATUS.format(state="on" if obs.active else "off",
                                             edges=obs.edges(),
                                             start=self._s(obs.stream.start_tick))]

    def _vcd(self, args: list[str]) -> list[str]:
        if len(args) != 1:
            return [msg.REPL_BAD_ARG.format(cmd="/vcd", problem="give a file name")]
        obs = self.observers
        try:
            edges = obs.export_vcd(args[0])
        except OSError as exc:
            return [msg.OBSERVE_FILE_ERROR.format(path=args[0], error=exc)]
        return [msg.REPL_VCD_WROTE.format(path=args[0], edges=edges,
                                          start=self._s(obs.stream.start_tick),
                                          end=self._s(obs.now_tick()))]

    def _plot(self, args: list[str]) -> list[str]:
        from ..watch import plots

        series = plots.series_of(self.observers)
        outputs = plots.outputs_of(self.observers)
        if not args:
            width = max(20, min(shutil.get_terminal_size((80, 24)).columns - 14, 120))
            return plots.terminal_plot(series, width=width, outputs=outputs)
        if not plots.png_available():
            return [msg.PLOT_EXTRA_MISSING]
        try:
            plots.write_png(series, args[0], outputs=outputs)
        except OSError as exc:
            return [msg.OBSERVE_FILE_ERROR.format(path=args[0], error=exc)]
        return [msg.OBSERVE_WROTE.format(path=args[0])]

    def _report(self) -> list[str]:
        from ..watch import report

        app = self._app_of_trace()
        lines = report.report_lines(self.observers, positions=report.library_positions(app))
        return lines + (app.watch_report() if app is not None else [])

    # ------------------------------------------------------------ helpers
    def _app_of_trace(self):
        app = self.get_app()
        return app if self.observers is not None and app.backend is self.observers.backend \
            else None

    def _s(self, tick: int | None) -> float:
        obs = self.observers
        return (tick or 0) / obs.profile.ticks_per_s if obs is not None else 0.0

    def stop(self) -> None:
        """Stop recording (the console switches to another chip); keep the results."""
        if self.observers is not None:
            self.observers.finish()

    def close(self) -> None:
        """Stop recording and remove the spool file."""
        if self.observers is not None:
            self.observers.discard()
            self.observers = None
