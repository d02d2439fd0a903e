"""How close the simulated `e` (100 us interrupt blocks) comes to the firmware's runs.

For every conformance folder with the `e` injection (e01..e18, d35..d38) this runs the
folder's input on the simulated chip and compares, per stepper, the pin-derived
position and pulse count with the firmware's, and per 256 ms window of `e` the number
of ~4.1 ms gaps (a step compare missed, the 16-bit timer wrapped) in both.

    python3 bench/e_fidelity.py [--conformance DIR] [--build NAME] [--windows] [CASE ...]
    python3 bench/e_fidelity.py --holdout | --pulses | --starts | --phase [CASE ...]

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

``--pulses`` splits each step pin's pulse-high total (``result.txt``'s Total High, the
model's pins) into the pulses held by a blocked section - a compare inside a block keeps
its pin high to the block's end; their extra time is summed from the blocks and the
step rises of each side - and the rest, whose mean per pulse (ticks) is the plain pulse
width plus what the other interrupts add: the figure the step interrupt's latency
(``SimTiming.isr_latency_ticks``) is read from, apart from where the blocks fall.

``--starts`` measures where each `e` window begins: its first block after the
timer-0 overflow that makes ``millis()`` a multiple of 256 (the model's overflow tick),
firmware beside model, and the phase of timer 0 itself, read from the pitches between
two blocks that carry timer 0's interrupt (a pitch one ``millis_isr_ticks`` longer than
one of the run's common pitches: the overflow lies between the two block starts).

``--phase`` runs each case again with the first block of every window moved later by
0, 25, ... ``PHASE_SPAN_TICKS`` (the firmware's window starts scatter over that much,
``--starts``) and prints, per window, the range of gap counts the model makes and
whether the firmware's count lies in it: how far a window's count is set by the phase
of the loop's pass at the window's start, which the model does not keep (it skips idle
passes and takes up the loop at the overflow).  ``--start-shift T1,T2,...`` moves the
first step of the n-th queue start a ramp task makes by Tn ticks (negative: earlier) in
those runs: what a first step the model places off the firmware's does to the windows.
"""

from __future__ import annotations

import argparse
import bisect
import gzip
import re
import sys
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from fas.sim import SimBackend  # noqa: E402
from fas.sim.channel import SimChannel  # noqa: E402
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


TASK_PITCH = (1700, 3200)  # a pitch across a ramp task that plans no command (ticks)


def task_pitches(blocks: list[tuple[int, int]], top: int = 2) -> list[tuple[int, float]]:
    """The most common pitches between two blocks across a ramp task that plans no
    command (timer 1's overflow every 4.096 ms: the loop's pass plus the task), each as
    (ticks, share of those)."""
    c = Counter(blocks[i + 1][0] - blocks[i][1] for i in range(len(blocks) - 1)
                if TASK_PITCH[0] <= blocks[i + 1][0] - blocks[i][1] < TASK_PITCH[1])
    n = max(1, sum(c.values()))
    return [(t, k / n) for t, k in c.most_common(top)]


def holdout(conf: Path) -> int:
    """Figures read from the training half against the model's; acceptance on the rest."""
    print("Figures of the `e` model, read from the firmware's blocked sections of the "
          f"training runs ({' '.join(TRAIN)}) only, beside the model's (ticks, share):")
    print("| run | board | block fw | block model | pitches fw | pitches model "
          "| across a ramp task fw | model |")
    print("| --- " * 8 + "|")
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
              f"| {fmt(p_fw)} | {fmt(p_m)} | {fmt(task_pitches(fw))} "
              f"| {fmt(task_pitches(ours))} |")
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


def held_extra(rises: list[int], blocks: list[tuple[int, int]]) -> tuple[int, int]:
    """(pulses whose rise falls inside a blocked section, their summed ticks from the
    rise to the block's end): what the blocks add to the pulses' high time."""
    starts = [a for a, _ in blocks]
    n = extra = 0
    for c in rises:
        k = bisect.bisect_right(starts, c) - 1
        if k >= 0 and c < blocks[k][1]:
            n += 1
            extra += blocks[k][1] - c
    return n, extra


def firmware_high_totals(folder: Path) -> dict[str, int]:
    """Total High (us) per step pin letter, from the firmware run's ``result.txt``."""
    text = (folder / "result.txt").read_text()
    return {m.group(1): int(m.group(2))
            for m in re.finditer(r"Step(\w):.*Total High=(\d+)us", text)}


