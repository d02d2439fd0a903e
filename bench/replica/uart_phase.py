"""The console's characters and the pulses they hold: a build-d replica run beside the
model, character by character (docs/timing-model.md, "forty-second pass").

A step pulse on the ATmega328P lasts until its step interrupt lowers the pin; the longest
ones wait behind the UART's transmit interrupt (118 cycles to its ``reti``).  Which pulses
wait, and how long, follows from where the transmit interrupts fall against the steps: the
phase of the console's characters.  From a replica run (``WORK/CASE-TAG.ev`` / ``.pins``
of ``replica.py --build d``, less the replica's lead over the firmware, ``--lag``) and the
model's run of the same input in build d (ATmega328P):

* ``chars``: every character's hand-over to the serial driver (the replica: the driver's
  critical section in the main program, one per character; the model: the UART's records),
  the first one, the commonest difference where both wait for room (a full buffer), and
  with ``-v`` every place where the difference moves by more than 30 ticks;
* ``status``: each 100 ms status line of a running stepper (a character after a quiet
  line, ``M1``) counted from timer 0's overflow before it (the loop's pass that reads the
  new ``millis()``);
* ``longest``: the longest pulses of stepper A and what held each (the replica: the
  routines running at the rise - ``V19`` the UART, ``V16`` timer 0, ``V13`` the ramp task,
  ``cli`` a section of the main program with interrupts off); the model's longest;
  and per holder the replica's held pulses and their ticks beyond the plain width.

``--set FIELD=VALUE`` / ``--variant NAME`` change build d's ATmega328P figures as
``bench/d_corpus.py`` does::

    python3 bench/replica/uart_phase.py chars test_sd_07_328p
    python3 bench/replica/uart_phase.py --variant U42 chars test_sd_07_328p
    python3 bench/replica/uart_phase.py --conformance /tmp/conf longest readme_move

(``readme_move``: a folder with ``input.txt`` holding ``M1 A1000 V100 R3200 W `` and a
replica run of it: ``replica.py --conformance /tmp/conf --build d steps readme_move``.)
"""

from __future__ import annotations

import argparse
import bisect
import collections
import sys
from collections import deque
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent))
sys.path.insert(0, str(HERE.parent))

import pulse_holders  # noqa: E402
from d_corpus import set_build_d_from_args  # noqa: E402

WRITE_PCS = ("1064", "1074")  # HardwareSerial::write's critical sections (buffer, register)
UART_VECTOR, TIMER0_VECTOR, TASK_VECTOR = "19", "16", "13"
VECTOR_ENTRY = 4  # a vector's entry after its request
STEP_PIN = "B1"
FULL_GAP = (1400, 1600)  # two characters apart by about one on the wire: a full buffer
QUIET_GAP = 1_000_000  # a line quiet this long before a status line's first character


def replica_events(ev: Path) -> list[list[str]]:
    return [p for p in (line.split() for line in ev.open()) if len(p) >= 2]


def replica_chars(events: list[list[str]], lag: int) -> list[int]:
    """Each character's hand-over: the driver's critical section entered by the main
    program (no routine running), less ``lag``."""
    out: list[int] = []
    depth = 0
    for p in events:
        if p[1] == "V":
            depth += 1
        elif p[1] == "R":
            depth -= 1
        elif p[1] == "C" and depth == 0 and p[2] in WRITE_PCS:
            out.append(int(p[0]) - lag)
    return out


def replica_vector(events: list[list[str]], vector: str, lag: int) -> list[int]:
    """A vector's requests (its entries less the entry and ``lag``)."""
    return [int(p[0]) - lag - VECTOR_ENTRY for p in events
            if p[1] == "V" and len(p) >= 3 and p[2] == vector]


def replica_pulses(pins: Path, lag: int) -> list[tuple[int, int]]:
    """(rise, fall) of every step pulse of stepper A in a ``.pins`` file, less ``lag``."""
    with pins.open() as f:
        return pulse_holders.replica_pulses(f, STEP_PIN, lag)


