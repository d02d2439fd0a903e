"""The console's serial side: ``--port``, ``stepperdemo device``, ``stepperdemo relay``.

* ``stepperdemo --port DEVICE [-c LINE]`` runs StepperDemo on this computer with the
  serial backend (:mod:`fas.serial`): the device executes the queue commands.
* ``stepperdemo device --pty`` is a device on the simulated machine, serving a new
  pseudo-terminal in real time (prints its path).
* ``stepperdemo relay DEVICE`` sits between a host and a device and injects faults.

Also the console's meta commands for a serial session (``/reconnect``, ``/link``,
``/estop``) and the statistics lines.  Every text is in :mod:`.messages`.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterable, Sequence

from fas.arch import PROFILES

from .. import messages as msg

EXIT_USAGE = 2
EXIT_LINK_LOST = 5

META_COMMANDS = {
    "/reconnect": "serial: open the device again (optionally another port)",
    "/link": "serial: link and device statistics",
    "/estop": "serial: emergency stop on the device",
}


# ------------------------------------------------------------------- host side
def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--port", metavar="DEVICE",
                    help="run on a device behind this serial port or pty (see "
                         "'stepperdemo device'); the device decides the profile")
    ap.add_argument("--baud", type=int, default=115200, metavar="N",
                    help="serial line speed of the device or board (default 115200)")
    ap.add_argument("--watchdog-ms", type=int, default=500, metavar="MS",
                    help="--port: the device stops all motion after MS of host silence")
    ap.add_argument("--link-planning-ms", type=_planning_ms, default=None, metavar="MS",
                    help="--port: plan MS beyond the library's forward-planning time "
                         "(default: derived from the measured round trip and losses "
                         "plus 50 ms for host stalls)")


def _planning_ms(text: str) -> int:
    try:
        ms = int(text)
    except ValueError:
        ms = -1
    if not 0 <= ms <= 10_000:
        raise argparse.ArgumentTypeError(msg.SERIAL_BAD_PLANNING.format(ms=text))
    return ms


def open_backend(port: str, baud: int = 115200, watchdog_ms: int = 500,
                 link_planning_ms: int | None = None):
    """A connected :class:`fas.serial.SerialBackend` (raises ``SerialError``)."""
    from fas.serial import SerialBackend

    return SerialBackend(port, baud=baud, watchdog_ms=watchdog_ms,
                         link_planning_ms=link_planning_ms)


def planning_line(backend) -> str:
    """How far ahead the host plans for this link, and why."""
    hz = backend.clock_hz
    link = backend.link
    return msg.SERIAL_PLANNING.format(
        extra_ms=backend.planning_extra_ticks * 1000 // hz,
        how=("set" if backend.link_planning_ms is not None else "measured"),
        rtt_ms=backend.round_trip_ticks() * 1000 / hz,
        rounds=backend.retry_rounds(), loss_pct=100 * (link.loss if link else 0.0),
        queue_len=backend.profile.queue_len,
        window=link.window if link else 0, payload=link.max_payload if link else 0)


def stats_lines(backend) -> list[str]:
    """Link statistics, device counters and per-stepper figures, one line each.  Without
    a device (lost) its figures are those of its last report: said so."""
    lines = [msg.SERIAL_LINK_STATS.format(**backend.link_stats())]
    if backend.connected:
        lines.append(planning_line(backend))
    counters = backend.device_counters()
    if not backend.connected and (counters or backend.statuses):
        lines.append(msg.SERIAL_LAST_REPORT)
    if counters:
        lines.append(msg.SERIAL_DEVICE_STATS.format(**counters))
        lines.append(msg.SERIAL_DEVICE_REPAIRS.format(**counters))
    for idx in sorted(backend.statuses):
        st = backend.statuses[idx]
        lines.append(msg.SERIAL_STEPPER_STATS.format(n=idx + 1, position=st.position,
                                                     pulses=st.pulses,
                                                     underruns=st.underruns))
    return lines


def run_scripted(args: argparse.Namespace, write) -> int:
    """``stepperdemo --port DEVICE -c LINE``: the line in real time on the device."""
    from fas.serial import SerialError

    from ..program import EndReason, make_program
    from ..watch import observe

    if observe.wanted(args):
        print(msg.CLI_ERROR.format(problem=msg.SERIAL_NO_OBSERVE), file=sys.stderr)
        return EXIT_USAGE
    try:
        backend = open_backend(args.port, args.baud, args.watchdog_ms,
                               getattr(args, "link_planning_ms", None))
    except SerialError as exc:
        print(msg.CLI_SERIAL_CONNECT.format(port=args.port, error=exc), file=sys.stderr)
        return EXIT_USAGE
    try:
        app = make_program(args.program, backend, scripted=True, output=write,
                           **getattr(args, "program_options", {}))
    except ValueError as exc:  # the profile cannot host the program
        print(msg.CLI_ERROR.format(problem=exc), file=sys.stderr)
        backend.close()
        return EXIT_USAGE
    max_ticks = int(args.max_time * backend.profile.ticks_per_s)

    def on_event(event: str, text: str) -> None:
        if event == "lost":  # a script cannot go on without its device
            raise _DeviceLost(text)

    backend.listeners.append(on_event)
    reason = None
    try:
        reason = app.run_script(args.command, firmware_end=args.firmware_end,
                                max_ticks=max_ticks)
    except _DeviceLost:
        pass
    except KeyboardInterrupt:
        backend.emergency_stop()
        raise
    finally:
        sys.stdout.flush()
        backend.listeners.remove(on_event)
    code = finish_scripted(backend)
    if code:
        return code
    if reason == EndReason.MAX_TIME:
        print(msg.CLI_MAX_TIME.format(seconds=args.max_time), file=sys.stderr)
        return 3
    return app.exit_code()


class _DeviceLost(Exception):
    pass


def finish_scripted(backend, out=sys.stderr) -> int:
    """After ``-c`` on a device: wait for it, print the statistics, end the session."""
    lost = backend.lost_reason
    if backend.connected:
        backend.settle()
        backend.request_status()
    for line in stats_lines(backend):
        print(line, file=out)
    if lost or not backend.connected:
        print(msg.CLI_SERIAL_LOST.format(reason=lost or backend.lost_reason), file=out)
        backend.close()
        return EXIT_LINK_LOST
    backend.close()
    return 0


# ------------------------------------------------------------ console (REPL)
class DeviceDriver:
    """The console's driver on a device: host time runs by itself (it is the device's).

    The simulator's driver runs the program up to the wall clock; here the clock does
    not wait for the program, so each call serves the link, runs the ramp tasks that
    are due and makes one pass of the program's loop - as ``loop()`` on a board that
    never sleeps - and says how long the program may sleep.
    """

    def __init__(self, app, scale: float = 1.0) -> None:
        self.app = app
        self.scale = scale

    def set_scale(self, scale: float) -> None:  # the device decides its clock
        pass

    def target_tick(self) -> int:
        return self.app.backend.now()

    def advance(self) -> float | None:
        app = self.app
        backend = app.backend
        app.run_until(backend.now())  # setup() on the first call; serves the link
        backend.app_wait_until(backend.now())
        app.loop_pass()
        wake = app.next_wake_tick()
        if wake is None:
            return None
        tps = app.profile.ticks_per_s
        return max(0.0, (wake - backend.now()) / tps / self.scale)


def not_connected(backend) -> str:
    """The console's answer to program input while the device is lost."""
    return msg.SERIAL_NOT_CONNECTED.format(reason=backend.lost_reason or "closed")


