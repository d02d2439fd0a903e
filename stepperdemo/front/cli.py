"""Command line entry point: ``stepperdemo`` (REPL), ``stepperdemo -c LINE``, subcommands."""

from __future__ import annotations

import argparse
import os
import sys
from typing import Sequence

from fas.arch import PROFILES

from .. import messages as msg
from ..watch import options as observe_options
from . import board_options, serial_cli

EXIT_OK = 0
EXIT_TEST_FAILED = 1
EXIT_USAGE = 2
EXIT_MAX_TIME = 3
EXIT_SCENARIO_FAILED = 4
EXIT_CLOSED_PIPE = 141  # 128 + SIGPIPE: what a shell reports for a tool whose reader left

SUBCOMMANDS = ("run", "device", "relay", "gcode")
PROGRAM_SUBCOMMANDS = ("winder",)  # programs beside StepperDemo: stepperdemo winder ...

DESCRIPTION = """\
The StepperDemo console of FastAccelStepper on a simulated microcontroller.

Without arguments: an interactive console (prompt-toolkit) running the simulated
chip in real time.  With -c: run one line of StepperDemo commands on virtual time
and print the transcript as the firmware would.

With --port DEVICE: the same, the queue commands executed by a device behind a
serial port or pty (real time; see docs/serial-protocol.md).

With --board DEVICE: the same console in front of a board running the original
StepperDemo sketch (its text console over the serial port); -c runs the line on
the board and ends when the board is idle.

Subcommands:
  stepperdemo winder [options]        the helix winder (seed 002): --help
  stepperdemo run FILES|FOLDERS ...   run scenario files (sequences/*.toml);
                                      --board DEVICE: on a board, with the twin check
  stepperdemo device --pty            a simulated device on a new pty (--help);
                                      --console: the simulated StepperDemo firmware
  stepperdemo relay DEVICE            a fault-injecting relay to a device (--help)
  stepperdemo gcode FILE|-            run G-code (user outputs M62-M68; --help)

exit codes: 0 ok, 1 a test sequence failed, 2 bad arguments,
            3 --max-time reached, 4 a scenario failed (run), 5 device lost
            (--board: the board was lost or restarted), 130 interrupted,
            141 the reader of the output went away (e.g. `| head`), quietly"""


def build_parser(program: str = "demo") -> argparse.ArgumentParser:
    prog, description = "stepperdemo", DESCRIPTION
    if program != "demo":  # a program's own subcommand and --help text
        from ..program import program_factory
        prog = f"stepperdemo {program}"
        description = getattr(program_factory(program), "cli_description", DESCRIPTION)
    ap = argparse.ArgumentParser(
        prog=prog, description=description,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("-c", "--command", metavar="LINE",
                    help="run LINE on virtual time, print the transcript, exit when the "
                         "input is consumed and every stepper is idle")
    ap.add_argument("--arch", default="atmega328p", choices=sorted(PROFILES),
                    metavar="ARCH",
                    help="architecture profile (default: atmega328p): " + ", ".join(PROFILES)
                    + " (ESP32 chips without a suffix: the oldest ESP-IDF upstream builds "
                    "them with; _idf5/_idf6: ESP-IDF 5.3 / 6)")
    ap.add_argument("--max-time", type=float, default=3600.0, metavar="SECONDS",
                    help="give up a scripted run after this much simulated time "
                         "(default 3600 s; a W on a stepper that never stops ends here)")
    ap.add_argument("--firmware-end", action="store_true",
                    help="end like the firmware's built-in-input mode: one second after "
                         "the last input character was taken")
    ap.add_argument("--lf", action="store_true",
                    help="print LF line ends instead of the firmware's CR LF")
    ap.add_argument("--test-mode-wait", action="store_true",
                    help="extension: accept w<ms> in test mode too (the firmware answers "
                         "'Unknown command' there), to let endless test sequences run "
                         "for a while in a -c line")
    ap.add_argument("--speed", type=float, default=1.0, metavar="FACTOR",
                    help="interactive: run the simulated clock FACTOR times real time")
    ap.add_argument("--history", metavar="FILE",
                    help="interactive: history file (default: in the user state directory)")
    observe_options.add_arguments(ap)  # --vcd --plot --plot-size --report --steps-csv (issue 6)
    serial_cli.add_arguments(ap)  # --port --baud --watchdog-ms (issue 7)
    board_options.add_arguments(ap)  # --board --log --quiet-ms --boot-wait (issue 15)
    ap.set_defaults(program=program)
    return ap


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
    backend = SimBackend(args.arch)
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
    if observers is not None:  # issue 6: close the files, write the plot, print the report
        for line in observe.finish_arguments(observers, args, app,
                                             title=(title or args.command)[:100]):
            print(line)
        sys.stdout.flush()
    if reason == EndReason.MAX_TIME:
        print(msg.CLI_MAX_TIME.format(seconds=args.max_time), file=sys.stderr)
        return EXIT_MAX_TIME
    return app.exit_code()  # EXIT_TEST_FAILED when a test sequence failed


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
            try:
                os.dup2(devnull, stream.fileno())
            except (OSError, ValueError):
                pass
    os.close(devnull)
    return EXIT_CLOSED_PIPE


def _main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] in SUBCOMMANDS:
        if argv[0] == "run":
            from ..scenarios.runner import main as run_main
            return run_main(argv[1:])
        if argv[0] in ("device", "relay"):  # issue 7
            return serial_cli.main(argv)
        if argv[0] == "gcode":  # issue 12
            from ..gcode.cli import main as gcode_main
            return gcode_main(argv[1:])
        print(msg.CLI_ERROR.format(problem=f"{argv[0]}: not available in this version"),
              file=sys.stderr)
        return EXIT_USAGE
    if argv and argv[0] in PROGRAM_SUBCOMMANDS:
        args = build_parser(argv[0]).parse_args(argv[1:])
    else:
        args = build_parser().parse_args(argv)
    if args.max_time <= 0:
        print(msg.CLI_ERROR.format(problem="--max-time must be positive"), file=sys.stderr)
        return EXIT_USAGE
    problem = observe_options.check_arguments(args)  # issue 6: e.g. --plot without matplotlib
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


def entry() -> None:  # pragma: no cover - console script
    sys.exit(main())


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
