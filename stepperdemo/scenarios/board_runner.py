"""``stepperdemo run --board DEVICE FILES``: scenario files on a board, and the twin check.

Each file runs on a board with the original StepperDemo: the board is reset (DTR,
as an Arduino restarts when its port is opened), its start-up text is awaited, the
input line goes in the way the console sends it (:mod:`..front.board_input`), and
the run ends when the board is idle (:mod:`..front.board_session`).  Then ``?``
asks for the stepper table.  What the text can show is checked:

* the positions of the steppers (the table) against the file's ``position``;
* tests: when a test sequence completed, it must have passed;
* ``transcript.contains`` / ``not_contains`` on the board's text;
* the banner (F_CPU, TICKS_PER_S, Steppers) against the file's profile.

The board is known before the first file: its start banner says its chip.  A file
written for another chip (its profile's F_CPU, ticks per second or number of steppers
differ from the banner's) is skipped with the reason, not run and failed: the folder of
examples holds files for several chips.

Pulse, direction and enable counts and times need the pins: not checked here.
Whole-transcript references (``transcript.matches``) are of the firmware built with
a built-in input line, not of the interactive firmware on a board: not checked.

The twin check runs the same input the same way on the simulated board
(:class:`~..front.board_link.SimBoardLink`, virtual time) and reports per stepper
the difference in position (a check, within the file's position tolerance) and in
the times of the status lines (from the first command sent; information).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

from fas.arch import get_profile
from fas.serial.stream import LinkClosed

from .. import messages as msg
from ..front.board_link import BoardLink, SerialBoardLink, SimBoardLink
from ..front.board_log import BoardLog
from ..front.board_session import BOOT_WAIT_S, QUIET_S, BoardSession, End
from ..watch.status_lines import STOP_STATE, Banner
from .runner import (
    EXIT_FAILED,
    EXIT_OK,
    EXIT_USAGE,
    Check,
    ScenarioResult,
    print_results,
    report_console,
)
from .scenario import Scenario, ScenarioError, load

TABLE_WAIT_S = 10.0  # for the answer to the final "?"
EXIT_INTERRUPTED = 130


def add_arguments(ap: argparse.ArgumentParser) -> None:
    g = ap.add_argument_group(msg.RUN_BOARD_HELP)
    g.add_argument("--board", metavar="DEVICE",
                   help="run on the board at this serial port or pty, not the simulation")
    g.add_argument("--baud", type=int, default=115200, metavar="N",
                   help="--board: serial line speed (default 115200)")
    g.add_argument("--log", metavar="FILE", help="--board: the session log with timestamps")
    g.add_argument("--quiet-ms", type=int, default=int(QUIET_S * 1000), metavar="MS",
                   help=f"--board: idle after MS without output (default {int(QUIET_S * 1000)})")
    g.add_argument("--boot-wait", type=float, default=BOOT_WAIT_S, metavar="SECONDS",
                   help=f"--board: wait for the start banner after a reset (default "
                        f"{BOOT_WAIT_S:g})")


@dataclass
class SideRun:
    """One run of a scenario on one side (board or simulation)."""

    end: str
    restarted: bool
    transcript: str
    positions: dict[int, int]
    status_times: dict[int, list[float]]  # seconds from the first command sent
    tests_completed: int
    tests_failed: int
    banner: tuple[int | None, int | None, int | None]
    seconds: float


@dataclass
class TwinStepper:
    scenario: str
    number: int
    board_position: int | None
    sim_position: int | None
    position_diff: int | None
    board_lines: int
    sim_lines: int
    first_dt_s: float | None
    last_dt_s: float | None
    max_dt_s: float | None


@dataclass
class BoardResult:
    result: ScenarioResult
    twin: list[TwinStepper] = field(default_factory=list)


def start_board(session: BoardSession, *, reset: bool) -> bool:
    """Reset (if asked) and wait for the start; a board the open did not restart is
    reset now.  True: its start banner came."""
    if reset:
        session.reset()
    restarted = session.wait_ready()
    if not restarted and not reset:  # the open did not restart it: reset it now
        session.reset()
        restarted = session.wait_ready()
    return restarted


def run_side(session: BoardSession, sc: Scenario, *, reset: bool,
             started: bool | None = None) -> SideRun:
    """Reset (if asked), wait for the start, run the input, ask for the table.
    ``started``: the caller has just started the board (True: with a banner)."""
    restarted = start_board(session, reset=reset) if started is None else started
    st = session.state
    completed, failed = st.tests_completed, st.tests_failed
    st.trace.clear()
    mark = len(session.transcript)
    t0 = session.now()
    end = session.run_script(sc.input, sc.max_time_s)
    seconds = session.now() - t0
    transcript = bytes(session.transcript[mark:]).decode("utf-8", "replace")
    start = session.input_start_s if session.input_start_s is not None else t0
    times = {n: [s.t_s - start for s in tr.samples if s.state != STOP_STATE]
             for n, tr in st.trace.steppers.items()}
    if end == End.IDLE:
        session.run_script("?", TABLE_WAIT_S)
    b = st.banner
    return SideRun(end.value, restarted, transcript, st.positions(), times,
                   st.tests_completed - completed, st.tests_failed - failed,
                   (b.f_cpu, b.ticks_per_s, b.steppers), seconds)


def _letter(number: int) -> str:
    return chr(ord("A") + number - 1)


def checks_of(sc: Scenario, board: SideRun) -> list[Check]:
    p = get_profile(sc.profile)
    checks = [Check("board restarted", True, board.restarted, None, None, board.restarted)]
    want = (p.f_cpu, p.ticks_per_s, p.max_steppers)
    checks.append(Check("board profile", msg.RUN_BOARD_PROFILE.format(
        f_cpu=want[0], ticks=want[1], steppers=want[2]), msg.RUN_BOARD_PROFILE.format(
        f_cpu=board.banner[0], ticks=board.banner[1], steppers=board.banner[2]),
        None, None, board.banner == want))
    if board.end != End.IDLE.value:
        checks.append(Check("end", msg.RUN_BOARD_END["idle"], msg.RUN_BOARD_END[board.end],
                            None, None, False))
    for exp in sc.steppers:
        if "position" not in exp.values:
            continue
        number = ord(exp.letter) - ord("A") + 1
        got = board.positions.get(number)
        tol = exp.tol.get("position", 0)
        dev = None if got is None else got - exp.values["position"]
        checks.append(Check(f"{exp.letter} position", exp.values["position"], got, dev, tol,
                            dev is not None and abs(dev) <= tol))
    if board.tests_completed:
        checks.append(Check("test passed", 0, board.tests_failed, board.tests_failed, 0,
                            board.tests_failed == 0))
    for piece in sc.contains:
        ok = piece in board.transcript
        checks.append(Check("transcript contains", piece, ok, None, None, ok))
    for piece in sc.not_contains:
        ok = piece not in board.transcript
        checks.append(Check("transcript lacks", piece, ok, None, None, ok))
    return checks


def twin_of(sc: Scenario, board: SideRun, sim: SideRun) -> tuple[list[TwinStepper],
                                                                list[Check]]:
    rows, checks = [], []
    tolerances = {ord(e.letter) - ord("A") + 1: e.tol.get("position", 0) for e in sc.steppers}
    for n in sorted(set(board.positions) | set(sim.positions)):
        bp, sp = board.positions.get(n), sim.positions.get(n)
        diff = None if bp is None or sp is None else bp - sp
        bt, stt = board.status_times.get(n, []), sim.status_times.get(n, [])
        pairs = list(zip(bt, stt, strict=False))  # (the counts may differ: both are shown)
        rows.append(TwinStepper(
            sc.name, n, bp, sp, diff, len(bt), len(stt),
            bt[0] - stt[0] if pairs else None, bt[-1] - stt[-1] if pairs else None,
            max(abs(a - b) for a, b in pairs) if pairs else None))
        tol = tolerances.get(n, 0)
        checks.append(Check(f"{_letter(n)} twin position diff", 0, diff, diff, tol,
                            diff is not None and abs(diff) <= tol))
    return rows, checks


def other_chip(sc: Scenario, banner: Banner) -> str | None:
    """Why ``sc`` is not for the board of ``banner`` (its chip differs), or None (the
    same chip, or the banner did not say)."""
    p = get_profile(sc.profile)
    board = (banner.f_cpu, banner.ticks_per_s, banner.steppers)
    if None in board or board == (p.f_cpu, p.ticks_per_s, p.max_steppers):
        return None
    return msg.RUN_BOARD_OTHER_CHIP.format(
        name=sc.name, profile=p.name, f_cpu=p.f_cpu, ticks=p.ticks_per_s,
        steppers=p.max_steppers, board_f_cpu=banner.f_cpu, board_ticks=banner.ticks_per_s,
        board_steppers=banner.steppers)


def run_board_scenario(session: BoardSession, sc: Scenario, *, first: bool,
                       started: bool | None = None) -> BoardResult:
    """``started``: the board was started for this file (see :func:`run_side`)."""
    t0 = time.perf_counter()
    board = run_side(session, sc, reset=not first, started=started)
    sim = run_side(BoardSession(SimBoardLink(sc.profile), quiet_s=session.quiet_s), sc,
                   reset=False)
    res = ScenarioResult(str(sc.path), sc.name, True, end=board.end, sim_s=board.seconds,
                         wall_s=time.perf_counter() - t0, long=sc.long)
    res.checks = checks_of(sc, board)
    rows, twin_checks = twin_of(sc, board, sim)
    res.checks += twin_checks
    res.ok = all(c.ok for c in res.checks)
    return BoardResult(res, rows)


# ---------------------------------------------------------------- output
def _fmt(v: float | int | None, spec: str = "") -> str:
    return msg.BOARD_NONE if v is None else format(v, spec)


def print_twin(rows: list[TwinStepper], console) -> None:
    from rich.table import Table

    table = Table(title=msg.RUN_TWIN_TITLE, caption=msg.RUN_TWIN_CAPTION)
    for i, col in enumerate(msg.RUN_TWIN_COLUMNS):
        table.add_column(col, no_wrap=i == 0)
    for r in rows:
        table.add_row(r.scenario, f"M{r.number}", _fmt(r.board_position), _fmt(r.sim_position),
                      _fmt(r.position_diff, "+d"), f"{r.board_lines}/{r.sim_lines}",
                      _fmt(r.first_dt_s, "+.2f"), _fmt(r.last_dt_s, "+.2f"),
                      _fmt(r.max_dt_s, ".2f"))
    console.print(table)
    diffs = [abs(r.position_diff) for r in rows if r.position_diff is not None]
    dts = [r.max_dt_s for r in rows if r.max_dt_s is not None]
    console.print(msg.RUN_TWIN_SUMMARY.format(steppers=len(rows),
                                              pos=max(diffs) if diffs else msg.BOARD_NONE,
                                              dt=max(dts) if dts else 0.0))


def main(args: argparse.Namespace, files: list[Path], missing: bool) -> int:
    """Run ``files`` on the board of ``args.board`` (after ``runner.main`` parsed them)."""
    from rich.console import Console
    from rich.text import Text

    if args.vcd or args.steps_csv or args.plot or args.timing_report or args.report:
        print(msg.CLI_ERROR.format(problem=msg.RUN_BOARD_NO_WATCH), file=sys.stderr)
        return EXIT_USAGE
    try:
        link: BoardLink = SerialBoardLink(args.board, args.baud)
        log = BoardLog(args.log, args.board, args.baud) if args.log else None
    except (LinkClosed, OSError) as exc:
        print(msg.CLI_BOARD_CONNECT.format(port=args.board, error=exc), file=sys.stderr)
        return EXIT_USAGE
    err = Console(stderr=True)
    session = BoardSession(link, log=log, quiet_s=args.quiet_ms / 1000,
                           boot_wait_s=args.boot_wait, lost_note=msg.BOARD_LOST_RUN,
                           notes=lambda text: err.print(Text(text, "cyan")))
    results: list[BoardResult] = []
    notes: list[str] = []
    skipped = 0
    first = True
    try:
        # the board first: its banner names its chip (files for others are skipped)
        started: bool | None = start_board(session, reset=False)
        for f in files:
            try:
                sc = load(f)
            except ScenarioError as exc:
                results.append(BoardResult(ScenarioResult(str(f), f.stem, False,
                                                          error=str(exc))))
                continue
            if (args.k and args.k not in sc.name) or (args.skip_long and sc.long):
                continue
            why = (f"{sc.name}: " + msg.RUN_BOARD_SKIPPED.format(program=sc.program)
                   if sc.program != "demo" else other_chip(sc, session.state.banner))
            if why is not None:
                notes.append(why)
                skipped += 1
                continue
            if sc.transcript_ref is not None and msg.RUN_BOARD_MATCHES_NOTE not in notes:
                notes.append(msg.RUN_BOARD_MATCHES_NOTE)
            err.print(Text(f"{sc.name}: {sc.input}", "bold"))
            results.append(run_board_scenario(session, sc, first=first, started=started))
            first, started = False, None
            if session.lost is not None:
                break
            silent = session.silent_reason()
            if silent is not None:  # not StepperDemo: the other files would wait as long
                notes.append(msg.RUN_BOARD_NO_ANSWER.format(port=args.board, why=silent))
                break
    except KeyboardInterrupt:
        numbers, _ = session.stop_all()
        session.settle(1.0)
        print(msg.CLI_BOARD_INTERRUPTED.format(steppers=" ".join(f"M{n}" for n in numbers)),
              file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        session.close()
    failed = [r for r in results if not r.result.ok]
    if args.json:
        json.dump([{**asdict(r.result), "twin": [asdict(t) for t in r.twin]} for r in results],
                  sys.stdout, indent=1, default=str)
        sys.stdout.write("\n")
    else:
        out = report_console(Console)
        print_results([r.result for r in results], out, verbose=args.verbose)
        print_twin([t for r in results for t in r.twin], out)
        for text in [msg.RUN_BOARD_PINS_NOTE, *notes]:
            out.print(Text(text, "italic"))
        out.print(msg.RUN_SUMMARY.format(total=len(results), failed=len(failed))
                  + (msg.RUN_SUMMARY_SKIPPED.format(n=skipped) if skipped else ""))
    return EXIT_FAILED if failed or missing else EXIT_OK
