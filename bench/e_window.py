"""One `e` run's windows step by step and block by block, firmware beside model
(docs/timing-model.md, "thirty-eighth pass").

From the conformance folder's measured step times (``steps_<pin>.tsv.gz``) and blocks
(``blocked_intervals.tsv.gz``) and the model's run of the same input (build e for
e01.., with ``--set`` / ``--variant`` as in ``e_fidelity.py``):

* ``ramp``: the step period at each step index (a missed compare's interval less one
  timer wrap), firmware against model: the largest single difference and the largest
  drift of their sum.  A drift of a few ticks means the same ramp step for step (the
  stop applied at the same step); the two sides then differ only in where the wraps
  fall in time.
* per window: the step index and period at the window's first block, the steps that
  fall within the blocks' span, the compares held by a block, those missed (a wrap
  followed), the held ones by their place in the block (200-tick bins), and the runs
  of consecutive wraps.
* ``--margins``: each held compare's margin (the next compare less the block's end,
  ticks), missed or kept, in 25-tick bins, split by whether another stepper's compare
  fell in the same block.
* ``--phases SPAN STEP``: the model's run again with each window's first block 0..SPAN
  ticks later (``e_fidelity.py --phase``'s probe): per window, how many phases make each
  count of wraps, with their steps, held compares and those held in a block's first 200
  ticks, beside the firmware's.
* ``--replica PREFIX``: a replica run (``replica.py steps``'s ``PREFIX.pins`` and
  ``.ev``) in the model's column, less its lead over the firmware's first step: e.g. the
  firmware rebuilt with its input line changed by a space, to read the firmware's own
  spread of a window's count.
* ``--pitches``: per window, the blocks' pitch (one block's start to the next) by what
  fell in the pass: the pin's compares and the other steppers' (count, commonest
  pitches).

    python3 bench/e_window.py --conformance ../shared/conformance --margins --pitches e09 A 7 8
"""

from __future__ import annotations

import argparse
import bisect
import sys
from collections import Counter
from collections.abc import Sequence
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE / "replica"))

import e_fidelity as ef  # noqa: E402

TICKS_PER_US = 16
WRAP = 65536  # timer 1's period: a missed compare waits one wrap
WRAP_MIN = 60_000  # an interval this long holds a wrap
WINDOW_TICKS = round(ef.WINDOW_PERIOD_US * TICKS_PER_US)
SPAN_TICKS = round(ef.WINDOW_SPAN_US * TICKS_PER_US)
PLACE_BIN, MARGIN_BIN = 200, 25
WINDOW_GAP_US = 50_000  # a block this long after the last one starts a window (e_fidelity)
MARGIN_RANGE = (-100, 250)

Span = tuple[int, int]


def periods(rises: Sequence[int]) -> list[int]:
    """Each step's period (ticks): the interval to the next rise, less one wrap where the
    compare was missed."""
    out = []
    for a, b in zip(rises, rises[1:], strict=False):
        iv = b - a
        out.append(iv - WRAP if iv > WRAP_MIN else iv)
    return out


def ramp_diff(a: Sequence[int], b: Sequence[int]) -> tuple[int, int, int]:
    """(indices compared, the largest difference of one period, the largest drift of the
    summed periods) of two step trains, ticks.  A small largest drift means the same
    ramp step for step: the single periods may still differ by the pin's own jitter (the
    firmware's rises come 2-3 ticks early or late in pairs that cancel)."""
    pa, pb = periods(a), periods(b)
    n = min(len(pa), len(pb))
    worst = drift = total = 0
    for x, y in zip(pa[:n], pb[:n], strict=True):
        worst = max(worst, abs(x - y))
        total += y - x
        drift = max(drift, abs(total))
    return n, worst, drift


def _block_of(starts: Sequence[int], blocks: Sequence[Span], t: int) -> int | None:
    k = bisect.bisect_right(starts, t) - 1
    return k if k >= 0 and t < blocks[k][1] else None


def _count(rises: Sequence[int], a: int, b: int) -> int:
    return bisect.bisect_left(rises, b) - bisect.bisect_left(rises, a)


