"""Command line entry point: ``stepperdemo`` (REPL), ``stepperdemo -c LINE``, subcommands."""

from __future__ import annotations

import argparse
import sys
from typing import Sequence

from fas.arch import PROFILES

from . import messages as msg

EXIT_OK = 0
EXIT_TEST_FAILED = 1
EXIT_USAGE = 2
EXIT_MAX_TIME = 3
EXIT_SCENARIO_FAILED = 4

SUBCOMMANDS = ("run", "device", "relay")

DESCRIPTION = """\
The StepperDemo console of FastAccelStepper on a simulated microcontroller.

Without arguments: an interactive console (prompt-toolkit) running the simulated
chip in real time.  With -c: run one line of StepperDemo commands on virtual time
and print the transcript as the firmware would.

Subcommands:
  stepperdemo run FILES|FOLDERS ...   run scenario files (sequences/*.toml)

exit codes: 0 ok, 1 a test sequence failed, 2 bad arguments,
            3 --max-time reached, 4 a scenario failed (run)"""


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="stepperdemo", description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("-c", "--command", metavar="LINE",
                    help="run LINE on virtual time, print the transcript, exit when the "
                         "input is consumed and every stepper is idle")
    ap.add_argument("--arch", default="atmega328p", choices=sorted(PROFILES),
                    help="architecture profile (default: atmega328p)")
    ap.add_argument("--max-time", type=float, default=3600.0, metavar="SECONDS",
                    help="give up a scripted run after this much simulated time "
                         "(default 3600 s; a W on a stepper that never stops ends here)")
    ap.add_argument("--firmware-end", action="store_true",
                    help="end like the firmware's built-in-input mode: one second after "
                         "the last input character was taken")
    ap.add_argument("--lf", action="store_true",
                    help="print LF line ends instead of the firmware's CR LF")
    ap.add_argument("--speed", type=float, default=1.0, metavar="FACTOR",
                    help="interactive: run the simulated clock FACTOR times real time")
    ap.add_argument("--history", metavar="FILE",
                    help="interactive: history file (default: in the user state directory)")
    return ap


def run_scripted(args: argparse.Namespace) -> int:
    from fas.sim import SimBackend

    from .app import EndReason, StepperDemo

    out = sys.stdout.buffer

    def write(data: bytes) -> None:
        out.write(data.replace(b"\r\n", b"\n") if args.lf else data)

    backend = SimBackend(args.arch)
    app = StepperDemo(backend, scripted=True, output=write)
    max_ticks = int(args.max_time * backend.profile.ticks_per_s)
    reason = app.run_script(args.command, firmware_end=args.firmware_end, max_ticks=max_ticks)
    out.flush()
    if reason == EndReason.MAX_TIME:
        print(msg.CLI_MAX_TIME.format(seconds=args.max_time), file=sys.stderr)
        return EXIT_MAX_TIME
    if app.test_failed_count:
        return EXIT_TEST_FAILED
    return EXIT_OK


def main(argv: Sequence[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and argv[0] in SUBCOMMANDS:
        if argv[0] == "run":
            from .runner import main as run_main
            return run_main(argv[1:])
        print(msg.CLI_ERROR.format(problem=f"{argv[0]}: not available in this version"),
              file=sys.stderr)
        return EXIT_USAGE
    args = build_parser().parse_args(argv)
    if args.max_time <= 0:
        print(msg.CLI_ERROR.format(problem="--max-time must be positive"), file=sys.stderr)
        return EXIT_USAGE
    if args.command is not None:
        return run_scripted(args)
    from .console import run_console
    return run_console(args)


def entry() -> None:  # pragma: no cover - console script
    sys.exit(main())


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