class ModelRun:
    """The model's run of ``text`` in build d with every character's hand-over kept."""

    def __init__(self, text: str) -> None:
        from pulse_widths import backend_pulses

        from fas.sim import SimBackend
        from stepperdemo.program import make_program

        self.writes: list[int] = []
        writes = self.writes

        class Records(deque[list[int]]):  # the UART's records: each appended one is a hand-over
            def append(self, x: list[int]) -> None:
                writes.append(x[0])
                super().append(x)

        backend = SimBackend("atmega328p", record=True, build="d")
        m = backend.machine
        m.uart.records = Records(maxlen=m.uart.capacity)
        app = make_program("demo", backend, scripted=True)
        app.run_script(text, firmware_end=True)
        self.text = bytes(app.transcript)
        self.pulses = backend_pulses(backend)["A"]
        self.millis_phase = m._millis_phase  # noqa: SLF001 (timer 0's overflow phase)
        self.millis_period = m.timing.millis_overflow_ticks


def full_offset(rep: list[int], mod: list[int]) -> tuple[int, int]:
    """The commonest model-minus-replica difference of the characters both hand over
    into a full buffer, and how many do."""
    c: collections.Counter[int] = collections.Counter()
    for i in range(1, min(len(rep), len(mod))):
        if (FULL_GAP[0] <= rep[i] - rep[i - 1] <= FULL_GAP[1]
                and FULL_GAP[0] <= mod[i] - mod[i - 1] <= FULL_GAP[1]):
            c[mod[i] - rep[i]] += 1
    if not c:
        return 0, 0
    return c.most_common(1)[0][0], sum(c.values())


def report_chars(rep: list[int], run: ModelRun, verbose: bool) -> None:
    mod = run.writes
    print(f"characters: replica {len(rep)}, model {len(mod)}")
    if rep and mod:
        print(f"first: replica {rep[0]}, model {mod[0]} ({mod[0] - rep[0]:+d})")
    off, n = full_offset(rep, mod)
    print(f"into a full buffer: model - replica {off:+d} ticks (commonest of {n})")
    if verbose:
        prev = None
        for i in range(min(len(rep), len(mod))):
            d = mod[i] - rep[i]
            if prev is None or abs(d - prev) > 30:
                ctx = run.text[max(0, i - 12):i + 1]
                print(f"{i:6d} replica {rep[i]:10d} model {mod[i]:10d} {d:+7d} {ctx!r}")
            prev = d


def status_starts(chars: list[int], text: bytes) -> list[int]:
    """Indices of the status lines' first characters (``M`` after a quiet line)."""
    return [i for i in range(1, len(chars))
            if chars[i] - chars[i - 1] > QUIET_GAP and text[i:i + 2] == b"M1"]


def report_status(rep: list[int], events: list[list[str]], run: ModelRun, lag: int) -> None:
    t0 = replica_vector(events, TIMER0_VECTOR, lag)
    mod = run.writes
    rows = []
    for i in status_starts(rep, run.text):
        if i >= len(mod):
            break
        j = bisect.bisect_right(t0, rep[i]) - 1
        after_m = (mod[i] - run.millis_phase) % run.millis_period
        rows.append((i, rep[i] - t0[j], after_m, mod[i] - rep[i]))
    print("| character | replica: after timer 0 | model: after timer 0 | model - replica |")
    print("| --- | --- | --- | --- |")
    for i, a, b, d in rows:
        print(f"| {i} | {a} | {b} | {d:+d} |")
    if rows:
        ra = sorted(r[1] for r in rows)
        ma = sorted(r[2] for r in rows)
        print(f"median after timer 0: replica {ra[len(ra) // 2]} (min {ra[0]}, max {ra[-1]}), "
              f"model {ma[len(ma) // 2]} (min {ma[0]}, max {ma[-1]})")


def holders(events: list[list[str]], lag: int) -> tuple[list[tuple[int, int, str]],
                                                         list[tuple[int, int, str]]]:
    """The routines (entry, reti, vector) and the main program's sections with interrupts
    off (cli, restore, pc), less ``lag``."""
    spans: list[tuple[int, int, str]] = []
    sections: list[tuple[int, int, str]] = []
    stack: list[tuple[int, str]] = []
    cli = None
    for p in events:
        t = int(p[0]) - lag
        if p[1] == "V":
            stack.append((t, p[2]))
        elif p[1] == "R" and stack:
            e, v = stack.pop()
            spans.append((e, t, v))
        elif p[1] == "C":
            cli = (t, p[2])
        elif p[1] == "S" and cli is not None:
            sections.append((cli[0], t, cli[1]))
            cli = None
    spans.sort()
    return spans, sections


