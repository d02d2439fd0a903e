"""Step pulse widths, pulse by pulse: the replica of the firmware beside the model.

On the AVR the compare raises the step pin and the step interrupt lowers it, so a pulse
lasts as long as that interrupt waits plus its code up to the pin write (issue 23 item
2).  This tool reads a replica run (``bench/replica/replica.py``: ``CASE.pins``, every
pin edge by CPU cycle; ``CASE.ev``, every interrupt entry ``V n`` and ``reti`` ``R``)
and puts each pulse in the situation its step interrupt met:

* ``alone``: no routine held the CPU at the rise, the interrupt entered at once;
* ``behind N``: routine ``N`` (vector number) was running at the rise with interrupts
  off; ``behind N+M`` a chain (``M`` entered before the step interrupt too);
* ``in task``: the ramp task was running but had interrupts on (the step interrupt nests);
* ``loop cli``: nothing ran, yet the step interrupt entered late - the loop held
  interrupts off (an `e` block, a ``millis()`` or position read).

It runs the model on the same input (``SimBackend(record=True)``) and, where the two
make the same number of pulses, pairs them by index and sums each situation's high time
on both sides (ticks), so the situation whose width the model gets wrong stands out::

    python3 bench/pulse_widths.py --replica /tmp/fas-replica d38 d35 e13

``--holds`` reads the replica alone: per routine, how long it holds a step interrupt
requested while it runs (from its entry to the step interrupt's, beside its own entry to
``reti``).

The replica is build e of the firmware; the ``d`` folders of the conformance data were
run in build d, whose commands land 200-336 us earlier (docs/timing-model.md, "A replica
of the firmware") - the model runs each case in its folder's build, as the corpus does.
"""

from __future__ import annotations

import argparse
import bisect
import collections
import re
import sys
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from fas.sim import SimBackend  # noqa: E402
from stepperdemo.program import make_program  # noqa: E402
from stepperdemo.scenarios.evaluate import stepper_pins  # noqa: E402

# replica pin name and step vector per (board, letter): the ATmega328P's timer 1 compares
# A/B (vectors 11, 12), the Mega's timer-1 build A/B/C (17, 18, 19)
REPLICA = {
    "atmega328p": {"A": ("B1", 11), "B": ("B2", 12)},
    "atmega2560_timer1": {"A": ("B5", 17), "B": ("B6", 18), "C": ("B7", 19)},
}
PROFILE = {"e13": "atmega2560_timer1", "e14": "atmega2560_timer1"}
TASK = {"atmega328p": 13, "atmega2560_timer1": 20}
ENTRY_SLACK = 4  # an interrupt enters within the instruction running at its request


def build_of(case: str) -> str:
    return "e" if re.fullmatch(r"e\d+", case) else "d"


def replica_edges(pins: Path, pin: str) -> Iterator[tuple[int, bool]]:
    """(cycle, rising) of every level change of ``pin`` in a replica's pins file."""
    level = 0
    with open(pins) as f:
        for line in f:
            c, p, v = line.split()
            if p != pin:
                continue
            lv = int(v)
            if lv != level:
                yield int(c), bool(lv)
            level = lv


def replica_rises(pins: Path, pin: str) -> list[int]:
    """Every rising edge of ``pin`` (cycles)."""
    return [c for c, up in replica_edges(pins, pin) if up]


def replica_pulses(pins: Path, pin: str) -> list[tuple[int, int]]:
    """(rise, fall) of every whole pulse of ``pin`` (cycles)."""
    out: list[tuple[int, int]] = []
    rise = 0
    for c, up in replica_edges(pins, pin):
        if up:
            rise = c
        else:
            out.append((rise, c))
    return out


def routines(ev: Path) -> tuple[list[int], list[tuple[int, int, int]]]:
    """(entry ticks sorted, [(entry, reti, vector)]) of every interrupt, nested ones too."""
    stack: list[tuple[int, int]] = []
    spans: list[tuple[int, int, int]] = []
    with open(ev) as f:
        for line in f:
            parts = line.split()
            if parts[1] == "V":
                stack.append((int(parts[0]), int(parts[2])))
            elif parts[1] == "R" and stack:
                a, vec = stack.pop()
                spans.append((a, int(parts[0]), vec))
    spans.sort()
    return [a for a, _, _ in spans], spans