def window_rows(rises: Sequence[int], blocks: Sequence[Span], window: int) -> dict:
    """The window's figures for one step train (see the module's text)."""
    lo, hi = window * WINDOW_TICKS, window * WINDOW_TICKS + SPAN_TICKS
    wb = [b for b in blocks if lo <= b[0] < hi]
    out: dict = {"blocks": len(wb), "steps": 0, "held": 0, "missed": 0,
                 "place": Counter(), "runs": Counter(), "first": None}
    if not wb:
        return out
    starts = [a for a, _ in blocks]
    first = bisect.bisect_left(rises, wb[0][0])
    if first < len(rises) - 1:
        out["first"] = (first, rises[first + 1] - rises[first] if
                        rises[first + 1] - rises[first] <= WRAP_MIN else
                        rises[first + 1] - rises[first] - WRAP)
    run = 0
    for i in range(len(rises) - 1):
        c = rises[i]
        wrapped = rises[i + 1] - c > WRAP_MIN
        if lo <= c < hi:
            if wrapped:
                run += 1
            elif run:
                out["runs"][run] += 1
                run = 0
        if not wb[0][0] <= c < wb[-1][1]:
            continue
        out["steps"] += 1
        k = _block_of(starts, blocks, c)
        if k is None:
            continue
        out["held"] += 1
        out["missed"] += wrapped
        out["place"][(c - blocks[k][0]) // PLACE_BIN * PLACE_BIN] += 1
    if run:
        out["runs"][run] += 1
    return out


def margins(rises: Sequence[int], blocks: Sequence[Span], others: Sequence[Sequence[int]],
            windows: Sequence[int] | None = None) -> dict[bool, Counter]:
    """Held compares by margin bin and fate: {other stepper held in the block:
    Counter((bin, missed))}."""
    starts = [a for a, _ in blocks]
    out: dict[bool, Counter] = {False: Counter(), True: Counter()}
    for i in range(len(rises) - 1):
        c = rises[i]
        if windows is not None and c // WINDOW_TICKS not in windows:
            continue
        k = _block_of(starts, blocks, c)
        if k is None:
            continue
        iv = rises[i + 1] - c
        wrapped = iv > WRAP_MIN
        m = c + (iv - WRAP if wrapped else iv) - blocks[k][1]
        if not MARGIN_RANGE[0] <= m < MARGIN_RANGE[1]:
            continue
        other = any(_count(o, *blocks[k]) for o in others)
        out[other][(m // MARGIN_BIN * MARGIN_BIN, wrapped)] += 1
    return out


def pitches(rises: Sequence[int], blocks: Sequence[Span], others: Sequence[Sequence[int]],
            window: int) -> dict[tuple[int, int], Counter]:
    """The window's block pitches by (the pin's compares, the others') in the pass from
    one block's start to the next."""
    lo, hi = window * WINDOW_TICKS, window * WINDOW_TICKS + SPAN_TICKS
    wb = [b for b in blocks if lo <= b[0] < hi]
    out: dict[tuple[int, int], Counter] = {}
    for (a, _), (n, _) in zip(wb, wb[1:], strict=False):
        key = (_count(rises, a, n), sum(_count(o, a, n) for o in others))
        out.setdefault(key, Counter())[n - a] += 1
    return out


def tracks(conf: Path, case: str) -> tuple[dict[str, tuple[list[int], list[int]]],
                                            list[Span], list[Span]]:
    """({pin: (firmware rises, model rises)}, firmware blocks, model blocks), ticks."""
    folder = conf / case
    ours: list[Span] = []
    backend = ef.run_model((folder / "input.txt").read_text().strip(),
                           ef.PROFILE.get(case, "atmega328p"), ef.build_of(case), ours)
    out = {}
    for sp in ef.stepper_pins(backend.profile):
        path = folder / f"steps_{sp.letter}.tsv.gz"
        if path.exists():
            ref, _ = ef.read_reference_track(path)
            out[sp.letter] = ([round(t * TICKS_PER_US) for t in ref],
                              [round(t * TICKS_PER_US) for t in ef.step_times_us(backend, sp.step)])
    return out, ef.firmware_blocks(folder), ours


def phase_rows(conf: Path, case: str, pin: str, windows: Sequence[int], span: int,
               step: int) -> dict[int, list[tuple[int, int, int, int]]]:
    """The model's window over the window start's phase (each window's first block
    ``0..span`` ticks later, as ``e_fidelity.py --phase``): {window: [(missed, steps in
    the blocks' span, held, held in the block's first 200 ticks) per phase]}."""
    folder = conf / case
    text = (folder / "input.txt").read_text().strip()
    out: dict[int, list[tuple[int, int, int, int]]] = {w: [] for w in windows}
    for shift in range(0, span + 1, step):
        backend = ef.SimBackend(ef.PROFILE.get(case, "atmega328p"), record=True,
                                build=ef.build_of(case))
        m, block, last = backend.machine, backend.block_interrupts, [-(1 << 62)]
        blocks: list[Span] = []
        m.block_listeners.append(lambda a, b, blocks=blocks: blocks.append((a, b)))

        def delayed(ticks: int, m=m, block=block, last=last, shift=shift) -> None:
            if m.now - last[0] > WINDOW_GAP_US * TICKS_PER_US:
                m.consume(shift)  # the loop reaches its check later in the pass
            block(ticks)
            last[0] = m.now

        backend.block_interrupts = delayed  # type: ignore[method-assign]
        ef.make_program("demo", backend, scripted=True).run_script(text, firmware_end=True)
        sp = next(p for p in ef.stepper_pins(backend.profile) if p.letter == pin)
        rises = [round(t * TICKS_PER_US) for t in ef.step_times_us(backend, sp.step)]
        for w in windows:
            r = window_rows(rises, blocks, w)
            out[w].append((r["missed"], r["steps"], r["held"], r["place"].get(0, 0)))
    return out


REPLICA_PINS = {"A": "B1", "B": "B2"}  # the ATmega328P's OC1A / OC1B: steppers A and B


def replica_tracks(prefix: Path, firmware: dict[str, tuple[list[int], list[int]]]
                   ) -> tuple[dict[str, list[int]], list[Span]]:
    """A replica run's rises per pin and blocks (``PREFIX.pins``, ``PREFIX.ev``), less its
    lead over the firmware (its first step of A less the firmware's)."""
    from block_pulses import replica_blocks
    from pulse_widths import replica_rises

    pins, ev = prefix.with_suffix(".pins"), prefix.with_suffix(".ev")
    rises = {k: replica_rises(pins, v) for k, v in REPLICA_PINS.items() if k in firmware}
    lag = rises["A"][0] - firmware["A"][0][0]
    with open(ev) as f:
        blocks = replica_blocks(f, lag)
    return {k: [t - lag for t in v] for k, v in rises.items()}, blocks


def _bins(c: Counter, lo: int, hi: int, step: int) -> str:
    return " ".join(str(c.get(b, 0)) for b in range(lo, hi, step))


def report(conf: Path, case: str, pin: str, windows: list[int], show_margins: bool,
           show_pitches: bool, phases: tuple[int, int] | None = None,
           replica: Path | None = None) -> int:
    tr, fw_blocks, model_blocks = tracks(conf, case)
    if replica is not None:  # the replica's run in the model's place
        rr, model_blocks = replica_tracks(replica, tr)
        tr = {k: (v[0], rr[k]) for k, v in tr.items() if k in rr}
        print(f"(the model's column: the replica run {replica})")
    if pin not in tr:
        print(f"e_window: {case} has no pin {pin} (pins: {' '.join(sorted(tr))})", file=sys.stderr)
        return 2
    fr, mr = tr[pin]
    others = [v for k, v in tr.items() if k != pin]
    n, worst, drift = ramp_diff(fr, mr)
    print(f"## {case} {pin}: rises firmware {len(fr)}, model {len(mr)}")
    print(f"ramp (periods, wraps taken out): {n} compared, one period off by up to {worst} "
          f"ticks, their sum drifts by up to {drift} ticks")
    if not windows:
        windows = sorted({c // WINDOW_TICKS for c, _ in fw_blocks})
    sides = (("firmware", fr, fw_blocks, [o[0] for o in others]),
             ("model", mr, model_blocks, [o[1] for o in others]))
    print("| window | side | blocks | first step (index, period) | steps in the blocks' span "
          "| held | missed | held by place in block (0-1600, 200-tick bins) | wrap runs |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for w in windows:
        for name, rises, blocks, _ in sides:
            r = window_rows(rises, blocks, w)
            runs = " ".join(f"{k}x{v}" for k, v in sorted(r["runs"].items()))
            print(f"| {w} | {name} | {r['blocks']} | {r['first']} | {r['steps']} | {r['held']} "
                  f"| {r['missed']} | {_bins(r['place'], 0, 1600, PLACE_BIN)} | {runs} |")
    if show_margins:
        print(f"margins (next compare - block end, {MARGIN_BIN}-tick bins from "
              f"{MARGIN_RANGE[0]}): missed/kept, windows {windows}")
        for name, rises, blocks, oth in sides:
            m = margins(rises, blocks, oth, windows)
            for other in (False, True):
                cells = " ".join(f"{b}:{m[other].get((b, True), 0)}/{m[other].get((b, False), 0)}"
                                 for b in range(*MARGIN_RANGE, MARGIN_BIN))
                print(f"  {name}, other stepper {'held' if other else 'not held'}: {cells}")
    if phases:
        span, step = phases
        print(f"the model over the window start's phase (0-{span} ticks, every {step}):")
        for w, rows in phase_rows(conf, case, pin, windows, span, step).items():
            fw = window_rows(fr, fw_blocks, w)
            cells = []
            for k in sorted({r[0] for r in rows}):
                g = [r for r in rows if r[0] == k]
                n = len(g)
                cells.append(f"{k} wraps at {n} phases (steps {sum(r[1] for r in g) / n:.0f}, "
                             f"held {sum(r[2] for r in g) / n:.0f}, in the first 200 ticks "
                             f"{sum(r[3] for r in g) / n:.1f})")
            print(f"  window {w}: firmware {fw['missed']} wraps (steps {fw['steps']}, held "
                  f"{fw['held']}, in the first 200 ticks {fw['place'].get(0, 0)}); model: "
                  + "; ".join(cells))
    if show_pitches:
        for w in windows:
            print(f"pitches in window {w}: (compares of {pin}, others') count, commonest")
            for name, rises, blocks, oth in sides:
                p = pitches(rises, blocks, oth, w)
                cells = "; ".join(f"{k} {sum(c.values())} {[t for t, _ in c.most_common(3)]}"
                                  for k, c in sorted(p.items()) if sum(c.values()) > 1)
                print(f"  {name}: {cells}")
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--conformance", type=Path, default=ef.DEFAULT_CONF)
    ap.add_argument("--set", action="append", default=[], metavar="[CHIP:]FIELD=VALUE")
    ap.add_argument("--variant", action="append", default=[], choices=sorted(ef.VARIANTS))
    ap.add_argument("--margins", action="store_true")
    ap.add_argument("--pitches", action="store_true")
    ap.add_argument("--phases", type=int, nargs=2, metavar=("SPAN", "STEP"),
                    help="the model's windows over the window start's phase, 0..SPAN ticks")
    ap.add_argument("--replica", type=Path, metavar="PREFIX",
                    help="a replica run (PREFIX.pins, PREFIX.ev; ATmega328P) in the model's place, "
                         "e.g. the same firmware with the input changed")
    ap.add_argument("case")
    ap.add_argument("pin")
    ap.add_argument("windows", nargs="*", type=int)
    args = ap.parse_args(argv)
    if not (args.conformance / args.case / "input.txt").exists():
        print(f"e_window: no firmware run {args.case} in {args.conformance}", file=sys.stderr)
        return 2
    try:
        ef.set_timing(ef.variant_settings(args.variant) + args.set)
    except ValueError as exc:
        print(f"e_window: {exc}", file=sys.stderr)
        return 2
    return report(args.conformance, args.case, args.pin, args.windows, args.margins,
                  args.pitches, tuple(args.phases) if args.phases else None, args.replica)


if __name__ == "__main__":
    sys.exit(main())
