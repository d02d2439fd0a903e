"""Command line entry point: ``stepperdemo`` (REPL), ``stepperdemo -c LINE``, subcommands."""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
from typing import Sequence

from fas.arch import PROFILES
from fas.sim.builds import BUILDS

from .. import messages as msg
from ..subcommands import SUBCOMMANDS, help_lines, main_of
from ..watch import options as observe_options
from . import arg_checks, board_options, serial_cli
from .scripted import (  # noqa: F401 (the exit codes are re-exported)
    EXIT_MAX_TIME,
    EXIT_OK,
    EXIT_TEST_FAILED,
    EXIT_USAGE,
    read_stdin_script,
    run_scripted,
    stdin_is_script,
)

EXIT_SCENARIO_FAILED = 4
EXIT_CLOSED_PIPE = 141  # 128 + SIGPIPE: what a shell reports for a tool whose reader left

DESCRIPTION_HEAD = """\
The StepperDemo console of FastAccelStepper on a simulated microcontroller.

Without arguments: an interactive console (prompt-toolkit) running the simulated
chip in real time.  With -c: run one line of StepperDemo commands on virtual time
and print the transcript as the firmware would.  A pipe or a file on standard input
(echo "R100 W" | stepperdemo) is run the same way, all its lines as one script.

With --port DEVICE: the same, the queue commands executed by a device behind a
serial port or pty (real time; see docs/serial-protocol.md).

With --board DEVICE: the same console in front of a board running the original
StepperDemo sketch (its text console over the serial port); -c runs the line on
the board and ends when the board is idle.

Subcommands:
"""
DESCRIPTION_TAIL = """

exit codes: 0 ok, 1 a test sequence failed, 2 bad arguments,
            3 --max-time reached, 4 a scenario failed (run), 5 device lost
            (--board: the board was lost or restarted, or no StepperDemo
            answer came within 3 s), 130 interrupted,
            141 the reader of the output went away (e.g. `| head`), quietly"""


def description() -> str:
    """``stepperdemo --help``: the subcommands as the registry lists them."""
    return DESCRIPTION_HEAD + "\n".join(help_lines()) + DESCRIPTION_TAIL


