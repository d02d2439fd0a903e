"""A held W's status lines, the model beside build d's replica: where each line starts
against the pass chain of W and the step train, and which rises its transmit interrupts
meet (docs/timing-model.md, "forty-eighth pass").

While a stepper runs, StepperDemo's ``W`` runs the loop pass after pass and prints a
status line when a pass's ``millis()`` read has passed 100 ms since the last line.  The
line's first character therefore lies at the read of the pass that first sees the new
``millis()``; its transmit interrupts follow every 1 496 ticks, and which step pulses
they hold follows from where that pass lies.  From a replica run (``WORK/CASE-TAG.ev`` /
``.pins`` of ``replica.py --build d``, less ``--lag``) and the model's run of the same
input (``--variant`` / ``--set`` as ``bench/d_corpus.py``):

* ``lines``: per status line, on the replica its ``millis()`` read (the main program's
  section at ``c4a``) after timer 0's entry and the first character's hand-over after
  that read; the hand-over after timer 0's entry on both sides and the difference; the
  difference of the first rise after the line (the step train's); their difference, the
  line's phase against the steps (model less replica); the length of the pass that
  prints (the replica: from the pass end before the hand-over to the one after it, a
  pass ending 123 ticks after its read; the model: its loop pass);
* ``uart``: the first transmit interrupt after each hand-over (the replica's entry, the
  model's load), and every rise that lies within 130 ticks after a transmit interrupt's
  request with its width (the replica's request: its entry less 4);
* ``body``: the main program's CPU from a line's first character to its last (the
  replica: the span less every routine entered in it, entry to ``reti``; the model: the
  characters' own ticks and what the program spends between them), per line, and with
  ``--pieces K`` character by character for line ``K``.

::

    python3 bench/replica/status_chain.py --work /tmp/s37rep --conformance /tmp/s37conf \\
        --variant R47 --variant S42 ... readme_move

(``readme_move``: a folder with ``input.txt`` holding ``M1 A1000 V100 R3200 W `` and a
replica run of it: ``replica.py --conformance /tmp/s37conf --build d steps readme_move``,
with ``TASK_SECTIONS=1`` as ``pulse_holders.py`` reads it.)
"""

from __future__ import annotations

import argparse
import bisect
import statistics
import sys
from collections import deque
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent))
sys.path.insert(0, str(HERE.parent))

import pulse_holders  # noqa: E402
from d_corpus import set_build_d_from_args  # noqa: E402

READ_PC = "c4a"  # the main program's millis() section
UART_VECTOR, TIMER0_VECTOR = "19", "16"
WRITE_PCS = ("1064", "1074")  # HardwareSerial::write's critical sections
VECTOR_ENTRY = 4  # a vector's entry after its request (the replica)
READ_BEFORE_END = 123  # a held W's pass ends this long after its millis() read
QUIET_GAP = 1_000_000  # a status line's first character after a quiet line
NEAR = 130  # a rise this close after a transmit request can wait for it
STEP_PIN = "B1"


# ------------------------------------------------------------------ replica's side
class ReplicaRun:
    """The main program's hand-overs and millis() reads, timer 0's and the UART's
    entries and stepper A's pulses of one replica run, less ``lag``."""

    def __init__(self, ev_lines: list[str], pins_lines: list[str], lag: int) -> None:
        self.chars: list[int] = []
        self.reads: list[int] = []
        self.routines: list[tuple[int, int]] = []  # (entry, reti) of the outermost ones
        self.timer0: list[int] = []
        self.uart: list[int] = []
        depth = 0
        entry = 0
        for line in ev_lines:
            p = line.split()
            if len(p) < 2:
                continue
            t = int(p[0]) - lag
            if p[1] == "V":
                if depth == 0:
                    entry = t
                depth += 1
                if len(p) >= 3 and p[2] == TIMER0_VECTOR:
                    self.timer0.append(t)
                elif len(p) >= 3 and p[2] == UART_VECTOR:
                    self.uart.append(t)
            elif p[1] == "R":
                depth -= 1
                if depth == 0:
                    self.routines.append((entry, t))
            elif p[1] == "C" and depth == 0 and len(p) >= 3:
                if p[2] in WRITE_PCS:
                    self.chars.append(t)
                elif p[2] == READ_PC:
                    self.reads.append(t)
        self.pulses = pulse_holders.replica_pulses(pins_lines, STEP_PIN, lag)
        self._entries = [a for a, _ in self.routines]

    def cpu(self, begin: int, end: int) -> int:
        """The main program's ticks in ``[begin, end)``: the span less the routines
        entered in it (to their ``reti``, at most ``end``)."""
        i = bisect.bisect_left(self._entries, begin)
        t = end - begin
        while i < len(self.routines) and self.routines[i][0] < end:
            a, b = self.routines[i]
            t -= min(b, end) - a
            i += 1
        return t