def situation(rise: int, vec: int, task: int, starts: list[int],
              spans: list[tuple[int, int, int]]) -> str:
    """The situation of the step interrupt (vector ``vec``) of the pulse rising at ``rise``."""
    k = bisect.bisect_left(starts, rise)
    mine = None  # the step interrupt that clears this pulse: the first of vec from the rise
    for j in range(k, min(k + 12, len(spans))):
        if spans[j][2] == vec:
            mine = spans[j]
            break
    if mine is None:
        return "?"
    # routines running at the rise (entered before, returned after)
    running = [s for s in spans[max(0, k - 40):k] if s[0] < rise < s[1]]
    before = [s for s in spans[k:] if s[0] < mine[0] and s[2] != vec]
    ahead = [str(s[2]) for s in before]
    if running:
        top = max(running)  # the innermost one
        if top[2] == task and mine[0] < top[1]:
            return "in task"  # nested: the task had interrupts on
        return "behind " + "+".join([str(top[2])] + ahead)
    if mine[0] - rise <= ENTRY_SLACK:
        return "alone"
    if ahead:
        return "behind " + "+".join(ahead)
    return "loop cli"


def hold_lengths(ev: Path, pins: Path, pin: str,
                 vec: int) -> dict[int, tuple[list[int], list[int]]]:
    """How long each routine holds a step interrupt (vector ``vec``, pulses on ``pin``):
    per routine vector, (its entry-to-reti spans, and for every pulse that rose while
    it alone ran - nothing entered in between - the step interrupt's entry less the
    routine's entry).  The model's window for it is the hold, not the CPU time."""
    starts, spans = routines(ev)
    out: dict[int, tuple[list[int], list[int]]] = {}
    for a, r, v in spans:
        if v != vec:
            out.setdefault(v, ([], []))[0].append(r - a)
    for rise, _ in replica_pulses(pins, pin):
        k = bisect.bisect_left(starts, rise)
        mine = next((spans[j] for j in range(k, min(k + 12, len(spans)))
                     if spans[j][2] == vec), None)
        if mine is None:
            continue
        running = [s for s in spans[max(0, k - 40):k] if s[0] < rise < s[1]]
        between = [s for s in spans[k:] if s[0] < mine[0] and s[2] != vec]
        if len(running) == 1 and not between and running[0][2] != vec:
            top = running[0]
            out.setdefault(top[2], ([], []))[1].append(mine[0] - top[0])
    return out


def report_holds(case: str, replica: Path) -> None:
    profile = PROFILE.get(case, "atmega328p")
    print(f"## {case}: holds ({profile}; ticks from the routine's entry)")
    print("| step vector | behind vector | routine entry to reti (median) | held pulses "
          "| step entry - routine entry: median, mean |")
    print("| --- | --- | --- | --- | --- |")
    for letter, (pin, vec) in REPLICA[profile].items():
        holds = hold_lengths(replica / f"{case}.ev", replica / f"{case}.pins", pin, vec)
        for v, (durs, held) in sorted(holds.items()):
            if not held or v == TASK[profile]:  # the task nests: its pulses are no holds
                continue
            durs_s, held_s = sorted(durs), sorted(held)
            print(f"| {vec} ({letter}) | {v} | {durs_s[len(durs_s) // 2]} | {len(held)} "
                  f"| {held_s[len(held_s) // 2]}, {sum(held) / len(held):.1f} |")
    print()


def model_pulses(case: str, conf: Path, profile: str) -> dict[str, list[tuple[int, int]]]:
    backend = SimBackend(profile, record=True, build=build_of(case))
    app = make_program("demo", backend, scripted=True)
    app.run_script((conf / case / "input.txt").read_text().strip(), firmware_end=True)
    return backend_pulses(backend)


def backend_pulses(backend: SimBackend) -> dict[str, list[tuple[int, int]]]:
    """Each stepper's step pulses (rise, fall) in ticks, from a recording backend's pins."""
    rec = backend.recorder
    assert rec is not None
    out: dict[str, list[tuple[int, int]]] = {}
    for sp in stepper_pins(backend.profile):
        times, levels = rec.pin_edges(sp.step)
        pulses: list[tuple[int, int]] = []
        rise = None
        for t, lv in zip(times, levels, strict=True):
            if lv:
                rise = t
            elif rise is not None:
                pulses.append((rise, t))
                rise = None
        out[sp.letter] = pulses
    return out


