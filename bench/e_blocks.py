"""Where the `e` blocks fall: the model's 100 us blocks beside the firmware's, per window.

    python3 bench/e_blocks.py --conformance DIR pitches CASE [WINDOW ...]
    python3 bench/e_blocks.py --conformance DIR threshold CASE [CASE ...]
    python3 bench/e_blocks.py --conformance DIR ramp CASE
    python3 bench/e_blocks.py --conformance DIR rises CASE FROM_MS TO_MS

``pitches`` prints, for each `e` window (the 256 ms period k of ``millis()``), the
firmware's and the model's blocks: how many, the first one's tick after the period's
start, and the histogram of the pitches between two blocks (from a block's end to the
next one's start, ticks: the loop's pass plus the interrupts inside it), side by side.
A pass figure that is off shows as a pitch one or two ticks apart on every block.

``threshold`` takes every step compare that falls inside a block (its pin rises there)
and whose next step is a fast one, and its margin: the next compare (the next rise, less
one wrap of 65 536 ticks when a ~4.1 ms gap follows) less the block's end plus 91 ticks
(the model's rule: the next compare is missed when it lies at or before the write of
the step interrupt entered at the block's end, 1 + 61 + 29 ticks after it).  Per board
and count of higher-priority channels whose compares fall in the same block, it prints
the largest margin that gave a gap and the smallest that gave none, firmware and model:
whether the miss rule or the placement of the blocks differs.

``ramp`` sets each stepper's steps beside each other by the steps still to come (its
ramp is the library's on both sides, so a step with as many steps left has the same
period): when each side reaches 8 000 ... 10 steps before its end, and the model's
lead or lag in ms.  A constant lag is a command planned a task apart (the stop found
the queue a command shorter or longer); a jump of ~4.1 ms is a window with one gap more.

``rises`` prints the blocks and every step rise between two times (ms), firmware and
model one after the other, each rise with its distance to the same stepper's rise
before (a wrap shows as ~65 536 + the period), each block with its length.
"""

from __future__ import annotations

import argparse
import bisect
import sys
from collections import Counter, defaultdict
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "bench"))
sys.path.insert(0, str(ROOT))

import e_fidelity as ef  # noqa: E402

TICKS_PER_US = 16
PERIOD_TICKS = 256_000 * TICKS_PER_US  # one period of millis() & 0xff
WRAP_TICKS = 65_536
WRITE_TICKS = 1 + 61 + 29  # block end -> the step interrupt's compare write (model)
FAST_TICKS = 3_000  # a step period counted here (faster than ~5.3 kHz)


def _run(conf: Path, case: str):
    folder = conf / case
    inp = (folder / "input.txt").read_text().strip()
    blocks: list[tuple[int, int]] = []
    backend = ef.run_model(inp, ef.PROFILE.get(case, "atmega328p"), ef.build_of(case), blocks)
    return folder, backend, ef.firmware_blocks(folder), blocks