# -------------------------------------------------------------------- model's side
class ModelRun:
    """The model's run of ``text`` in build d: every hand-over, every transmit
    interrupt's load, the loop passes' starts, timer 0's phase and stepper A's pulses."""

    def __init__(self, text: str) -> None:
        from pulse_widths import backend_pulses

        from fas.sim import SimBackend
        from stepperdemo.program import make_program

        records: list[list[int]] = []

        class Records(deque[list[int]]):  # each appended record is a hand-over
            def append(self, x: list[int]) -> None:
                records.append(x)  # (the same list: a later blocked window moves it)
                super().append(x)

        backend = SimBackend("atmega328p", record=True, build="d")
        m = backend.machine
        m.uart.records = Records(maxlen=m.uart.capacity)
        # the program's CPU: each character's own ticks (in hand-over order) and what it
        # spends elsewhere, at the tick it spends it
        self.char_cpu: list[int] = []
        self.spends: list[tuple[int, int]] = []
        char_cpu, spends = self.char_cpu, self.spends
        app_spend, console_write = backend.app_spend, backend.console_write

        def spend(ticks: int) -> None:
            spends.append((m.now, ticks))
            app_spend(ticks)

        def write(data: bytes, cpu_after: Any = None) -> None:
            ct = m.timing.char_ticks
            char_cpu.extend(ct + (cpu_after[i] if cpu_after else 0) for i in range(len(data)))
            console_write(data, cpu_after)

        backend.app_spend = spend  # type: ignore[method-assign]
        backend.console_write = write  # type: ignore[method-assign]
        app = make_program("demo", backend, scripted=True)
        self.starts: list[int] = []
        starts = self.starts
        loop_pass = app.loop_pass

        def counted_pass() -> None:
            starts.append(m.now)
            loop_pass()

        app.loop_pass = counted_pass  # type: ignore[method-assign]
        app.run_script(text, firmware_end=True)
        self.text = bytes(app.transcript)
        self.chars = [r[0] for r in records]
        self.loads = sorted(r[1] for r in records if r[1] > r[0])
        self.pulses = backend_pulses(backend)["A"]
        self.millis_phase = m._millis_phase  # noqa: SLF001
        self.millis_period = m.timing.millis_overflow_ticks
        self._spent_at = [t for t, _ in self.spends]

    def cpu(self, k: int) -> int:
        """The program's ticks from character ``k``'s hand-over to character ``k+1``'s:
        character ``k``'s own and what it spends in between."""
        a, b = self.chars[k], self.chars[k + 1]
        i, j = bisect.bisect_left(self._spent_at, a), bisect.bisect_left(self._spent_at, b)
        return self.char_cpu[k] + sum(t for _, t in self.spends[i:j])


# ------------------------------------------------------------------------ tables
def line_starts(chars: list[int]) -> list[int]:
    """Indices of the characters that begin a line after a quiet one (status lines)."""
    return [i for i in range(1, len(chars)) if chars[i] - chars[i - 1] > QUIET_GAP]


def before(xs: list[int], t: int) -> int | None:
    i = bisect.bisect_right(xs, t) - 1
    return xs[i] if i >= 0 else None


def after(xs: list[int], t: int) -> int | None:
    i = bisect.bisect_right(xs, t)
    return xs[i] if i < len(xs) else None


