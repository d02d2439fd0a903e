"""How close the simulated `e` (100 us interrupt blocks) comes to the firmware's runs.

For every conformance folder with the `e` injection (e01..e18, d35..d38) this runs the
folder's input on the simulated chip and compares, per stepper, the pin-derived
position and pulse count with the firmware's, and per 256 ms window of `e` the number
of ~4.1 ms gaps (a step compare missed, the 16-bit timer wrapped) in both.

    python3 bench/e_fidelity.py [--conformance DIR] [--build NAME] [--windows] [CASE ...]

Acceptance (issue 23): position and pulses within max(10 steps, 0.5 %) of the
firmware's, each window's gap count within 1.  The firmware build of a folder: the
runs e01.. come from another build than the d*/test_sd_* runs (the conformance README;
``fas.sim.builds``); ``--build`` runs every case in one build.  Gaps and windows as
``stepperdemo.scenarios.evaluate.wrap_gaps`` / ``gaps_per_window`` count them (the
scenario files' ``[gaps]`` check).  ``--windows`` adds the gap start times.

``--holdout`` checks that the figures of build e are the mechanism's, not the cases':
it reads the CPU figures the `e` model rests on - the length of a blocked section and
the loop's pitch between two blocks (the most common ones: a plain pass, a pass with a
step or timer-0 interrupt, ...) - from the firmware's ``blocked_intervals.tsv.gz`` of
a training half of the runs (odd numbers) only, prints them beside the model's (its
blocked sections recorded the same way), and then reports the acceptance on the other
half (even numbers), which no figure was read from.
"""

from __future__ import annotations

import argparse
import gzip
import re
import sys
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from fas.sim import SimBackend  # noqa: E402
from stepperdemo.program import make_program  # noqa: E402
from stepperdemo.scenarios.evaluate import (  # noqa: E402
    gaps_per_window,
    pin_activity,
    position_from_pins,
    read_reference_track,
    step_times_us,
    stepper_pins,
    wrap_gaps,
)


def _default_conformance() -> Path:
    """``shared/conformance`` beside the checkout or one of its parents."""
    for folder in ROOT.parents:
        if (folder / "shared" / "conformance").is_dir():
            return folder / "shared" / "conformance"
    return ROOT / "sequences" / "reference"


DEFAULT_CONF = _default_conformance()
CASES = [f"e{i:02d}" for i in range(1, 19)] + ["d30", "d35", "d36", "d37", "d38"]
PROFILE = {"e13": "atmega2560_timer1", "e14": "atmega2560_timer1",
           "e15": "atmega32u4", "e16": "atmega32u4"}


def build_of(case: str) -> str:
    """The firmware build of a conformance folder (the README of the data)."""
    return "e" if re.fullmatch(r"e\d+", case) else "d"


TICKS_PER_US = 16
TRAIN = [f"e{i:02d}" for i in range(1, 19, 2)]  # the hold-out split: odd numbers
TEST = [f"e{i:02d}" for i in range(2, 19, 2)]
PITCH_MAX_TICKS = 200 * TICKS_PER_US  # a pitch between two blocks of one window


def run_model(inp: str, profile: str, build: str,
              blocks: list[tuple[int, int]] | None = None) -> SimBackend:
    backend = SimBackend(profile, record=True, build=build)
    if blocks is not None:  # record the model's blocked sections (start, end ticks)
        backend.machine.block_listeners.append(lambda a, b: blocks.append((a, b)))
    app = make_program("demo", backend, scripted=True)
    app.run_script(inp, firmware_end=True)
    return backend


def block_figures(blocks: list[tuple[int, int]], top: int = 4) -> tuple[list, list]:
    """(most common block lengths, most common pitches between blocks), in ticks, each
    as (ticks, share of all)."""
    if not blocks:
        return [], []
    lengths = Counter(b - a for a, b in blocks)
    pitches = Counter(blocks[i + 1][0] - blocks[i][1] for i in range(len(blocks) - 1)
                      if blocks[i + 1][0] - blocks[i][1] < PITCH_MAX_TICKS)
    n_l, n_p = sum(lengths.values()), max(1, sum(pitches.values()))
    return ([(t, c / n_l) for t, c in lengths.most_common(1)],
            [(t, c / n_p) for t, c in pitches.most_common(top)])


def firmware_blocks(folder: Path) -> list[tuple[int, int]]:
    """The firmware's blocked sections (measured), in ticks."""
    path = folder / "blocked_intervals.tsv.gz"
    if not path.exists():
        return []
    out = []
    with gzip.open(path, "rt") as f:
        for line in f:
            if line[:1].isdigit():
                a, b = map(float, line.split()[:2])
                out.append((round(a * TICKS_PER_US), round(b * TICKS_PER_US)))
    return out