BINS = ((0, "0"), (4, "1-4"), (20, "5-20"), (60, "21-60"),
        (150, "61-150"), (1 << 30, "> 150"))
BINS_NAMES = [name for _, name in BINS]


def plain_width(pulses: list[tuple[int, int]]) -> int:
    """The commonest width (ticks): a pulse whose interrupt entered at once."""
    return collections.Counter(b - a for a, b in pulses).most_common(1)[0][0] if pulses else 0


def excess_bins(pulses: list[tuple[int, int]]) -> dict[str, list[int]]:
    """Pulses and their summed ticks beyond the plain width (the commonest width), by size."""
    out = {name: [0, 0] for name in BINS_NAMES}
    if not pulses:
        return out
    plain = plain_width(pulses)
    for a, b in pulses:
        x = b - a - plain
        for top, name in BINS:
            if x <= top:
                out[name][0] += 1
                out[name][1] += max(0, x)
                break
    return out


def firmware_totals(folder: Path) -> dict[str, int]:
    text = (folder / "result.txt").read_text()
    return {m.group(1): int(m.group(2))
            for m in re.finditer(r"Step(\w):.*Total High=(\d+)us", text)}


def report(case: str, replica: Path, conf: Path) -> None:
    profile = PROFILE.get(case, "atmega328p")
    starts, spans = routines(replica / f"{case}.ev")
    model = model_pulses(case, conf, profile)
    totals = firmware_totals(conf / case)
    for letter, (pin, vec) in REPLICA[profile].items():
        rep = replica_pulses(replica / f"{case}.pins", pin)
        mod = model.get(letter, [])
        if not rep and not mod:
            continue
        fw = totals.get(letter, 0)
        rep_total = sum(b - a for a, b in rep)
        mod_total = sum(b - a for a, b in mod)
        print(f"## {case} {letter} ({profile}, model build {build_of(case)})")
        print(f"total high: firmware {fw} us, replica {rep_total / 16:.1f} us "
              f"({len(rep)} pulses), model {mod_total / 16:.1f} us ({len(mod)} pulses)")
        paired = len(rep) == len(mod)
        rows: dict[str, list[int]] = collections.defaultdict(lambda: [0, 0, 0, 0])
        for i, (a, b) in enumerate(rep):
            row = rows[situation(a, vec, TASK[profile], starts, spans)]
            row[0] += 1
            row[1] += b - a
            if paired:
                row[2] += mod[i][1] - mod[i][0]
                row[3] = max(row[3], abs((mod[i][1] - mod[i][0]) - (b - a)))
        print("| situation (replica) | pulses | replica ticks/pulse | model ticks/pulse "
              "| model - replica (us) | largest pulse difference (ticks) |")
        print("| --- | --- | --- | --- | --- | --- |")
        for name, (n, r, m, worst) in sorted(rows.items(), key=lambda kv: -kv[1][0]):
            ms = f"{m / n:.2f}" if paired else "-"
            diff = f"{(m - r) / 16:+.1f}" if paired else "-"
            print(f"| {name} | {n} | {r / n:.2f} | {ms} | {diff} | {worst if paired else '-'} |")
        print()
        print(f"plain width: replica {plain_width(rep)} ticks, model {plain_width(mod)} ticks")
        print("| beyond the plain width (ticks) | replica: pulses, ticks | model: pulses, ticks |")
        print("| --- | --- | --- |")
        br, bm = excess_bins(rep), excess_bins(mod)
        for name in BINS_NAMES:
            print(f"| {name} | {br[name][0]}, {br[name][1]} | {bm[name][0]}, {bm[name][1]} |")
        print()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--replica", type=Path, default=Path("/tmp/fas-replica"),
                    help="the replica's runs (CASE.pins, CASE.ev)")
    ap.add_argument("--conformance", type=Path, default=Path("/work/shared/conformance"))
    ap.add_argument("--holds", action="store_true",
                    help="only the replica: how long each routine holds a step interrupt")
    ap.add_argument("cases", nargs="+")
    args = ap.parse_args(argv)
    for case in args.cases:
        if args.holds:
            report_holds(case, args.replica)
        else:
            report(case, args.replica, args.conformance)
    return 0


if __name__ == "__main__":
    sys.exit(main())