def near_rises(pulses: list[tuple[int, int]], requests: list[int]) -> list[tuple[int, int]]:
    """(rise less the transmit request before it, width) of every pulse that rises within
    ``NEAR`` ticks after a request, in order of the distance."""
    out = []
    for rise, fall in pulses:
        r = before(requests, rise)
        if r is not None and rise - r < NEAR:
            out.append((rise - r, fall - rise))
    return sorted(out)


def lines_table(rep: ReplicaRun, mod: ModelRun) -> list[dict[str, Any]]:
    """One row per status line found on both sides (paired from the last)."""
    rl, ml = line_starts(rep.chars), line_starts(mod.chars)
    n = min(len(rl), len(ml))
    rends = [t + READ_BEFORE_END for t in rep.reads]
    rrises = [a for a, _ in rep.pulses]
    mrises = [a for a, _ in mod.pulses]
    rows = []
    for ri, mi in zip(rl[len(rl) - n:], ml[len(ml) - n:], strict=True):
        rh, mh = rep.chars[ri], mod.chars[mi]
        read = before(rep.reads, rh)
        t0r = before(rep.timer0, rh)
        ph, ov = mod.millis_phase, mod.millis_period
        t0m = mh - (mh - ph) % ov
        rr, mr = after(rrises, rh), after(mrises, mh)
        re0, re1 = before(rends, rh), after(rends, rh)
        ms0, ms1 = before(mod.starts, mh), after(mod.starts, mh)
        row: dict[str, Any] = {
            "read_after_t0": None if read is None or t0r is None else read - t0r,
            "handover_after_read": None if read is None else rh - read,
            "rep_after_t0": None if t0r is None else rh - t0r,
            "mod_after_t0": mh - t0m,
            "handover": mh - rh,
            "rise": None if rr is None or mr is None else mr - rr,
            "rep_pass": None if re0 is None or re1 is None else re1 - re0,
            "mod_pass": None if ms0 is None or ms1 is None else ms1 - ms0,
        }
        row["phase"] = None if row["rise"] is None else row["handover"] - row["rise"]
        rows.append(row)
    return rows


def line_length(chars: list[int], i: int) -> int:
    """Characters of the line that begins at ``i`` (up to the next quiet gap)."""
    n = 1
    while i + n < len(chars) and chars[i + n] - chars[i + n - 1] <= QUIET_GAP:
        n += 1
    return n


def paired_lines(rep: ReplicaRun, mod: ModelRun) -> list[tuple[int, int, int]]:
    """(replica index, model index, characters) of the status lines, paired from the
    last: each line up to its line feed in the model's text (0 where the replica's line
    is shorter, or no text was kept)."""
    rl, ml = line_starts(rep.chars), line_starts(mod.chars)
    n = min(len(rl), len(ml))
    out = []
    for ri, mi in zip(rl[len(rl) - n:], ml[len(ml) - n:], strict=True):
        end = mod.text.find(b"\n", mi) if len(mod.text) == len(mod.chars) else -1
        k = end + 1 - mi if end >= 0 else 0
        out.append((ri, mi, k if 0 < k <= line_length(rep.chars, ri) else 0))
    return out


def pieces(rep: ReplicaRun, mod: ModelRun, ri: int, mi: int,
           n: int) -> list[tuple[int, bytes, int, int]]:
    """Per gap ``j`` between a line's characters ``j`` and ``j+1``: (j, the two
    characters, the replica's CPU, the model's)."""
    out = []
    for j in range(n - 1):
        two = mod.text[mi + j:mi + j + 2] if len(mod.text) == len(mod.chars) else b""
        out.append((j, two, rep.cpu(rep.chars[ri + j], rep.chars[ri + j + 1]), mod.cpu(mi + j)))
    return out


def first_isr_after(chars: list[int], starts: list[int], isrs: list[int]) -> list[int]:
    """Per line, its first transmit interrupt less its first character's hand-over."""
    out = []
    for i in starts:
        x = after(isrs, chars[i])
        if x is not None:
            out.append(x - chars[i])
    return out


def _cell(v: object) -> str:
    return "" if v is None else f"{v:+d}" if isinstance(v, int) else str(v)


