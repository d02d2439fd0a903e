"""Issue 25's laser figure: how late the M4 power follows each queue command.

    python bench/bench_laser.py [--arch atmega2560] [--executor lookahead|exact_stop|both]

Laser mode (``$32=1``), ``M4 S1000``, ``G1 X40 F3000`` then ``G0 X0`` (80 steps/mm,
500 mm/s², ``$30=2000``: full feed is 50 % duty, ``$141=1000``: a 1 kHz PWM) on the
simulated chip.  For every queue command the executor tells the laser about (its tick
and the duty it asks for), the lateness is the time from that tick to the moment the
chip's PWM unit is given that duty (0 when it has it already); the duty shows from the
timer's next period after that.  Printed: the largest lateness, the PWM period, and how
many commands came later than one period.

``--device``: the same program through ``--port`` (``rigs/laser.py``) on the Python
device at 115 200 baud and on our firmware in simavr at 115 200 and 1 000 000 baud: for
every duty change the laser asked for that a later one does not replace before it
could show, how many PWM periods after the first one that begins after its tick the
Uno's pin 11 shows it (asked: the laser's changes; sent: those that went on the line,
OutputAt or OutputNext - the host leaves out a change that a later one replaces in
the same PWM period of the device).
"""

from __future__ import annotations

import argparse
import bisect
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
if ROOT not in sys.path:
    sys.path.insert(0, ROOT)

from stepperdemo.gcode.program import RawGrbl  # noqa: E402

SPU = 80
MM = (f"$100={SPU}\n$101={SPU}\n$102={SPU}\n$110=12000\n$111=12000\n$112=12000\n"
      "$120=500\n$121=500\n$122=500\n")
PROGRAM = "M4 S1000\nG1 X40 F3000\nG0 X0\n"


def settle_lines(g: RawGrbl, text: str) -> None:
    for line in text.splitlines(keepends=True):
        g.send(line.encode())
        assert g.settle()


def lateness(arch: str, executor: str) -> dict[str, float]:
    g = RawGrbl(arch, record=True)
    settle_lines(g, MM + "$30=2000\n$32=1\n$141=1000\n"
                 f"$171={int(executor == 'exact_stop')}\n")
    g.take()
    g.machine.poll()  # ($171 picks the executor at the next poll)
    tooling = g.machine.tooling
    asked: list[tuple[int, float]] = []  # (tick, duty) of every change the laser asked for
    original = tooling.on_speed

    def spy(tick, rate, block):  # type: ignore[no-untyped-def]
        before = tooling.last_scheduled
        original(tick, rate, block)
        if tooling.last_scheduled is not None and tooling.last_scheduled != before:
            asked.append((tick, tooling.last_scheduled))

    g.machine.executor.set_speed_listener(spy)
    made: list[tuple[int, float]] = []  # (tick, duty) the chip's PWM unit was given
    g.backend.output_listeners.append(lambda ch, t: made.append((t, ch.percent)))
    settle_lines(g, PROGRAM)
    period = g.ticks_per_s // 1000
    made_ticks = [t for t, _ in made]
    worst, late = 0, 0
    for tick, duty in asked:
        k = bisect.bisect_right(made_ticks, tick)
        if k and made[k - 1][1] == duty:
            continue  # given at or before its tick
        found = next((t for t, d in made[k:] if d == duty), None)
        if found is None:  # superseded before it was made: late until the next change
            found = made_ticks[k] if k < len(made) else tick
        worst = max(worst, found - tick)
        late += found - tick > period
    ms = 1000 / g.ticks_per_s
    return {"commands": len(asked), "worst_ms": worst * ms, "period_ms": period * ms,
            "later_than_a_period": late}


def on_devices() -> None:
    from rigs.laser import run

    for device, baud in (("python", 115200), ("simavr", 115200), ("simavr", 1_000_000)):
        r = run(device, baud)
        checks = r.checks()
        late = [c for c in checks if c[3] != 0]
        worst = max((c[2] + c[3] * r.period - c[0] for c in checks if c[3] >= 0), default=0)
        print(f"{device:6s} {baud:>7} baud: {len(r.asked)} asked, {len(r.sent)} sent, "
              f"{len(checks)} checked, {len(late)} late "
              f"(never shown: {sum(c[3] < 0 for c in late)}), the latest shows "
              f"{worst / 16000:.3f} ms after its tick (PWM period {r.period / 16000:.3f} ms),"
              f" rejected {r.counters['rejected']}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--arch", default="atmega2560")
    ap.add_argument("--executor", default="both", choices=("lookahead", "exact_stop", "both"))
    ap.add_argument("--device", action="store_true", help="the runs through --port")
    a = ap.parse_args()
    if a.device:
        on_devices()
        return
    for ex in ("lookahead", "exact_stop") if a.executor == "both" else (a.executor,):
        r = lateness(a.arch, ex)
        print(f"{a.arch} {ex:10s}: {r['commands']} duty changes, latest "
              f"{r['worst_ms']:.3f} ms after its queue command (PWM period "
              f"{r['period_ms']:.3f} ms), {r['later_than_a_period']} later than a period")


if __name__ == "__main__":
    main()