def pulses(conf: Path, cases: list[str]) -> int:
    """Pulse-high totals split into the blocks' part and the plain pulses' mean."""
    print("| case | pin | total high fw / model (us) | held pulses fw / model | their extra "
          "fw / model (us) | rest per pulse fw / model (ticks) |")
    print("| --- " * 6 + "|")
    for case in cases:
        folder = conf / case
        ours: list[tuple[int, int]] = []
        backend = run_model((folder / "input.txt").read_text().strip(),
                            PROFILE.get(case, "atmega328p"), build_of(case), ours)
        fw_blocks = firmware_blocks(folder)
        totals = firmware_high_totals(folder)
        for sp in stepper_pins(backend.profile):
            ref_path = folder / f"steps_{sp.letter}.tsv.gz"
            if not ref_path.exists() or sp.letter not in totals:
                continue
            ref, _ = read_reference_track(ref_path)
            fw_rises = [round(t * TICKS_PER_US) for t in ref]
            our_rises = [round(t * TICKS_PER_US) for t in step_times_us(backend, sp.step)]
            act = pin_activity(backend, sp.step)
            n_fw, x_fw = held_extra(fw_rises, fw_blocks)
            n_m, x_m = held_extra(our_rises, ours)
            rest_fw = (totals[sp.letter] * TICKS_PER_US - x_fw) / max(1, len(fw_rises))
            rest_m = (act.high_total_us * TICKS_PER_US - x_m) / max(1, act.rises)
            print(f"| {case} | {sp.letter} | {totals[sp.letter]} / {act.high_total_us:.0f} "
                  f"| {n_fw} / {n_m} | {x_fw / TICKS_PER_US:.0f} / {x_m / TICKS_PER_US:.0f} "
                  f"| {rest_fw:.2f} / {rest_m:.2f} |")
    return 0


def window_firsts(blocks: list[tuple[int, int]]) -> list[int]:
    """The first block of each `e` window (ticks): a block after 50 ms without one."""
    out = []
    for i, (a, _) in enumerate(blocks):
        if i == 0 or a - blocks[i - 1][1] > 50_000 * TICKS_PER_US:
            out.append(a)
    return out


def timer0_phase(blocks: list[tuple[int, int]], isr: int, period: int) -> tuple[int, int, int]:
    """(pitches carrying timer 0's interrupt, lowest, highest phase mod ``period``):
    the ticks at which every such pitch's stretch - from its block's start to the next
    block's start - holds the overflow."""
    pitches = [blocks[i + 1][0] - blocks[i][1] for i in range(len(blocks) - 1)]
    common = {p for p, _ in Counter(p for p in pitches if p < 1000).most_common(3)}
    hits = [0] * period
    n = 0
    for i, p in enumerate(pitches):
        if p in common or not any(p - isr + k in common for k in (-1, 0, 1)):
            continue
        n += 1
        for t in range(blocks[i][0], blocks[i + 1][0]):
            hits[t % period] += 1
    top = max(hits)
    where = [k for k in range(period) if hits[k] == top]
    return n, where[0], where[-1]


def starts(conf: Path, cases: list[str]) -> int:
    """Window starts after the model's timer-0 overflow, and timer 0's phase."""
    print("| case | board | first block after the overflow, fw (ticks) | model | timer 0's "
          "overflow mod 16384: fw range / model |")
    print("| --- " * 5 + "|")
    for case in cases:
        folder = conf / case
        fw = firmware_blocks(folder)
        if not fw:
            continue
        ours: list[tuple[int, int]] = []
        backend = run_model((folder / "input.txt").read_text().strip(),
                            PROFILE.get(case, "atmega328p"), build_of(case), ours)
        m = backend.machine
        ov = m.timing.millis_overflow_ticks
        rel: tuple[list[int], list[int]] = ([], [])
        for side, blocks in zip(rel, (fw, ours), strict=True):
            for a in window_firsts(blocks):
                k = round(a / (256_000 * TICKS_PER_US))
                side.append(a - backend.tick_at_millis(256 * k))
        _, lo, hi = timer0_phase(fw, m.timing.millis_isr_ticks, ov)
        phase = m.tick_at_millis(1) % ov
        print(f"| {case} | {PROFILE.get(case, 'atmega328p')} | {' '.join(map(str, rel[0]))} "
              f"| {' '.join(map(str, rel[1]))} | {lo}-{hi} / {phase} |")
    return 0


