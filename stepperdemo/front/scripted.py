"""A scripted run on virtual time: ``stepperdemo -c LINE`` and a program's file input.

Every front end that runs a program's input to its end and prints the transcript goes
through :func:`run_scripted`: the simulated chip, a device behind ``--port``, a board
behind ``--board``; with the observers of ``--vcd``/``--plot``/``--report``.
"""

from __future__ import annotations

import argparse
import os
import sys

from .. import messages as msg
from ..watch import options as observe_options
from . import serial_cli

EXIT_OK = 0
EXIT_TEST_FAILED = 1
EXIT_USAGE = 2
EXIT_MAX_TIME = 3


def stdin_is_script() -> bool:
    """Standard input is a pipe or a file, not a terminal: its lines are a script, run
    on virtual time as ``-c`` runs its line (``echo "R100 W" | stepperdemo``)."""
    try:
        return not os.isatty(sys.stdin.fileno())
    except (AttributeError, ValueError, OSError):  # no standard input at all
        return False


def read_stdin_script() -> str:
    """All of standard input as text (bytes that are not UTF-8 read as U+FFFD)."""
    raw = getattr(sys.stdin, "buffer", None)  # None: a text stream put in its place
    return raw.read().decode("utf-8", "replace") if raw is not None else sys.stdin.read()


def run_scripted(args: argparse.Namespace, title: str | None = None) -> int:
    from fas.sim import SimBackend

    from ..program import EndReason, make_program

    out = sys.stdout.buffer

    def write(data: bytes) -> None:
        out.write(data.replace(b"\r\n", b"\n") if args.lf else data)

    if args.port:  # issue 7: a device behind a serial port executes the queue commands
        return serial_cli.run_scripted(args, write)
    if getattr(args, "board", None):  # issue 15: a board running the original StepperDemo
        from . import board
        return board.run_scripted(args, write)
    backend = SimBackend(args.arch, build=getattr(args, "build", None))
    if getattr(args, "test_mode_wait", False) and args.program == "demo":  # the demo's w
        args.program_options = {**getattr(args, "program_options", {}), "test_mode_wait": True}
    try:
        app = make_program(args.program, backend, scripted=True, output=write,
                           **getattr(args, "program_options", {}))
    except ValueError as exc:  # the profile cannot host the program
        print(msg.CLI_ERROR.format(problem=exc), file=sys.stderr)
        return EXIT_USAGE
    observers = None
    try:  # watching the run (issue 6): --vcd, --plot, --report, --steps-csv
        if observe_options.wanted(args):
            from ..watch import observe
            observers = observe.from_arguments(backend, args, app.trace_signals())
    except OSError as exc:
        print(msg.CLI_ERROR.format(problem=exc), file=sys.stderr)
        return EXIT_USAGE
    if observers is not None:
        app.watch(observers)
    max_ticks = int(args.max_time * backend.profile.ticks_per_s)
    reason = app.run_script(args.command, firmware_end=args.firmware_end, max_ticks=max_ticks)
    out.flush()
    problem = None
    if observers is not None:  # issue 6: close the files, write the plot, print the report
        lines, problem = observe.finish_arguments(observers, args, app,
                                                  title=title or args.command)
        for line in lines:
            print(line)
        sys.stdout.flush()
    if app.dropped_input():  # the firmware's transcript says nothing of it; the console does
        print(msg.CLI_INPUT_DROPPED.format(n=app.dropped_input()), file=sys.stderr)
    if problem is not None:  # (checked before the run: a disk full, a folder gone)
        print(msg.CLI_ERROR.format(problem=problem), file=sys.stderr)
        return EXIT_USAGE
    if reason == EndReason.MAX_TIME:
        print(msg.CLI_MAX_TIME.format(seconds=args.max_time), file=sys.stderr)
        return EXIT_MAX_TIME
    return app.exit_code()  # EXIT_TEST_FAILED when a test sequence failed