def console_attach(console, backend) -> None:
    """Report a lost device in one line above the prompt."""
    def on_event(event: str, text: str) -> None:
        if event == "lost":
            console.note(msg.SERIAL_LOST.format(reason=text))
    backend.listeners.append(on_event)


def console_meta(console, cmd: str, args: list[str]) -> Iterable[str]:
    """``/reconnect [port]``, ``/link``, ``/estop``: the lines to show."""
    from fas.serial import SerialError

    backend = console.backend
    if not getattr(console, "port", None):
        return [msg.SERIAL_NOT_SERIAL.format(cmd=cmd)]
    if cmd == "/reconnect":
        try:
            backend.reconnect(args[0] if args else None)
        except SerialError as exc:
            return [msg.SERIAL_RECONNECT_FAILED.format(error=exc)]
        console.port = backend.port
        return [msg.SERIAL_RECONNECTED.format(port=backend.port, profile=backend.profile.name,
                                              sessions=backend.sessions)]
    if cmd == "/link":
        if backend.connected:
            backend.request_status(500)
        lines = stats_lines(backend)
        if not backend.connected:
            lines.append(msg.SERIAL_LOST.format(reason=backend.lost_reason))
        return lines
    if cmd == "/estop":
        if not backend.connected:
            return [msg.SERIAL_ESTOP_NO_DEVICE.format(reason=backend.lost_reason or "closed")]
        if backend.emergency_stop():
            return [msg.SERIAL_ESTOP_DONE]
        return [msg.SERIAL_ESTOP_FAILED.format(reason=backend.lost_reason)]
    return [msg.REPL_UNKNOWN_META.format(cmd=cmd)]