PHASE_SPAN_TICKS = 500  # the firmware's window starts scatter over ~530 ticks (--starts)
PHASE_STEP_TICKS = 25


def phase(conf: Path, cases: list[str], start_shifts: tuple[int, ...] = ()) -> int:
    """Per window: the gap counts over the window start's phase, and the firmware's
    (``start_shifts``: ticks added before the n-th queue start of a ramp task)."""
    plain_start = SimChannel.start
    made: dict[int, int] = {}

    def shifted_start(ch: SimChannel) -> None:
        q = ch.q
        if ch.m.in_task and not ch.running and q.read_idx != q.next_write_idx:
            n = made.get(id(ch.m), 0)
            made[id(ch.m)] = n + 1
            if n < len(start_shifts):
                ch.m.task_offset += start_shifts[n]
        plain_start(ch)

    SimChannel.start = shifted_start  # type: ignore[method-assign]
    try:
        return _phase(conf, cases)
    finally:
        SimChannel.start = plain_start  # type: ignore[method-assign]


def _phase(conf: Path, cases: list[str]) -> int:
    for case in cases:
        folder = conf / case
        inp = (folder / "input.txt").read_text().strip()
        profile = PROFILE.get(case, "atmega328p")
        counts: dict[str, dict[int, set[int]]] = {}
        fw_win: dict[str, dict[int, int]] = {}
        for shift in range(0, PHASE_SPAN_TICKS + 1, PHASE_STEP_TICKS):
            backend = SimBackend(profile, record=True, build=build_of(case))
            m = backend.machine
            block = backend.block_interrupts
            last = [-(1 << 62)]

            def delayed(ticks: int, m=m, block=block, last=last, shift=shift) -> None:
                if m.now - last[0] > 50_000 * TICKS_PER_US:
                    m.consume(shift)  # the loop reaches its check later in the pass
                block(ticks)
                last[0] = m.now

            backend.block_interrupts = delayed  # type: ignore[method-assign]
            make_program("demo", backend, scripted=True).run_script(inp, firmware_end=True)
            for sp in stepper_pins(backend.profile):
                ref_path = folder / f"steps_{sp.letter}.tsv.gz"
                if not ref_path.exists():
                    continue
                if sp.letter not in fw_win:
                    fw_win[sp.letter] = gaps_per_window(wrap_gaps(read_reference_track(
                        ref_path)[0]))
                w = gaps_per_window(wrap_gaps(step_times_us(backend, sp.step)))
                per = counts.setdefault(sp.letter, {})
                for k in set(w) | set(fw_win[sp.letter]) | set(per):
                    per.setdefault(k, set()).add(w.get(k, 0))
        for letter, per in counts.items():
            cells = []
            for k in sorted(per):
                lo, hi, f = min(per[k]), max(per[k]), fw_win[letter].get(k, 0)
                cells.append(f"{f} in {lo}-{hi}" if lo <= f <= hi else f"{f} NOT in {lo}-{hi}")
            print(f"{case} {letter}: firmware's count per window against the model's over "
                  f"0-{PHASE_SPAN_TICKS} ticks: {'; '.join(cells)}")
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
    ap.add_argument("--pulses", action="store_true",
                    help="pulse-high totals: the part the blocks add and the plain "
                    "pulses' mean per pulse, firmware beside model")
    ap.add_argument("--starts", action="store_true",
                    help="each window's first block after the timer-0 overflow, firmware "
                    "beside model, and timer 0's phase read from the blocks")
    ap.add_argument("--phase", action="store_true",
                    help="gap counts per window over the phase of the window's start")
    ap.add_argument("--start-shift", default="",
                    help="with --phase: ticks added to the first step of the 1st, 2nd, "
                    "... queue start of a ramp task, comma-separated")
    args = ap.parse_args(argv)
    conf = Path(args.conformance)
    missing = [c for c in (args.cases or CASES) if not (conf / c / "input.txt").is_file()]
    if missing:
        print(f"e_fidelity: no firmware run {', '.join(missing)} in {conf} "
              "(give the conformance folder with --conformance DIR)", file=sys.stderr)
        return 2
    e_cases = args.cases or [c for c in CASES if c.startswith("e")]
    if args.starts:
        return starts(conf, e_cases)
    if args.phase:
        shifts = tuple(int(x) for x in args.start_shift.split(",") if x.strip())
        return phase(conf, e_cases, shifts)
    if args.pulses:
        return pulses(conf, args.cases or [c for c in CASES if c.startswith("e")])
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
