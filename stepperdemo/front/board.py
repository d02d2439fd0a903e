"""``stepperdemo --board DEVICE``: the console in front of a board running StepperDemo.

Most FastAccelStepper users have the original StepperDemo sketch on a board.  With
``--board`` the console talks to it over its serial port (pyserial) instead of
running the simulation:

* the REPL (:class:`BoardConsole`, the simulation's :class:`~.console.Console` with
  the board where the program was): lines go to the board one command at a time
  (:mod:`.board_input`), its output is shown as it arrives (CR LF handled, status
  lines dimmed); history, completion and toolbar follow the board's mode as its
  answers tell it; ``/plot`` and ``/report`` read its status lines; Ctrl-C sends
  ``X`` to every stepper; a board that restarts or disappears gives one line, and
  ``/reconnect`` opens it again;
* ``-c LINE`` (:func:`run_scripted`): the line, the board's output on stdout as it
  arrives, the end when the board is idle (:mod:`.board_session` says how that is
  read from its text).

Exit codes of ``-c`` on a board: 0 ok, 1 a test sequence failed, 2 bad arguments or
the port cannot be opened, 3 ``--max-time`` reached with the board still busy,
5 the board was lost or restarted during the run, or nothing StepperDemo prints came
within 3 s of the first command (``board_session.NO_ANSWER_S``: another sketch, a
wrong ``--baud``), 130 interrupted (Ctrl-C; the stop was sent).
"""

from __future__ import annotations

import argparse
import shutil
import sys
from collections.abc import Callable

from fas.serial.stream import LinkClosed

from .. import messages as msg
from ..demo.command_registry import COMMANDS
from ..demo.command_table import Mode
from ..watch import plots, status_report
from .board_link import BoardLink, SerialBoardLink
from .board_log import BoardLog
from .board_options import add_arguments, check_arguments  # noqa: F401 (re-exported)
from .board_session import BOOT_WAIT_S, NO_ANSWER_S, POLL_S, BoardSession, End
from .console import Console, toolbar_hints

EXIT_OK = 0
EXIT_TEST_FAILED = 1
EXIT_USAGE = 2
EXIT_MAX_TIME = 3
EXIT_LOST = 5
EXIT_INTERRUPTED = 130

META_COMMANDS = {
    "/help": "console commands",
    "/quit": "leave the console",
    "/stop": "X to every stepper (Ctrl-C)",
    "/reset": "restart the board (DTR)",
    "/reconnect": "open the board again [port]",
    "/state": "mode, stepper, toggles, positions",
    "/time": "session time",
    "/plot": "position/speed from status lines [FILE.png]",
    "/report": "report from the status lines",
}
_SIMULATION_ONLY = ("/arch", "/speed", "/trace", "/vcd", "/link", "/estop")
PARTIAL_LINE_S = 0.3  # a line the board left unfinished is shown after this long


def _open(args: argparse.Namespace) -> BoardLink:
    return SerialBoardLink(args.board, args.baud)


def _open_log(args: argparse.Namespace) -> BoardLog | None:
    return BoardLog(args.log, args.board, args.baud) if args.log else None


def plot_lines(session: BoardSession, argv: list[str]) -> list[str]:
    """``/plot [FILE.png]`` from the status lines."""
    series = status_report.series_of(session.state.trace)
    if not argv:
        width = max(20, min(shutil.get_terminal_size((80, 24)).columns - 14, 120))
        return plots.terminal_plot(series, width=width)
    if not plots.png_available():
        return [msg.PLOT_EXTRA_MISSING]
    problem = plots.write_png_or_problem(series, argv[0])
    return [problem or msg.OBSERVE_WROTE.format(path=argv[0])]