# ------------------------------------------------------------- subcommands
class StopOnSignal:
    """A stop flag for the serving loops of the subcommands: Ctrl-C and SIGTERM set it
    (the loop ends cleanly, closing its pty and printing its summary)."""

    def __init__(self) -> None:
        import signal  # (only a device needs it: not imported at every start)

        self.flag = False
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, self._set)

    def _set(self, *_args) -> None:
        self.flag = True

    def __call__(self) -> bool:
        return self.flag


def device_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="stepperdemo device",
        description="A device that speaks the serial protocol (docs/serial-protocol.md) "
                    "and executes on the simulated machine in real time - or, with "
                    "--simavr, the device firmware (firmware/) in the simavr AVR "
                    "simulator.")
    where = ap.add_mutually_exclusive_group()
    where.add_argument("--pty", action="store_true",
                       help="serve a new pseudo-terminal and print its path (default)")
    where.add_argument("--port", metavar="PATH", help="serve an existing serial port")
    where.add_argument("--simavr", action="store_true",
                       help="run the device firmware (firmware/) in the simavr AVR "
                            "simulator on a new pty instead; builds it if needed")
    ap.add_argument("--firmware", metavar="ELF",
                    help="--simavr: this firmware build instead of the one built from the "
                         "sources (firmware/ of the checkout or of the installed package)")
    ap.add_argument("--baud", type=int, default=115200, choices=(115200, 1_000_000),
                    help="--simavr: the firmware's line speed (default 115200)")
    ap.add_argument("--trace", metavar="FILE",
                    help="--simavr: record every pin change (cycle, pin, level) in FILE")
    ap.add_argument("--arch", default="atmega328p", choices=sorted(PROFILES),
                    help="the device's profile (default atmega328p)")
    ap.add_argument("--watchdog-ms", type=int, default=500, metavar="MS",
                    help="stop all motion after MS of host silence unless the host asks "
                         "for another time (default 500)")
    ap.add_argument("--speed", type=float, default=1.0, metavar="FACTOR",
                    help="run the device clock FACTOR times faster than real time")
    ap.add_argument("--link", metavar="PATH",
                    help="also make PATH a symbolic link to the pty (a stable name)")
    ap.add_argument("--quiet", action="store_true", help="print only the pty path")
    ap.add_argument("--input", action="append", default=[], metavar="PIN=VALUE",
                    help="an input of the board at start: a switch (0/1) or a pot (0..1023); "
                         "PIN is a pin number or A0, A1, ... (e.g. --input A4=0 closes the "
                         "winder's fixture switch); repeatable; also with --simavr (on the "
                         "chip's pins)")
    ap.add_argument("--inputs-from-stdin", action="store_true",
                    help="read PIN=VALUE lines from standard input while serving: turn pots "
                         "and press switches of the simulated board (e.g. A0=900, A3=0); "
                         "also with --simavr")
    ap.add_argument("--console", action="store_true",  # issue 15
                    help="instead of the protocol: the simulated StepperDemo firmware with "
                         "its text console (as a board flashed with the original sketch; "
                         "for stepperdemo --board); it restarts when a host opens the pty")
    return ap


def parse_input(text: str, profile) -> tuple[int, int, bool | None]:
    """``PIN=VALUE`` -> (pin, value, analog): a value above 1 is a pot; 0 and 1 go to
    the pin as the host watches it (None: digital while nobody watches it)."""
    pin_text, sep, value_text = text.strip().partition("=")
    if not sep:
        raise ValueError(f"{text!r} is not PIN=VALUE")
    pin_text = pin_text.strip().upper()
    try:
        value = int(value_text)
        pin = (profile.analog_pins[int(pin_text[1:])] if pin_text.startswith("A")
               else int(pin_text))
    except (ValueError, IndexError):
        raise ValueError(f"{text!r} is not PIN=VALUE") from None
    if not 0 <= value <= 1023 or not 0 <= pin <= 255:
        raise ValueError(f"{text!r}: pin 0..255, value 0..1023")
    return pin, value, (True if value > 1 else None)


