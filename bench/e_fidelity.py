"""How close the simulated `e` (100 us interrupt blocks) comes to the firmware's runs.

For every conformance folder with the `e` injection (e01..e18, d35..d38) this runs the
folder's input on the simulated chip and compares, per stepper, the pin-derived
position and pulse count with the firmware's, and per 64 ms window of `e` the number of
~4.1 ms gaps (a step compare missed, the 16-bit timer wrapped) in both.

    python3 bench/e_fidelity.py [--conformance DIR] [--windows] [CASE ...]

A gap is an interval between two rising step edges of 4000 us or more that comes
between intervals of less than 2000 us (fast motion; the slow start of a ramp is no
gap).  A gap belongs to the window in which its first edge lies (window from its
first block to its last, +- 1 ms).
"""

from __future__ import annotations

import argparse
import bisect
import gzip
import re
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from fas.sim import SimBackend  # noqa: E402
from stepperdemo.program import make_program  # noqa: E402
from stepperdemo.scenarios.evaluate import (  # noqa: E402
    pin_activity,
    position_from_pins,
    read_reference_track,
    step_times_us,
    stepper_pins,
)


def _default_conformance() -> Path:
    """``shared/conformance`` beside the checkout or one of its parents."""
    for folder in ROOT.parents:
        if (folder / "shared" / "conformance").is_dir():
            return folder / "shared" / "conformance"
    return ROOT / "sequences" / "reference"


DEFAULT_CONF = _default_conformance()
CASES = [f"e{i:02d}" for i in range(1, 19)] + ["d35", "d36", "d37", "d38"]
PROFILE = {"e13": "atmega2560_timer1", "e14": "atmega2560_timer1",
           "e15": "atmega32u4", "e16": "atmega32u4"}
BUILD: str | None = None  # --build: one build for every case
GAP_US = 4000.0
FAST_US = 2000.0


def gaps(times: list[float]) -> list[float]:
    """Start times of the ~4.1 ms gaps between fast steps."""
    out = []
    for i in range(1, len(times) - 1):
        d = times[i] - times[i - 1]
        if d < GAP_US:
            continue
        # nearest non-gap intervals on both sides
        j = i - 1
        while j >= 1 and times[j] - times[j - 1] >= GAP_US:
            j -= 1
        k = i + 1
        while k < len(times) and times[k] - times[k - 1] >= GAP_US:
            k += 1
        before = times[j] - times[j - 1] if j >= 1 else None
        after = times[k] - times[k - 1] if k < len(times) else None
        if (before is not None and before < FAST_US) or (after is not None and after < FAST_US):
            out.append(times[i - 1])
    return out


def per_window(gap_starts: list[float], windows: list[tuple[float, float]]) -> list[int]:
    counts = []
    for a, b in windows:
        lo = bisect.bisect_left(gap_starts, a - 1000)
        hi = bisect.bisect_right(gap_starts, b + 1000)
        counts.append(hi - lo)
    return counts


def read_windows(folder: Path) -> list[tuple[float, float]]:
    path = folder / "blocked_windows.tsv"
    if not path.exists():
        return []
    out = []
    for line in path.read_text().splitlines()[1:]:
        parts = line.split()
        out.append((float(parts[0]), float(parts[1])))
    return out


def read_blocks(folder: Path) -> list[tuple[float, float]]:
    path = folder / "blocked_intervals.tsv.gz"
    if not path.exists():
        return []
    with gzip.open(path, "rt") as fh:
        return [(float(a), float(b)) for a, b in (ln.split() for ln in fh if ln.strip())]


WINDOW_PERIOD_US = 256000.0  # millis() & 0xff: the window of `e` recurs every 256 ms