# ------------------------------------------------------------------ -c LINE
def run_scripted(args: argparse.Namespace, write: Callable[[bytes], None]) -> int:
    """``stepperdemo --board DEVICE -c LINE`` (exit codes in the module text)."""
    problem = check_arguments(args)
    if problem:
        print(msg.CLI_ERROR.format(problem=problem), file=sys.stderr)
        return EXIT_USAGE
    try:
        link = _open(args)
        log = _open_log(args)
    except (LinkClosed, OSError) as exc:
        print(msg.CLI_BOARD_CONNECT.format(port=args.board, error=exc), file=sys.stderr)
        return EXIT_USAGE
    out = sys.stdout.buffer

    def show(data: bytes) -> None:
        write(data)
        out.flush()

    session = BoardSession(link, output=show, log=log, quiet_s=args.quiet_ms / 1000,
                           boot_wait_s=args.boot_wait, lost_note=None,  # said at the end
                           notes=lambda text: print(text, file=sys.stderr))
    try:
        session.wait_ready()
        end = session.run_script(args.command, args.max_time)
    except KeyboardInterrupt:
        numbers, _ = session.stop_all()
        session.settle(1.0)  # show the board's answer to the stop
        print(msg.CLI_BOARD_INTERRUPTED.format(steppers=" ".join(f"M{n}" for n in numbers)),
              file=sys.stderr)
        session.close()
        return EXIT_INTERRUPTED
    reason = session.busy_reason()
    silent = session.silent_reason()
    session.close()
    out.flush()
    if getattr(args, "plot", None):
        size = plots.parse_size(args.plot_size)
        problem = plots.write_png_or_problem(
            status_report.series_of(session.state.trace), args.plot, size,
            title=plots.plot_title(args.command))
        if problem is not None:
            print(msg.CLI_ERROR.format(problem=problem), file=sys.stderr)
    if getattr(args, "report", False):
        for line in status_report.report_lines(session.state.trace, args.board):
            print(line)
    if end == End.NO_ANSWER:
        print(msg.CLI_BOARD_NO_ANSWER.format(port=args.board, seconds=NO_ANSWER_S,
                                             why=silent, baud=args.baud), file=sys.stderr)
        return EXIT_LOST
    if end == End.LOST:
        print(msg.CLI_BOARD_LOST.format(reason=session.lost), file=sys.stderr)
        return EXIT_LOST
    if end == End.RESET:
        print(msg.CLI_BOARD_RESTARTED, file=sys.stderr)
        return EXIT_LOST
    if end == End.MAX_TIME:
        why = msg.BOARD_BUSY_WHY.get(reason or "", reason or "")
        print(msg.CLI_BOARD_MAX_TIME.format(seconds=args.max_time, why=why), file=sys.stderr)
        return EXIT_MAX_TIME
    return EXIT_TEST_FAILED if session.state.tests_failed else EXIT_OK


# --------------------------------------------------------------------- REPL
class BoardProgram:
    """The board, where the console has its program: what the REPL asks of it."""

    title = "board"

    def __init__(self, session: BoardSession) -> None:
        self.session = session
        self.steppers: list = []  # the library's steppers: none here, they are on the board

    def feed(self, text: str | bytes) -> None:
        self.session.send(text)

    def input_pending(self) -> bool:
        return False  # the driver's delay covers the input waiting for the board

    def force_stop_all(self) -> None:
        self.session.stop_all()

    def mode_name(self) -> str:
        return self.session.state.mode

    def completions(self) -> list[tuple[str, str]]:
        return COMMANDS.hints(Mode[self.mode_name().upper()])

    def toolbar_status(self) -> str:
        return f"M{self.session.state.selected}"


class BoardDriver:
    """The console's driver: serves the link (the board runs by itself)."""

    scale = 1.0

    def __init__(self, console: BoardConsole) -> None:
        self.console = console

    def set_scale(self, scale: float) -> None:
        """The board's clock is its own."""

    def advance(self) -> float | None:
        con = self.console
        s = con.session
        s.poll(0.0)
        con.check_silence()
        if con.output_pending() and s.now() - s.last_rx_s >= PARTIAL_LINE_S:
            con.flush(final=True)  # a line the board did not finish (yet)
        wake = s.pacer.wake_in(s.now(), s.last_rx_s)
        return POLL_S if wake is None else min(wake, POLL_S)