def run_device(argv: Sequence[str]) -> int:
    from fas.arch import get_profile
    from fas.device import Device
    from fas.serial import LinkClosed, Pty, RealClock, open_serial
    from fas.serial.stream import remove_link, set_link

    from .arg_checks import link_problem, speed_problem

    args = device_parser().parse_args(argv)
    problem = speed_problem(args.speed) or (
        "--watchdog-ms must be >= 0" if args.watchdog_ms < 0 else None) or link_problem(
        args.link)
    if problem:
        print(msg.CLI_ERROR.format(problem=problem), file=sys.stderr)
        return EXIT_USAGE
    if args.simavr:
        return run_simavr(args)
    if args.console:  # issue 15: the StepperDemo text console, not the protocol
        from .console_device import run
        return run(args)
    profile = get_profile(args.arch)
    pty = None
    if args.port:
        try:
            stream = open_serial(args.port)
        except LinkClosed as exc:
            print(msg.CLI_ERROR.format(problem=exc), file=sys.stderr)
            return EXIT_USAGE
        path = args.port
    else:
        pty = Pty("device")
        stream, path = pty.stream, pty.path
        set_link(args.link, path)
    device = Device(stream, profile, RealClock(args.speed), watchdog_ms=args.watchdog_ms)
    try:
        for text in args.input:
            device.set_input(*parse_input(text, profile))
    except ValueError as exc:
        print(msg.CLI_ERROR.format(problem=exc), file=sys.stderr)
        return EXIT_USAGE
    each = _stdin_inputs(device.set_input, profile) if args.inputs_from_stdin else None
    if args.quiet:
        print(path, flush=True)
    else:
        print(msg.DEVICE_LISTENING.format(profile=profile.name, title=profile.title, path=path,
                                          link=f" ({args.link})" if args.link else "",
                                          speed=args.speed), flush=True)
        device.listeners.append(lambda event: print(msg.DEVICE_EVENT.format(event=event),
                                                    flush=True))
    stop = StopOnSignal()
    try:
        device.serve(stop, each)
    finally:
        if pty is not None:
            remove_link(args.link, path)
            pty.close()
        elif device.stream is not None:
            device.stream.close()
    if not args.quiet:
        for idx in sorted(device.queues):
            print(msg.DEVICE_STEPPER_STATS.format(n=idx + 1, position=device.position(idx),
                                                  pulses=device.pulses(idx),
                                                  edges=device.step_edges(idx)))
        print(msg.DEVICE_COUNTERS.format(**device.counters))
    return 0


def _stdin_inputs(set_input, profile):
    """Lines typed at the device's terminal set its inputs (read by a thread), through
    ``set_input(pin, value, analog)``."""
    import queue
    import threading

    typed: queue.Queue[str] = queue.Queue()

    def reader() -> None:
        for line in sys.stdin:
            typed.put(line)

    threading.Thread(target=reader, daemon=True).start()

    def each() -> None:
        while not typed.empty():
            line = typed.get_nowait().strip()
            if not line:
                continue
            try:
                set_input(*parse_input(line, profile))
                print(msg.DEVICE_INPUT_SET.format(text=line), flush=True)
            except ValueError as exc:
                print(msg.CLI_ERROR.format(problem=exc), flush=True)

    return each


def run_simavr(args: argparse.Namespace) -> int:
    """``stepperdemo device --simavr``: the firmware in simavr on a new pty, real time."""
    import time

    from fas.arch import get_profile
    from fas.device.simavr import (
        SimavrError,
        SimavrServer,
        build,
        build_dir,
        build_harness,
        first_build,
    )

    if args.arch != "atmega328p" or args.watchdog_ms != 500 or args.console:
        option = ("arch" if args.arch != "atmega328p" else
                  "watchdog-ms" if args.watchdog_ms != 500 else "console")
        print(msg.CLI_ERROR.format(problem=msg.DEVICE_SIMAVR_OPTION.format(option=option)),
              file=sys.stderr)
        return EXIT_USAGE
    try:
        if first_build(None if args.firmware else args.baud):
            print(msg.DEVICE_SIMAVR_BUILDING.format(
                what="simavr harness" if args.firmware else "firmware and its simavr harness",
                where=build_dir()), file=sys.stderr, flush=True)
        if args.firmware:
            elf, harness = args.firmware, build_harness()
        else:
            built = build(args.baud)
            elf, harness = built.elf, built.harness
        server = SimavrServer(elf, harness, speed=args.speed, link=args.link,
                              trace=args.trace)
    except SimavrError as exc:
        print(msg.DEVICE_SIMAVR_BUILD_FAILED.format(error=exc), file=sys.stderr)
        return EXIT_USAGE
    profile = get_profile("atmega328p")

    def set_input(pin: int, value: int, analog: bool | None = None) -> None:
        # the harness sets a level for 0/1 unless the value is a pot's (section 18)
        try:
            server.set_input(pin, value, value > 1 if analog is None else analog)
        except SimavrError as exc:  # the harness has ended: said once, as a bad line
            raise ValueError(str(exc)) from None

    try:
        for text in args.input:
            set_input(*parse_input(text, profile))
    except ValueError as exc:
        server.stop()
        print(msg.CLI_ERROR.format(problem=exc), file=sys.stderr)
        return EXIT_USAGE
    each = _stdin_inputs(set_input, profile) if args.inputs_from_stdin else None
    if args.quiet:
        print(server.path, flush=True)
    else:
        title = msg.DEVICE_SIMAVR_TITLE.format(elf=elf, baud=args.baud)
        print(msg.DEVICE_LISTENING.format(profile=profile.name, title=title, path=server.path,
                                          link=f" ({args.link})" if args.link else "",
                                          speed=args.speed), flush=True)
    stop = StopOnSignal()
    while not stop() and server.proc.poll() is None:
        if each is not None:
            each()
        time.sleep(0.1)
    lines = server.stop()
    if not args.quiet:
        for line in lines:
            print(msg.DEVICE_SIMAVR_SUMMARY.format(line=line))
    return 0 if server.proc.returncode in (0, -15) else 1