def holdout(conf: Path) -> int:
    """Figures read from the training half against the model's; acceptance on the rest."""
    print("Figures of the `e` model, read from the firmware's blocked sections of the "
          f"training runs ({' '.join(TRAIN)}) only, beside the model's (ticks, share):")
    print("| run | board | block fw | block model | pitches fw | pitches model |")
    print("| --- " * 6 + "|")
    fmt = lambda figs: " ".join(f"{t} ({share:.0%})" for t, share in figs)  # noqa: E731
    for case in TRAIN:
        folder = conf / case
        fw = firmware_blocks(folder)
        if not fw:
            continue
        ours: list[tuple[int, int]] = []
        run_model((folder / "input.txt").read_text().strip(), PROFILE.get(case, "atmega328p"),
                  build_of(case), ours)
        (bl_fw, p_fw), (bl_m, p_m) = block_figures(fw), block_figures(ours)
        print(f"| {case} | {PROFILE.get(case, 'atmega328p')} | {fmt(bl_fw)} | {fmt(bl_m)} "
              f"| {fmt(p_fw)} | {fmt(p_m)} |")
    print()
    result = {}
    for name, cases in (("training", TRAIN), ("held out", TEST)):
        rows = [r for case in cases for r in case_rows(conf, case)]
        ok = sum(verdict(r)[3] for r in rows)
        pos = sum(abs(r["pos"] - r["pos_fw"]) <= max(10.0, abs(r["pos_fw"]) * 0.005)
                  for r in rows)
        result[name] = (ok, pos, len(rows))
        print(f"{name} ({' '.join(cases)}): {ok} of {len(rows)} rows within acceptance "
              f"(position and pulses within max(10 steps, 0.5 %) and every window's gaps "
              f"within 1); positions alone: {pos} of {len(rows)}")
        for r in rows:
            off, bound, wdiff, good = verdict(r)
            print(f"    {r['case']} {r['letter']}: {r['pos_fw']} / {r['pos']} ({off:+d}, bound "
                  f"{bound:.0f}), windows {' '.join(map(str, r['win_fw']))} / "
                  f"{' '.join(map(str, r['win']))}{'' if good else '  **'}")
    return 0


def case_rows(conf: Path, case: str, build: str | None = None) -> list[dict]:
    """One row per stepper that moved in the firmware run: figures of both."""
    folder = conf / case
    inp = (folder / "input.txt").read_text().strip()
    profile = PROFILE.get(case, "atmega328p")
    t0 = time.perf_counter()
    backend = run_model(inp, profile, build or build_of(case))
    wall = time.perf_counter() - t0
    rows = []
    for sp in stepper_pins(backend.profile):
        ref_path = folder / f"steps_{sp.letter}.tsv.gz"
        if not ref_path.exists():
            continue
        ref, dirs = read_reference_track(ref_path)
        ours = step_times_us(backend, sp.step)
        g_fw, g_m = wrap_gaps(ref), wrap_gaps(ours)
        w_fw, w_m = gaps_per_window(g_fw), gaps_per_window(g_m)
        keys = sorted(set(w_fw) | set(w_m))
        rows.append(dict(
            case=case, arch=profile, letter=sp.letter, input=inp,
            pos_fw=sum(1 if d else -1 for d in dirs),
            pos=position_from_pins(backend, sp.step, sp.direction),
            pulses_fw=len(ref), pulses=pin_activity(backend, sp.step).rises,
            gaps_fw=len(g_fw), gaps=len(g_m),
            win_fw=[w_fw.get(k, 0) for k in keys], win=[w_m.get(k, 0) for k in keys],
            gap_times_fw=g_fw, gap_times=g_m, wall=wall))
    return rows


def verdict(r: dict) -> tuple[int, float, int, bool]:
    """(position off, bound, largest window difference, within acceptance)."""
    off = r["pos"] - r["pos_fw"]
    bound = max(10.0, abs(r["pos_fw"]) * 0.005)
    wdiff = max((abs(a - b) for a, b in zip(r["win_fw"], r["win"], strict=True)), default=0)
    ok = abs(off) <= bound and abs(r["pulses"] - r["pulses_fw"]) <= bound and wdiff <= 1
    return off, bound, wdiff, ok


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cases", nargs="*")
    ap.add_argument("--conformance", default=str(DEFAULT_CONF))
    ap.add_argument("--build", help="firmware build for every case (default: e for e01.., "
                    "d for the others)")
    ap.add_argument("--windows", action="store_true", help="print the gap start times")
    ap.add_argument("--holdout", action="store_true",
                    help="figures read from the odd-numbered e-runs only, beside the "
                    "model's; acceptance on the even-numbered ones")
    args = ap.parse_args(argv)
    conf = Path(args.conformance)
    if args.holdout:
        return holdout(conf)
    print("| case | arch | input | pin | pos fw | pos model | off | bound | pulses fw/model "
          "| gaps fw/model | per window fw | per window model | max win diff |")
    print("| --- " * 13 + "|")
    bad = 0
    for case in args.cases or CASES:
        for r in case_rows(conf, case, args.build):
            off, bound, wdiff, ok = verdict(r)
            bad += not ok
            print(f"| {r['case']} | {r['arch']} | `{r['input']}` | {r['letter']} "
                  f"| {r['pos_fw']} | {r['pos']} | {off:+d} | {bound:.0f} "
                  f"| {r['pulses_fw']}/{r['pulses']} | {r['gaps_fw']}/{r['gaps']} "
                  f"| {' '.join(map(str, r['win_fw']))} | {' '.join(map(str, r['win']))} "
                  f"| {wdiff}{'' if ok else ' **'} |")
            if args.windows:
                for name, gaps in (("fw", r["gap_times_fw"]), ("model", r["gap_times"])):
                    print(f"    gaps {name:5s} " + " ".join(f"{g / 1000:.2f}" for g in gaps))
    print("all within acceptance" if not bad else f"** = outside acceptance ({bad} rows)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