def windows_of(blocks: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Group blocks into windows: one per period of millis() & 0xff (blocks in the same
    256 ms period belong together, even where a long print interrupts them)."""
    out: dict[int, list[float]] = {}
    for a, b in blocks:
        k = int(a // WINDOW_PERIOD_US)
        if k in out:
            out[k][1] = b
        else:
            out[k] = [a, b]
    return [(a, b) for a, b in out.values()]


def keyed(windows: list[tuple[float, float]], counts: list[int]) -> dict[int, int]:
    return {int(a // WINDOW_PERIOD_US): n for (a, _), n in zip(windows, counts, strict=False)}


def build_of(case: str) -> str:
    """The firmware build of a conformance folder: e01.. come from another build than
    the d*/test_sd_* runs (the conformance README; fas.sim.builds)."""
    return "e" if re.fullmatch(r"e\d+", case) else "d"


def run_model(inp: str, profile: str, build: str | None = None):
    backend = SimBackend(profile, record=True, build=build)
    blocks: list[tuple[float, float]] = []
    tpu = backend.profile.ticks_per_us
    backend.machine.block_listeners.append(lambda s, e: blocks.append((s / tpu, e / tpu)))
    app = make_program("demo", backend, scripted=True)
    app.run_script(inp, firmware_end=True)
    return backend, blocks


def case_rows(conf: Path, case: str, show_windows: bool) -> list[dict]:
    folder = conf / case
    inp = (folder / "input.txt").read_text().strip()
    profile = PROFILE.get(case, "atmega328p")
    t0 = time.perf_counter()
    backend, model_blocks = run_model(inp, profile, BUILD or build_of(case))
    wall = time.perf_counter() - t0
    fw_windows = read_windows(folder)
    model_windows = windows_of(model_blocks)
    rows = []
    for sp in stepper_pins(backend.profile):
        ref_path = folder / f"steps_{sp.letter}.tsv.gz"
        if not ref_path.exists():
            continue
        ref, dirs = read_reference_track(ref_path)
        pos_fw = sum(1 if d else -1 for d in dirs)
        ours = step_times_us(backend, sp.step)
        pos = position_from_pins(backend, sp.step, sp.direction)
        act = pin_activity(backend, sp.step)
        g_fw = gaps(ref)
        g_m = gaps(ours)
        c_fw = per_window(g_fw, fw_windows)
        c_m = per_window(g_m, model_windows)
        k_fw, k_m = keyed(fw_windows, c_fw), keyed(model_windows, c_m)
        keys = sorted(set(k_fw) | set(k_m)) if fw_windows else []
        c_fw = [k_fw.get(k, 0) for k in keys]
        c_m = [k_m.get(k, 0) for k in keys]
        row = dict(case=case, arch=profile, letter=sp.letter, input=inp,
                   pos_fw=pos_fw, pos=pos, pulses_fw=len(ref), pulses=act.rises,
                   gaps_fw=len(g_fw), gaps=len(g_m), win_fw=c_fw, win=c_m,
                   win_n=(len(fw_windows), len(model_windows)),
                   wdiff=max((abs(a - b) for a, b in zip(c_fw, c_m, strict=False)), default=0),
                   hmax=act.high_max_us, htot=act.high_total_us, wall=wall)
        if show_windows:
            row["fw_windows"] = fw_windows
            row["model_windows"] = model_windows
        rows.append(row)
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cases", nargs="*")
    ap.add_argument("--conformance", default=str(DEFAULT_CONF))
    ap.add_argument("--windows", action="store_true", help="print window edges too")
    ap.add_argument("--build", help="firmware build for every case (default: e for e01.., "
                    "d for the others)")
    args = ap.parse_args(argv)
    global BUILD
    BUILD = args.build
    conf = Path(args.conformance)
    cases = args.cases or CASES
    print("| case | arch | input | pin | pos fw | pos model | off | bound | pulses fw/model "
          "| gaps fw/model | per window fw | per window model | max win diff |")
    print("| --- " * 13 + "|")
    ok_all = True
    for case in cases:
        for r in case_rows(conf, case, args.windows):
            off = r["pos"] - r["pos_fw"]
            bound = max(10, abs(r["pos_fw"]) * 0.005)
            ok = (abs(off) <= bound and abs(r["pulses"] - r["pulses_fw"]) <= bound
                  and r["wdiff"] <= 1)
            ok_all &= ok
            print(f"| {r['case']} | {r['arch']} | `{r['input']}` | {r['letter']} "
                  f"| {r['pos_fw']} | {r['pos']} | {off:+d} | {bound:.0f} "
                  f"| {r['pulses_fw']}/{r['pulses']} | {r['gaps_fw']}/{r['gaps']} "
                  f"| {' '.join(map(str, r['win_fw']))} | {' '.join(map(str, r['win']))} "
                  f"| {r['wdiff']}{'' if ok else ' **'} |")
            if args.windows:
                for (a, b), (c, d) in zip(r["fw_windows"], r["model_windows"], strict=False):
                    print(f"    window fw {a:12.1f} {b:12.1f}  model {c:12.1f} {d:12.1f}  "
                          f"start {c - a:+8.1f} end {d - b:+8.1f}")
    print("all within acceptance" if ok_all else "** = outside acceptance")
    return 0


if __name__ == "__main__":
    sys.exit(main())