def build_parser(program: str = "demo") -> argparse.ArgumentParser:
    prog, text = "stepperdemo", description()
    if program != "demo":  # a program's own subcommand and --help text
        from ..program import program_factory
        prog = f"stepperdemo {program}"
        text = getattr(program_factory(program), "cli_description", text)
    ap = argparse.ArgumentParser(
        prog=prog, description=text,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("-c", "--command", metavar="LINE",
                    help="run LINE on virtual time, print the transcript, exit when the "
                         "input is consumed and every stepper is idle")
    ap.add_argument("--arch", default="atmega328p", choices=sorted(PROFILES),
                    metavar="ARCH",
                    help="architecture profile (default: atmega328p): " + ", ".join(PROFILES)
                    + " (ESP32 chips without a suffix: the oldest ESP-IDF upstream builds "
                    "them with; _idf5/_idf6: ESP-IDF 5.3 / 6)")
    ap.add_argument("--build", default=None, choices=sorted(BUILDS), metavar="BUILD",
                    help="the firmware build whose CPU costs the simulated chip runs "
                         "(default: d): " + "; ".join(f"{k}: {v}" for k, v in BUILDS.items()))
    ap.add_argument("--max-time", type=float, default=3600.0, metavar="SECONDS",
                    help="give up a scripted run after this much simulated time "
                         "(default 3600 s; a W on a stepper that never stops ends here)")
    demo = program == "demo"  # StepperDemo's own options: its firmware's end, test mode
    if demo:
        ap.add_argument("--firmware-end", action="store_true",
                        help="end like the firmware's built-in-input mode: one second after "
                             "the last input character was taken")
    ap.add_argument("--lf", action="store_true",
                    help="print LF line ends instead of the firmware's CR LF")
    if demo:
        ap.add_argument("--test-mode-wait", action="store_true",
                        help="extension: accept w<ms> in test mode too (the firmware answers "
                             "'Unknown command' there), to let endless test sequences run "
                             "for a while in a -c line")
    ap.add_argument("--pin-config", type=int, default=None, metavar="N",
                    help=msg.PIN_CONFIG_HELP)
    ap.add_argument("--speed", type=float, default=1.0, metavar="FACTOR",
                    help="interactive: run the simulated clock FACTOR times real time")
    ap.add_argument("--history", metavar="FILE",
                    help="interactive: history file (default: in the user state directory)")
    observe_options.add_arguments(ap)  # --vcd --plot --plot-size --report --steps-csv (issue 6)
    serial_cli.add_arguments(ap)  # --port --baud --watchdog-ms (issue 7)
    if demo:  # a board running StepperDemo
        board_options.add_arguments(ap)  # --board --log --quiet-ms --boot-wait (issue 15)
    ap.set_defaults(program=program, firmware_end=False, test_mode_wait=False)
    return ap


def main(argv: Sequence[str] | None = None) -> int:
    """The ``stepperdemo`` command; a closed output pipe ends it quietly (issue 16)."""
    try:
        return _main(argv)
    except BrokenPipeError:
        return closed_pipe()


def closed_pipe() -> int:
    """The reader of our output went away (``| head``): stop without a traceback, as
    Unix tools do.  Standard output (and standard error, if it is the same pipe) is
    pointed at /dev/null so that the interpreter's last flush finds nothing to fail."""
    try:
        same = os.path.samestat(os.fstat(sys.stdout.fileno()), os.fstat(sys.stderr.fileno()))
    except (OSError, ValueError):
        same = False
    devnull = os.open(os.devnull, os.O_WRONLY)
    for stream, wanted in ((sys.stdout, True), (sys.stderr, same)):
        if wanted:
            with contextlib.suppress(OSError, ValueError):
                os.dup2(devnull, stream.fileno())
    os.close(devnull)
    return EXIT_CLOSED_PIPE


def _main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    program = "demo"
    if argv and argv[0] in SUBCOMMANDS:  # stepperdemo NAME ... (stepperdemo.subcommands)
        main_fn = main_of(argv[0])
        if main_fn is not None:  # a tool with its own command line
            return main_fn(argv[1:])
        program, argv = argv[0], argv[1:]  # a program hosted with the console's options
    args = build_parser(program).parse_args(argv)
    if args.command is None and stdin_is_script():  # a pipe or a file: a script, as -c
        args.command = read_stdin_script()
    problem = (arg_checks.number_problem(args)  # --max-time, --speed: finite, in range
               or observe_options.check_arguments(args))  # e.g. --plot without matplotlib
    if problem is not None:
        print(msg.CLI_ERROR.format(problem=problem), file=sys.stderr)
        return EXIT_USAGE
    problem = _pin_config(args)
    if problem is not None:
        print(msg.CLI_ERROR.format(problem=problem), file=sys.stderr)
        return EXIT_USAGE
    if args.command is not None:
        return run_scripted(args)
    if getattr(args, "board", None):  # issue 15
        from . import board
        return board.run_console(args)
    from .console import run_console
    return run_console(args)


def _pin_config(args: argparse.Namespace) -> str | None:
    """``--pin-config N``: StepperDemo answers its start-up prompt with N (issue 23)."""
    if args.pin_config is None:
        return None
    if args.program != "demo":
        return msg.PIN_CONFIG_PROGRAM.format(program=args.program)
    from ..demo.build import pin_config_problem

    problem = pin_config_problem(PROFILES[args.arch], args.pin_config)
    if problem is None:
        args.program_options = {**getattr(args, "program_options", {}),
                                "pin_config": args.pin_config}
    return problem


def entry() -> None:  # pragma: no cover - console script
    sys.exit(main())


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
