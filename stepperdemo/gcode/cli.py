"""``stepperdemo gcode FILE|-``: a G-code file on virtual time, or the G-code console."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from fas.arch import PROFILES

from .. import messages as msg
from ..front import arg_checks, serial_cli
from ..front.scripted import read_stdin_script, stdin_is_script
from ..watch import observe
from .program import DEFAULT_AXES
from .settings import (
    DEFAULT_ACCELERATION,
    DEFAULT_IDLE_DELAY_MS,
    DEFAULT_MAX_RATE,
    DEFAULT_STEPS_PER_UNIT,
)

EXIT_USAGE = 2

DESCRIPTION = f"""\
A G-code interpreter (Grbl conventions) on FastAccelStepper: G0/G1 straight lines
whose axes start together, stay on the line and arrive together; G4 P<seconds>;
G90/G91; G92/G92.1; M62/M63 P<n> digital output on/off after the motion before it,
M64/M65 at once; M67/M68 E<n> Q<percent> PWM duty (synchronized / at once); M2/M30.
Axes X Y Z A B C are steppers 1..6 of the profile's StepperDemo wiring.  Every line
is answered 'ok' or 'error: <reason>'; after an error the program goes on (Grbl).

With FILE (or '-' for stdin) the program runs on virtual time and ends when every
line is done; without it, standard input if that is a pipe or a file, else an
interactive console.  --port DEVICE runs the queue
commands on a device (see 'stepperdemo device').

Settings ($$ lists them, $N=value or --set '$N=value' changes one):
  $1        step idle delay, ms (255 keeps the drivers on)     default {DEFAULT_IDLE_DELAY_MS}
  $100-105  steps per unit, X Y Z A B C                        default {DEFAULT_STEPS_PER_UNIT:g}
  $110-115  maximum rate, units/min (also the G0 rate)         default {DEFAULT_MAX_RATE:g}
  $120-125  acceleration per axis, units/s^2                   default {DEFAULT_ACCELERATION:g}
  $140-143  PWM frequency of Aout0-3, Hz                       default 5000
  $150-153  pin of Dout0-3, $160-163 pin of Aout0-3            default: profile table
With one step per unit, X/Y/Z are in steps and F in steps per minute.

exit codes: 0 ok, 1 a line was answered with an error, 2 bad arguments,
            3 --max-time reached, 5 device lost"""


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="stepperdemo gcode", description=DESCRIPTION,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("file", nargs="?", metavar="FILE|-",
                    help="G-code to run on virtual time ('-': standard input); "
                         "none: a pipe or file on stdin, else the interactive console")
    ap.add_argument("--arch", default="atmega328p", choices=sorted(PROFILES),
                    help="architecture profile (default: atmega328p)")
    ap.add_argument("--axes", type=int, default=DEFAULT_AXES, metavar="N",
                    help=f"number of axes, X Y Z A B C (default {DEFAULT_AXES}, at most the "
                         "profile's steppers)")
    ap.add_argument("--set", action="append", default=[], metavar="'$N=VALUE'",
                    help="a setting before the program starts (repeatable)")
    ap.add_argument("--max-time", type=float, default=3600.0, metavar="SECONDS",
                    help="give up a file after this much simulated time (default 3600 s)")
    ap.add_argument("--lf", action="store_true",
                    help="print LF line ends instead of Grbl's CR LF")
    ap.add_argument("--speed", type=float, default=1.0, metavar="FACTOR",
                    help="interactive: run the simulated clock FACTOR times real time")
    ap.add_argument("--history", metavar="FILE",
                    help="interactive: history file (default: in the user state directory)")
    observe.add_arguments(ap)
    serial_cli.add_arguments(ap)
    return ap


def main(argv: Sequence[str]) -> int:
    args = build_parser().parse_args(list(argv))
    if args.file is None and stdin_is_script():  # a pipe or a file: as '-'
        args.file = "-"
    problem = arg_checks.number_problem(args)  # --max-time, --speed: finite, in range
    if problem is None and args.axes < 1:
        problem = "--axes must be at least 1"
    elif problem is None:
        for text in args.set:
            if not text.strip().startswith("$") or "=" not in text:
                problem = msg.GCODE_CLI_BAD_SET.format(text=text)
                break
    if problem is None:
        args.command = "" if args.file else None
        problem = observe.check_arguments(args)
    if problem is not None:
        print(msg.CLI_ERROR.format(problem=problem), file=sys.stderr)
        return EXIT_USAGE
    args.program = "gcode"
    args.program_options = {"axes": args.axes, "setup_lines": list(args.set)}
    args.firmware_end = False
    if args.file is None:
        from ..front.console import run_console
        return run_console(args)
    try:
        if args.file == "-":
            text = read_stdin_script()
        else:
            with open(args.file, encoding="utf-8", errors="replace") as f:
                text = f.read()
    except OSError as exc:
        print(msg.CLI_ERROR.format(problem=f"{args.file}: {exc.strerror or exc}"),
              file=sys.stderr)
        return EXIT_USAGE
    args.command = text
    from ..front.scripted import run_scripted
    return run_scripted(args, title=args.file)