def relay_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="stepperdemo relay",
        description="Relay between a new pty (for the host) and a device's port, with "
                    "seeded byte faults, latency and an optional baud-rate pace.")
    ap.add_argument("device", metavar="DEVICE", help="the device's port or pty path")
    ap.add_argument("--drop", type=float, default=0.0, metavar="P",
                    help="probability that a byte is lost")
    ap.add_argument("--corrupt", type=float, default=0.0, metavar="P",
                    help="probability that a byte has one bit flipped")
    ap.add_argument("--dup", type=float, default=0.0, metavar="P",
                    help="probability that a byte arrives twice")
    ap.add_argument("--latency-ms", type=float, default=0.0, metavar="MS",
                    help="delay added to every byte, each direction")
    ap.add_argument("--baud", type=int, default=0, metavar="N",
                    help="pace each direction to N baud, 10 bits a byte (0: no pacing)")
    ap.add_argument("--chunk-ms", type=float, default=0.0, metavar="MS",
                    help="deliver in bursts every MS (a USB adapter's latency timer)")
    ap.add_argument("--stall-ms", type=float, default=0.0, metavar="MS",
                    help="stop the line for MS (both ways) at every --stall-every-ms")
    ap.add_argument("--stall-every-ms", type=float, default=0.0, metavar="MS",
                    help="the period of the stalls (default: no stalls)")
    ap.add_argument("--seed", type=int, default=1, help="random seed (default 1)")
    ap.add_argument("--link", metavar="PATH",
                    help="also make PATH a symbolic link to the host-side pty")
    return ap


def run_relay(argv: Sequence[str]) -> int:
    from fas.device import Faults, Relay
    from fas.serial import LinkClosed, Pty, open_serial
    from fas.serial.stream import remove_link, set_link

    from .arg_checks import link_problem

    args = relay_parser().parse_args(argv)
    problem = link_problem(args.link)
    if problem:
        print(msg.CLI_ERROR.format(problem=problem), file=sys.stderr)
        return EXIT_USAGE
    try:
        faults = Faults(drop=args.drop, corrupt=args.corrupt, dup=args.dup,
                        latency_ms=args.latency_ms, baud=args.baud, seed=args.seed,
                        chunk_ms=args.chunk_ms, stall_ms=args.stall_ms,
                        stall_every_ms=args.stall_every_ms)
        device_side = open_serial(args.device)
    except (ValueError, LinkClosed) as exc:
        print(msg.CLI_ERROR.format(problem=exc), file=sys.stderr)
        return EXIT_USAGE
    pty = Pty("relay")
    set_link(args.link, pty.path)
    relay = Relay(pty.stream, device_side, faults)
    print(msg.RELAY_LISTENING.format(path=pty.path, device=args.device,
                                     link=f" ({args.link})" if args.link else ""), flush=True)
    stop = StopOnSignal()
    try:
        relay.serve(stop)
    finally:
        remove_link(args.link, pty.path)
        pty.close()
        device_side.close()
    if relay.closed:
        print(msg.RELAY_DEVICE_GONE.format(reason=relay.closed))
    for direction, figures in relay.stats().items():
        print(msg.RELAY_STATS.format(direction=direction.replace("_", " "), **figures))
    return 0