class BoardConsole(Console):
    """The REPL in front of a board (see the module text)."""

    meta_commands = META_COMMANDS

    def __init__(self, device: str, *, baud: int = 115200, log: str | None = None,
                 history: str | None = None, link: BoardLink | None = None,
                 boot_wait_s: float = BOOT_WAIT_S, input=None, output=None) -> None:
        self.device = device
        self.baud_rate = baud
        self._link = link
        self._log_path = log
        self._boot_wait_s = boot_wait_s
        self.session: BoardSession | None = None
        self._silence_noted = False
        super().__init__(history=history, input=input, output=output)

    def _start(self, arch: str) -> None:
        link = self._link or SerialBoardLink(self.device, self.baud_rate)
        log = BoardLog(self._log_path, self.device, self.baud_rate) if self._log_path else None
        self.session = BoardSession(link, output=self._collect, notes=self.note, log=log,
                                    boot_wait_s=self._boot_wait_s)
        self.backend = None
        self.app = BoardProgram(self.session)
        self.driver = BoardDriver(self)

    def welcome(self) -> str:
        return msg.BOARD_WELCOME.format(version=msg.VERSION, port=self.session.link.name,
                                        baud=self.baud_rate)

    def close_session(self) -> None:
        self.session.close()

    def check_silence(self) -> None:
        """One note when the port does not answer as StepperDemo (board_session)."""
        why = self.session.silent_reason()
        if why is None:
            self._silence_noted = False  # (a reconnect starts the question again)
        elif not self._silence_noted:
            self._silence_noted = True
            self.note(msg.BOARD_NO_ANSWER.format(seconds=NO_ANSWER_S, why=why,
                                                 baud=self.baud_rate))

    # ------------------------------------------------------------ toolbar
    def toolbar(self):
        from prompt_toolkit.formatted_text import FormattedText

        s = self.session
        st = s.state
        if s.lost is not None:
            status = msg.BOARD_TOOLBAR_LOST
        else:
            held = s.pacer.held_by()
            status = msg.BOARD_TOOLBAR_STATUS.format(
                mode=st.mode, selected=st.selected,
                running=" ".join(f"M{n}" for n in st.running()) or msg.BOARD_NONE,
                held=msg.BOARD_TOOLBAR_HELD.format(why=held) if held else "", t=s.now())
        return FormattedText([("bold", msg.BOARD_TOOLBAR.format(port=s.link.name)),
                              ("", status), ("italic", toolbar_hints(self.app.completions()))])

    # ------------------------------------------------------- meta commands
    def handle_line(self, line: str) -> None:
        s = self.session
        if s.lost is not None and not line.strip().startswith("/"):
            self.note(msg.BOARD_NOT_CONNECTED.format(reason=s.lost))
            return
        super().handle_line(line)

    def interrupt(self) -> None:
        """Ctrl-C: X to every stepper at once."""
        s = self.session
        if s.lost is not None:
            self.note(msg.BOARD_NOT_CONNECTED.format(reason=s.lost))
            return
        spinning = s.state.spinning
        numbers, left = s.stop_all()
        self.note(msg.BOARD_STOP_SENT.format(
            steppers=" ".join(f"M{n}" for n in numbers),
            left=msg.BOARD_STOP_LEFT_MODE.format(mode=left) if left else ""))
        if spinning:
            self.note(msg.BOARD_STOP_SPINNING)
        self._wake.set()

    def meta(self, line: str) -> None:
        parts = line.split()
        cmd, args = parts[0], parts[1:]
        s = self.session
        if cmd == "/help":
            lines = msg.BOARD_HELP.splitlines()
        elif cmd in ("/quit", "/exit"):
            self.quit = True
            return
        elif cmd == "/stop":
            self.interrupt()
            return
        elif cmd == "/reset":
            lines = [msg.BOARD_RESET_SENT.format(how=s.reset())]
        elif cmd == "/reconnect":
            try:
                s.reconnect(args[0] if args else None)
                lines = [msg.BOARD_RECONNECTED.format(port=s.link.name)]
            except (LinkClosed, OSError) as exc:
                lines = [msg.BOARD_RECONNECT_FAILED.format(error=exc)]
        elif cmd == "/state":
            lines = self._state_lines()
        elif cmd == "/time":
            lines = [msg.BOARD_TIME.format(t=s.now(), lines=s.lines, status=s.state.trace.lines)]
        elif cmd == "/plot":
            lines = plot_lines(s, args)
        elif cmd == "/report":
            lines = status_report.report_lines(s.state.trace, s.link.name)
        elif cmd in _SIMULATION_ONLY:
            lines = [msg.BOARD_NOT_ON_BOARD.format(cmd=cmd)]
        else:
            lines = [msg.REPL_UNKNOWN_META.format(cmd=cmd)]
        for text in lines:
            self.note(text)

    def _state_lines(self) -> list[str]:
        s = self.session
        st = s.state
        positions = ", ".join(f"M{n} {p}" for n, p in st.positions().items())
        lines = [msg.BOARD_STATE.format(
            mode=st.mode, selected=st.selected,
            verbose=msg.BOARD_ON if st.verbose else msg.BOARD_OFF,
            usage=msg.BOARD_ON if st.usage_info else msg.BOARD_OFF,
            running=" ".join(f"M{n}" for n in st.running()) or msg.BOARD_NONE,
            positions=positions or msg.BOARD_NONE)]
        held = s.pacer.held_by()
        if held or s.pacer.queue:
            lines.append(msg.BOARD_STATE_HELD.format(
                why=msg.BOARD_BUSY_WHY.get(held or "input", held), n=len(s.pacer.queue)))
        return lines


def run_console(args: argparse.Namespace) -> int:
    """``stepperdemo --board DEVICE``: the REPL."""
    import asyncio

    problem = check_arguments(args)
    if problem:
        print(msg.CLI_ERROR.format(problem=problem), file=sys.stderr)
        return EXIT_USAGE
    try:
        console = BoardConsole(args.board, baud=args.baud, log=args.log, history=args.history,
                               boot_wait_s=args.boot_wait)
    except (LinkClosed, OSError) as exc:
        print(msg.CLI_BOARD_CONNECT.format(port=args.board, error=exc), file=sys.stderr)
        return EXIT_USAGE
    return asyncio.run(console.run())
