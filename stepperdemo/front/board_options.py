"""The command-line options of the board console (``--board`` and its companions).

Apart from :mod:`.board` so that ``stepperdemo -c`` builds its parser without loading
the board console (start-up time)."""

from __future__ import annotations

import argparse

from .. import messages as msg

QUIET_S = 0.5  # five status-line periods without a line: the board is quiet
BOOT_WAIT_S = 2.5  # an Arduino's bootloader waits ~1.5 s after a reset before setup()


def add_arguments(ap: argparse.ArgumentParser) -> None:
    g = ap.add_argument_group("a board running the original StepperDemo")
    g.add_argument("--board", metavar="DEVICE",
                   help="talk to a board running StepperDemo at this serial port or pty "
                        "(--baud sets the speed); with -c: run the line on it")
    g.add_argument("--log", metavar="FILE",
                   help="--board: append the session to FILE, one line per command sent "
                        "and line received, with timestamps")
    g.add_argument("--quiet-ms", type=int, default=int(QUIET_S * 1000), metavar="MS",
                   help="--board -c: the board counts as idle once nothing holds it and it "
                        f"printed nothing for MS (default {int(QUIET_S * 1000)})")
    g.add_argument("--boot-wait", type=float, default=BOOT_WAIT_S, metavar="SECONDS",
                   help="--board: after opening the port, wait this long for the start "
                        "banner of a board that restarts when opened (default "
                        f"{BOOT_WAIT_S:g}; 0: do not wait)")


def check_arguments(args: argparse.Namespace) -> str | None:
    if getattr(args, "port", None):
        return msg.CLI_BOARD_AND_PORT
    if getattr(args, "vcd", None) or getattr(args, "steps_csv", None):
        return msg.CLI_BOARD_NO_PINS
    if args.program != "demo":
        return msg.CLI_BOARD_NOT_DEMO.format(program=args.program)
    if args.quiet_ms < 50 or args.boot_wait < 0:
        return msg.CLI_BOARD_TIMES
    return None
