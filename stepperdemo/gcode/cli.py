"""``stepperdemo gcode FILE|-``: a G-code file on virtual time, or the G-code console."""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence

from fas.arch import PROFILES

from .. import messages as msg
from ..front import arg_checks, serial_cli
from ..front.scripted import read_stdin_script, stdin_is_script
from ..watch import observe
from .program import DEFAULT_AXES
from .reports import axis_values
from .settings import (
    DEFAULT_ACCELERATION,
    DEFAULT_IDLE_DELAY_MS,
    DEFAULT_MAX_RATE,
    DEFAULT_STEPS_PER_UNIT,
)

EXIT_USAGE = 2

DESCRIPTION = f"""\
A Grbl 1.1 controller on FastAccelStepper, for G-code senders and by hand: G0/G1
straight lines whose axes start together, stay on the line and arrive together;
G2/G3 arcs (I/J/K or R, planes G17/G18/G19, segments within $12); G20/G21;
G54-G59, G10 L2/L20, G92/G92.1, G43.1/G49, G53, G28/G30 (.1); G4 P<seconds>;
G90/G91; M3/M4/M5 S spindle or laser ($32=1: Grbl's laser mode) and M7/M8/M9
coolant on the user outputs the profile maps (docs/gcode.md); T, M6;
M62/M63 P<n> digital output on/off after the motion before it, M64/M65 at once;
M67/M68 E<n> Q<percent> PWM duty (synchronized / at once); M0 M2 M30.
A synchronized output or a dwell holds the parser (Grbl_ESP32).
Axes X Y Z A B C are steppers 1..6 of the profile's StepperDemo wiring.  Every line
is answered 'ok' or 'error:N' (Grbl's numbers; the reason in a [MSG:...] line
before it); after an error the program goes on (Grbl).  Real-time bytes act
wherever they arrive: ? status, ! feed hold, ~ resume, Ctrl-X reset, 0x85 jog
cancel, 0x90-0x9D overrides; $J= jogs; $ lists the $ commands.

With FILE (or '-' for stdin) the program runs on virtual time and ends when every
line is done; without it, standard input if that is a pipe or a file, else an
interactive console (Ctrl-X resets).  --pty or --tcp serve it to senders (bCNC,
cncjs, UGS, LaserGRBL, pygrbl-streamer) in real time, a host opening the port resets
it; see docs/gcode.md.  --port DEVICE runs the queue
commands on a device (see 'stepperdemo device').

Settings ($$ lists them, $N=value or --set '$N=value' changes one):
  $1        step idle delay, ms (255 keeps the drivers on)     default {DEFAULT_IDLE_DELAY_MS}
  $10       status report: 1 MPos (else WPos) + 2 Bf:          default 3
  $11       junction deviation, units (look-ahead corners)      default 0.01
  $12       arc tolerance, units                               default 0.002
  $30 $31   spindle speed S of full / of the least PWM duty    default 1000 0
  $32       laser mode (M4 power follows the speed)            default 0
  $100-105  steps per unit, X Y Z A B C                        default {DEFAULT_STEPS_PER_UNIT:g}
  $110-115  maximum rate, units/min (also the G0 rate)         default {DEFAULT_MAX_RATE:g}
  $120-125  acceleration per axis, units/s^2                   default {DEFAULT_ACCELERATION:g}
  $140-143  PWM frequency of Aout0-3, Hz                       default 5000
  $150-153  pin of Dout0-3, $160-163 pin of Aout0-3            default: profile table
  $170      status report shows Dout:/Aout:                    default 0
  $171      motion: 0 look-ahead, 1 stop at every block        default 0
  $172      corners: 0 Grbl's junctions, 1 corner blends       default 0
  $173      with $172=1: corners within this many steps of     default 0
            their blend taken as Grbl's (0 .. 0.125)
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
                    help="interactive, --pty, --tcp: run the simulated clock FACTOR times "
                         "real time")
    where = ap.add_mutually_exclusive_group()
    where.add_argument("--pty", action="store_true",
                       help="serve G-code senders on a new pty (its path on the first line)")
    where.add_argument("--tcp", metavar="[HOST:]PORT",
                       help="serve G-code senders on a TCP port (loopback unless HOST is "
                            "given; port 0: any free one, printed on the first line)")
    ap.add_argument("--link", metavar="PATH",
                    help="--pty: also make PATH a symbolic link to the pty (a stable name)")
    ap.add_argument("--quiet", action="store_true",
                    help="--pty/--tcp: print only the path (pty path or tcp://HOST:PORT)")
    ap.add_argument("--history", metavar="FILE",
                    help="interactive: history file (default: in the user state directory)")
    observe.add_arguments(ap)
    serial_cli.add_arguments(ap)
    return ap


def main(argv: Sequence[str]) -> int:
    args = build_parser().parse_args(list(argv))
    serving = args.pty or args.tcp  # an endpoint reads its host, never stdin
    if args.file is None and not serving and stdin_is_script():  # a pipe or a file: '-'
        args.file = "-"
    problem = arg_checks.number_problem(args)  # --max-time, --speed: finite, in range
    if problem is None and args.pty:
        problem = arg_checks.link_problem(args.link)
    if problem is None and args.axes < 1:
        problem = "--axes must be at least 1"
    elif problem is None and (args.pty or args.tcp) and args.file:
        problem = msg.GCODE_CLI_ENDPOINT_FILE
    elif problem is None:
        for text in args.set:
            if not text.strip().startswith("$") or "=" not in text:
                problem = msg.GCODE_CLI_BAD_SET.format(text=text)
                break
    if problem is None:
        args.command = "" if args.file or args.pty or args.tcp else None
        problem = observe.check_arguments(args)
    if problem is not None:
        print(msg.CLI_ERROR.format(problem=problem), file=sys.stderr)
        return EXIT_USAGE
    args.program = "gcode"
    args.program_options = {"axes": args.axes, "setup_lines": list(args.set)}
    args.firmware_end = False
    if args.pty or args.tcp:
        return run_endpoint(args)
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
    toml = scenario_program(args.file, text)
    if toml is not None:
        print(msg.CLI_ERROR.format(problem=toml), file=sys.stderr)
        return EXIT_USAGE
    args.command = text
    from ..front.scripted import run_scripted
    return run_scripted(args, title=args.file)


def scenario_program(path: str, text: str) -> str | None:
    """A scenario file given as G-code (issue 26): the problem to say, else None."""
    if not path.endswith(".toml"):
        return None
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # Python 3.10: tomli (a dependency there, pyproject.toml)
        import tomli as tomllib

    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError:
        return None
    if not isinstance(data, dict) or "input" not in data and "input_file" not in data:
        return None
    program = ""
    if isinstance(data.get("input_file"), str):
        program = msg.GCODE_CLI_TOML_PROGRAM.format(
            file=os.path.join(os.path.dirname(path), data["input_file"]))
    return msg.GCODE_CLI_TOML.format(path=path, program=program)


def run_endpoint(args: argparse.Namespace) -> int:
    """``stepperdemo gcode --pty|--tcp``: serve senders until Ctrl-C."""
    from fas.serial.stream import remove_link, set_link

    from ..front.serial_cli import StopOnSignal
    from ..program import make_program
    from .endpoint import Endpoint, PtyPort, TcpPort, parse_tcp

    backend = None
    if args.port:
        from fas.serial import SerialError
        try:
            backend = serial_cli.open_backend(args.port, args.baud, args.watchdog_ms,
                                              getattr(args, "link_planning_ms", None))
        except SerialError as exc:
            print(msg.CLI_SERIAL_CONNECT.format(port=args.port, error=exc), file=sys.stderr)
            return EXIT_USAGE
    else:
        from fas.sim import SimBackend
        backend = SimBackend(args.arch)
    try:
        port = PtyPort() if args.pty else TcpPort(*parse_tcp(args.tcp))
    except (ValueError, OSError) as exc:
        print(msg.CLI_ERROR.format(problem=exc), file=sys.stderr)
        return EXIT_USAGE
    app = make_program("gcode", backend, scripted=False, **args.program_options)
    observers = None
    if not args.port and observe.wanted(args):
        try:
            observers = observe.from_arguments(backend, args, app.trace_signals())
        except OSError as exc:
            print(msg.CLI_ERROR.format(problem=exc), file=sys.stderr)
            port.close()
            return EXIT_USAGE
        app.watch(observers)
    if args.pty:
        set_link(args.link, port.path)
    events = None if args.quiet else (
        lambda text: print(msg.GCODE_ENDPOINT_EVENT.format(event=text), flush=True))
    endpoint = Endpoint(app, port, args.speed, device_clock=bool(args.port), events=events)
    p = backend.profile
    link = f" ({args.link})" if args.link and args.pty else ""
    if args.quiet:
        print(port.path, flush=True)
    elif args.port:
        print(msg.GCODE_ENDPOINT_DEVICE.format(path=port.path, link=link, port=args.port,
                                               profile=p.name, axes=app.axes), flush=True)
    else:
        print(msg.GCODE_ENDPOINT_LISTENING.format(path=port.path, link=link, profile=p.name,
                                                  title=p.title, axes=app.axes,
                                                  speed=args.speed), flush=True)
    stop = StopOnSignal()
    try:
        endpoint.serve(stop)
    finally:
        if args.pty:
            remove_link(args.link, port.path)
        port.close()
        if args.port:
            backend.close()
    m = app.machine
    if not args.quiet:
        print(msg.GCODE_ENDPOINT_STATS.format(
            hosts=endpoint.hosts, lines=m.lines, errors=m.errors, alarms=m.alarms,
            rx=endpoint.rx_bytes, dropped=m.rx.dropped, high=m.rx.dropped_high,
            tx=endpoint.tx_bytes, tx_dropped=endpoint.tx_dropped,
            lag=endpoint.lagged / backend.profile.ticks_per_s))
        print(msg.GCODE_ENDPOINT_POSITIONS.format(
            mpos=axis_values(m.machine_position()), state=m.state_name()))
    problem = None
    if observers is not None:
        lines, problem = observe.finish_arguments(observers, args, app, title="gcode endpoint")
        for line in lines:
            print(line)
    sys.stdout.flush()
    if problem is not None:  # checked before serving: a folder gone, a disk full since
        print(msg.CLI_ERROR.format(problem=problem), file=sys.stderr)
        return EXIT_USAGE
    return 0