def report(case: str, rep: ReplicaRun, mod: ModelRun, label: str) -> None:
    print(f"## {case}")
    rows = lines_table(rep, mod)
    print(f"status lines: replica {len(line_starts(rep.chars))}, "
          f"model {len(line_starts(mod.chars))}")
    print("| line | replica: read after timer 0 | hand-over after read | hand-over after "
          "timer 0: replica | model | hand-over, model less replica | first rise after | "
          "phase against the steps | printing pass: replica | model |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for k, r in enumerate(rows):
        print(f"| {k} | {_cell(r['read_after_t0'])} | {_cell(r['handover_after_read'])} | "
              f"{_cell(r['rep_after_t0'])} | {_cell(r['mod_after_t0'])} | "
              f"{_cell(r['handover'])} | {_cell(r['rise'])} | {_cell(r['phase'])} | "
              f"{_cell(r['rep_pass'])} | {_cell(r['mod_pass'])} |")
    phases = [r["phase"] for r in rows if r["phase"] is not None]
    if phases:
        print(f"phase against the steps: median {statistics.median(phases):+g}, "
              f"{min(phases):+d}..{max(phases):+d}")
    rf = first_isr_after(rep.chars, line_starts(rep.chars), rep.uart)
    mf = first_isr_after(mod.chars, line_starts(mod.chars), mod.loads)
    if rf and mf:
        print(f"first transmit interrupt after a line's hand-over: replica (entry) "
              f"{statistics.median(rf):g} ({min(rf)}..{max(rf)}), model (load) "
              f"{statistics.median(mf):g} ({min(mf)}..{max(mf)})")
    print("| line | characters | body CPU: replica | model | model less replica |")
    print("| --- | --- | --- | --- | --- |")
    diffs = []
    for k, (ri, mi, n) in enumerate(paired_lines(rep, mod)):
        if not n:
            print(f"| {k} | (not paired) | | | |")
            continue
        pc = pieces(rep, mod, ri, mi, n)
        r, m = sum(x[2] for x in pc), sum(x[3] for x in pc)
        diffs.append(m - r)
        print(f"| {k} | {n} | {r} | {m} | {m - r:+d} |")
    if diffs:
        print(f"body CPU, model less replica: median {statistics.median(diffs):+g}, "
              f"{min(diffs):+d}..{max(diffs):+d}")
    print(f"rises within {NEAR} ticks after a transmit request (distance, width):")
    print(f"  replica (entry less {VECTOR_ENTRY}): "
          f"{near_rises(rep.pulses, [t - VECTOR_ENTRY for t in rep.uart])}")
    print(f"  model {label} (load): {near_rises(mod.pulses, mod.loads)}")


def report_pieces(rep: ReplicaRun, mod: ModelRun, k: int) -> None:
    ri, mi, n = paired_lines(rep, mod)[k]
    print(f"line {k}: {mod.text[mi:mi + n]!r}")
    print("| gap | characters | replica CPU | model CPU | model less replica | sum |")
    print("| --- | --- | --- | --- | --- | --- |")
    total = 0
    for j, two, r, m in pieces(rep, mod, ri, mi, n):
        total += m - r
        print(f"| {j} | {two!r} | {r} | {m} | {m - r:+d} | {total:+d} |")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    pulse_holders.add_run_args(ap)
    ap.add_argument("--pieces", type=int, metavar="K",
                    help="also line K's CPU character by character")
    ap.add_argument("cases", nargs="+")
    args = ap.parse_args(argv)
    if not set_build_d_from_args(args, "status_chain"):
        return 2
    label = "(" + " ".join(args.variant + args.set) + ")" if args.variant or args.set else ""
    for case in args.cases:
        found = pulse_holders.run_files(args, case, "status_chain")
        if found is None:
            return 2
        ev, pins, text = found
        with ev.open() as f_ev, pins.open() as f_pins:
            rep = ReplicaRun(list(f_ev), list(f_pins), args.lag)
        mod = ModelRun(text)
        report(case, rep, mod, label)
        if args.pieces is not None:
            report_pieces(rep, mod, args.pieces)
    return 0


if __name__ == "__main__":
    sys.exit(main())