def pitches(conf: Path, case: str, windows: list[int]) -> None:
    _, _, fw, model = _run(conf, case)
    ks = windows or sorted({a // PERIOD_TICKS for a, _ in fw + model})
    for k in ks:
        hist, heads = [], []
        for bl in (fw, model):
            b = [x for x in bl if x[0] // PERIOD_TICKS == k]
            hist.append(Counter(b[i + 1][0] - b[i][1] for i in range(len(b) - 1)))
            heads.append(f"{len(b)} blocks, first at {b[0][0] - k * PERIOD_TICKS if b else '-'}, "
                         f"pitches sum {sum(p * n for p, n in hist[-1].items())}")
        print(f"{case} window {k}: firmware {heads[0]}; model {heads[1]}")
        keys = sorted(set(hist[0]) | set(hist[1]))
        common = [f"{p}:{hist[0][p]}/{hist[1][p]}" for p in keys if hist[0][p] + hist[1][p] >= 3]
        rare = [f"{p}:{hist[0][p]}/{hist[1][p]}" for p in keys if hist[0][p] + hist[1][p] < 3]
        print("  pitch:firmware/model  " + "  ".join(common))
        if rare:
            print("  rare  " + " ".join(rare))


def _held(rises: list[int], blocks: list[tuple[int, int]], higher: list[list[int]]):
    """(margin, gap, higher-priority compares in the block) per compare inside a block."""
    starts = [a for a, _ in blocks]
    for i in range(1, len(rises) - 1):
        s = rises[i]
        j = bisect.bisect_right(starts, s) - 1
        if j < 0 or not blocks[j][0] <= s < blocks[j][1]:
            continue
        a, b = blocks[j]
        d = rises[i + 1] - s
        if d >= 2 * WRAP_TICKS:
            continue
        gap = d > WRAP_TICKS - FAST_TICKS
        nxt = rises[i + 1] - WRAP_TICKS if gap else rises[i + 1]
        if not 0 < nxt - s <= FAST_TICKS:
            continue
        others = 0
        for o in higher:
            k = bisect.bisect_left(o, a)
            others += k < len(o) and o[k] < b
        yield nxt - (b + WRITE_TICKS), gap, others


def threshold(conf: Path, cases: list[str]) -> None:
    stats: dict[str, dict] = {"firmware": defaultdict(list), "model": defaultdict(list)}
    for case in cases:
        folder, backend, fw, model = _run(conf, case)
        tracks = _tracks(folder, backend)
        board = ef.PROFILE.get(case, "atmega328p")
        for side, bl in (("firmware", fw), ("model", model)):
            for letter, tr in tracks.items():
                higher = [tracks[o][side] for o in tracks if o < letter]
                for margin, gap, others in _held(tr[side], bl, higher):
                    stats[side][(board, others)].append((margin, gap))
    print("| side | board | higher-priority compares in the block | held compares | gaps | "
          "largest margin with a gap | smallest without | gaps at margin > 0 | none at <= 0 |")
    print("| --- " * 9 + "|")
    for side, by in stats.items():
        for (board, others), v in sorted(by.items()):
            g = [m for m, gap in v if gap]
            n = [m for m, gap in v if not gap]
            print(f"| {side} | {board} | {others} | {len(v)} | {len(g)} | "
                  f"{max(g) if g else '-'} | {min(n) if n else '-'} | "
                  f"{sum(m > 0 for m in g)} | {sum(m <= 0 for m in n)} |")


def _tracks(folder: Path, backend) -> dict[str, dict[str, list[int]]]:
    """Step rises (ticks) per stepper letter, firmware and model."""
    out = {}
    for sp in ef.stepper_pins(backend.profile):
        path = folder / f"steps_{sp.letter}.tsv.gz"
        if path.exists():
            ref, _ = ef.read_reference_track(path)
            out[sp.letter] = {
                "firmware": [round(t * TICKS_PER_US) for t in ref],
                "model": [round(t * TICKS_PER_US) for t in ef.step_times_us(backend, sp.step)]}
    return out


REMAINING = (8000, 7000, 6000, 5000, 4000, 3000, 2000, 1000, 500, 100, 10)


def ramp(conf: Path, case: str) -> None:
    folder, backend, _, _ = _run(conf, case)
    for letter, tr in _tracks(folder, backend).items():
        fw, md = tr["firmware"], tr["model"]
        print(f"{case} {letter}: {len(fw)} steps firmware, {len(md)} model")
        print("| steps left | firmware (ms) | model (ms) | model - firmware (ms) | period |")
        print("| --- | --- | --- | --- | --- |")
        for left in REMAINING:
            if left >= min(len(fw), len(md)) - 1:
                continue
            i, j = len(fw) - 1 - left, len(md) - 1 - left
            print(f"| {left} | {fw[i] / 16_000:.3f} | {md[j] / 16_000:.3f} | "
                  f"{(md[j] - fw[i]) / 16_000:+.3f} | {fw[i + 1] - fw[i]} / {md[j + 1] - md[j]} |")


def rises(conf: Path, case: str, lo_ms: float, hi_ms: float) -> None:
    folder, backend, fw_blocks, md_blocks = _run(conf, case)
    tracks = _tracks(folder, backend)
    lo, hi = round(lo_ms * 16_000), round(hi_ms * 16_000)
    for side, blocks in (("firmware", fw_blocks), ("model", md_blocks)):
        ev = [(a, f"block [{b - a}") for a, b in blocks] + [(b, "block ]") for _, b in blocks]
        for letter, tr in tracks.items():
            r = tr[side]
            ev += [(t, f"{letter} {t - r[i - 1] if i else ''}") for i, t in enumerate(r)]
        print(f"== {side}")
        for t, what in sorted(ev):
            if lo <= t < hi:
                print(f"{t:>11} {t / 16_000:10.4f}  {what}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--conformance", default=str(ef.DEFAULT_CONF))
    ap.add_argument("what", choices=("pitches", "threshold", "ramp", "rises"))
    ap.add_argument("case")
    ap.add_argument("more", nargs="*", help="pitches: window numbers; threshold: more cases; "
                    "rises: from and to (ms)")
    args = ap.parse_args(argv)
    conf = Path(args.conformance)
    for case in [args.case] + (args.more if args.what == "threshold" else []):
        if not (conf / case / "input.txt").is_file():
            print(f"e_blocks: no firmware run {case} in {conf} "
                  "(give the conformance folder with --conformance DIR)", file=sys.stderr)
            return 2
    if args.what == "rises" and len(args.more) != 2:
        print("e_blocks: rises CASE FROM_MS TO_MS", file=sys.stderr)
        return 2
    if args.what == "pitches":
        pitches(conf, args.case, [int(w) for w in args.more])
    elif args.what == "ramp":
        ramp(conf, args.case)
    elif args.what == "rises":
        rises(conf, args.case, float(args.more[0]), float(args.more[1]))
    else:
        threshold(conf, [args.case, *args.more])
    return 0


if __name__ == "__main__":
    sys.exit(main())