def held_by(rise: int, spans: list[tuple[int, int, str]], span_starts: list[int],
            sections: list[tuple[int, int, str]], sec_starts: list[int]) -> str:
    """What held a pulse rising at ``rise``: the routines running then (the ramp task
    only where it had interrupts off: its long runs nest the step interrupt), else a
    section of the main program with interrupts off."""
    names = []
    in_task = False
    j = bisect.bisect_right(span_starts, rise)
    for e, x, v in spans[max(0, j - 40):j]:
        if e <= rise <= x and v not in ("11", "12"):
            if v == TASK_VECTOR and x - e > 1000:
                in_task = True
                continue
            names.append(f"V{v}")
    if not names and in_task:
        return "V13's own sections"
    if not names:
        k = bisect.bisect_right(sec_starts, rise)
        for e, x, pc in sections[max(0, k - 3):k]:
            if e <= rise <= x:
                names.append(f"cli {pc}")
    return " ".join(sorted(set(names))) or "-"


def report_longest(events: list[list[str]], pins: Path, run: ModelRun, lag: int,
                   count: int) -> None:
    rep = replica_pulses(pins, lag)
    spans, sections = holders(events, lag)
    span_starts = [s[0] for s in spans]
    sec_starts = [s[0] for s in sections]
    widths = [b - a for a, b in rep]
    plain = collections.Counter(widths).most_common(1)[0][0]
    mod = [b - a for a, b in run.pulses]
    print(f"pulses: replica {len(rep)}, plain {plain}, longest {max(widths)}; "
          f"model {len(mod)}, plain {collections.Counter(mod).most_common(1)[0][0]}, "
          f"longest {max(mod)}")
    print("| replica pulse | ticks | rise | held by |")
    print("| --- | --- | --- | --- |")
    top = sorted(range(len(rep)), key=lambda i: -widths[i])[:count]
    for i in top:
        print(f"| {i} | {widths[i]} | {rep[i][0]} | "
              f"{held_by(rep[i][0], spans, span_starts, sections, sec_starts)} |")
    print("| model pulse | ticks | rise |")
    print("| --- | --- | --- |")
    for i in sorted(range(len(mod)), key=lambda i: -mod[i])[:count]:
        print(f"| {i} | {mod[i]} | {run.pulses[i][0]} |")
    by: dict[str, list[int]] = collections.defaultdict(lambda: [0, 0])
    for (a, _), w in zip(rep, widths, strict=True):
        if w > plain:
            row = by[held_by(a, spans, span_starts, sections, sec_starts)]
            row[0] += 1
            row[1] += w - plain
    print("| replica: held by | pulses | ticks beyond the plain width |")
    print("| --- | --- | --- |")
    for name, (n, t) in sorted(by.items(), key=lambda kv: -kv[1][1]):
        print(f"| {name} | {n} | {t} |")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    pulse_holders.add_run_args(ap)
    ap.add_argument("--count", type=int, default=8, help="longest: pulses listed")
    ap.add_argument("-v", "--verbose", action="store_true")
    ap.add_argument("what", choices=("chars", "status", "longest"))
    ap.add_argument("cases", nargs="+")
    args = ap.parse_args(argv)
    if not set_build_d_from_args(args, "uart_phase"):
        return 2
    for case in args.cases:
        found = pulse_holders.run_files(args, case, "uart_phase")
        if found is None:
            return 2
        ev, pins, text = found
        events = replica_events(ev)
        run = ModelRun(text)
        print(f"## {case}")
        if args.what == "chars":
            report_chars(replica_chars(events, args.lag), run, args.verbose)
        elif args.what == "status":
            report_status(replica_chars(events, args.lag), events, run, args.lag)
        else:
            report_longest(events, pins, run, args.lag, args.count)
    return 0


if __name__ == "__main__":
    sys.exit(main())
