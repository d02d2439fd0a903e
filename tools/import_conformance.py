"""Turn the conformance data (runs of the original firmware) into scenario files.

    python tools/import_conformance.py [CONFORMANCE_DIR ...] [--out sequences]

Sources: the shared conformance data (default), or any folder of runs in its layout.
Runs made with a local build of the firmware name that build in ``run_info.json``
(``"build"``); their description and justification say so.  Such a run keeps its
``input.txt``, ``result.txt`` and ``run_info.json`` next to its reference data, so that
``python tools/import_conformance.py sequences/reference -k dm`` imports it again (the
transcript there is already marked).

For every folder of the conformance data: write ``sequences/conformance/<name>.toml``
with the reference figures as expectations, and copy its per-step timestamps and its
console transcript (version and usage text replaced by markers) to
``sequences/reference/<name>/``.  Tolerances are the smallest our simulation meets,
and each must lie within a bound that follows from the timing model; the file states
the reason.  A deviation beyond its bound is printed and the file is written with the
bound, so that the scenario fails until the model is fixed.
"""

from __future__ import annotations

import argparse
import gzip
import json
import math
import re
import shutil
import sys
from itertools import pairwise
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from stepperdemo.messages import USAGE_NORMAL  # noqa: E402
from stepperdemo.scenarios.evaluate import read_reference_steps  # noqa: E402
from stepperdemo.scenarios.runner import run_scenario  # noqa: E402
from stepperdemo.scenarios.scenario import Scenario, StepperExpectation, TimingExpectation  # noqa: E402
from stepperdemo.scenarios.transcript import mark_reference  # noqa: E402

DESCRIPTION = ("Conformance: the original firmware (FastAccelStepper 1.2.6 StepperDemo, "
               "ATmega328P in an AVR simulator) for this input line")
DESCRIPTION_BUILD = ("Conformance: the original firmware (FastAccelStepper 1.2.6 StepperDemo, "
                     "ATmega328P) built and run locally ({build}) for this input line")
REASON_BUILD = ("This run comes from a local build of the original firmware ({build}), not "
                "from the shared conformance data.  That build reproduces every shared run "
                "(same positions, pulse counts and transcripts); its first steps come 34 us "
                "and its ramp task 9 us earlier than there (another compiler), which the "
                "step-time tolerances absorb.")
RUN_FILES = ("input.txt", "result.txt", "run_info.json")
SLOT_US = 4096.0  # the ramp task period of the ATmega328P (65536 ticks)
START_BOUND_US = 200.0  # start of a move inside the same ramp-task slot (fill CPU model)
PULSE_PCT_BOUND = 10.0

REASON_EXACT = ("No timed wait and no speed change while running: which commands reach the "
                "ramp generator, and in which order, does not depend on console timing, so "
                "positions and pulse, direction and enable counts are exact.")
REASON_TIMED = ("Timed input (w<ms> waits, speed changes while running, test sequences): "
                "the moment a command takes effect depends on console timing (115200-baud "
                "UART, the firmware's message-table lookups) and lands on the 4.096 ms ramp "
                "task.  Each of the {n} timed motion command(s) may land one slot earlier "
                "or later than in the firmware; that moves the turning point of the motion "
                "by at most one slot of travel at the top speed ({slot_steps} steps) out and "
                "the same back, so counts stay within 2 x {slot_steps} x {n} steps and step "
                "times within 2 x 4.096 ms x {n} (+0.2 ms); the tolerances are the measured "
                "deviations, all inside these bounds.")
REASON_SLOT = ("The firmware starts the first move one ramp-task slot (4.096 ms) later than "
               "the model: its console needs more CPU time for {what} than our model of its "
               "message table gives (docs/timing-model.md).  Step timing is therefore "
               "compared from the first step on (align = first_step), and the enable-off "
               "time allows one slot.")
REASON_E_TIMING = ("With `e` the step interrupt misses its compare whenever it is held "
                   "back more than one period; the next step then waits for the 16-bit timer "
                   "to wrap (4.1 ms).  Which steps are hit depends on the loop's phase to the "
                   "microsecond, so steps are not compared one by one; the step count (exact) "
                   "and the duration from first to last step are.")
DIRECT_BOUND_US = 1500.0
REASON_DIRECT = ("Single steps (+/-) are started by the console command itself, not by the "
                 "ramp task, so their time is the console's: our model of the firmware's "
                 "console places them within 1.5 ms.")
REASON_EACH_MOVE = ("Each move is started by a console command after the previous one "
                    "stopped (W) and the usage was printed; such a move may start one "
                    "4.096 ms ramp-task slot off (console CPU model, docs/timing-model.md). "
                    "Step times are compared move by move (align = each_move) and the start "
                    "offsets are bounded by start_us.")
REASON_SEQ_MOVES = ("The test sequence starts each move from the loop once the previous one "
                    "has stopped.  When the loop notices the stop within microseconds of "
                    "a ramp-task start, the move starts one 4.096 ms slot off (console CPU "
                    "model, docs/timing-model.md); the offsets add up over the sequence. "
                    "Step times are compared move by move (align = each_move) and the "
                    "start offsets are bounded by start_us.")
REASON_ENABLE = ("Enable-off time = start-up to the first auto-enable; it depends on when "
                 "the console took the first move command (see the timing model).")
REASON_PULSE = ("Pulse high time is the step interrupt's latency, modelled as a constant per "
                "channel (3.8 us A, 4.6 us B); the firmware's varies with other interrupts.")


def parse_result(path: Path) -> dict:
    res: dict = {}
    for line in path.read_text().splitlines():
        line = line.strip()
        m = re.match(r"(\w+):\s+(\d+)\*L->H,\s+(\d+)\*H->L"
                     r"(?:, Max High=(\d+)us Total High=(\d+)us)?", line)
        if m:
            res[m.group(1)] = dict(rise=int(m.group(2)), fall=int(m.group(3)),
                                   total_high=int(m.group(5)) if m.group(5) else None)
            continue
        m = re.match(r"Position\[(\w)\]=(-?\d+)", line)
        if m:
            res["Pos" + m.group(1)] = int(m.group(2))
            continue
        m = re.match(r"Time in (Enable\w)\s+max=(\d+) us, total=(\d+) us", line)
        if m:
            res["T" + m.group(1)] = int(m.group(2))
    return res


def is_timed(line: str) -> bool:
    tokens = line.split()
    moving = False
    for tok in tokens:
        if re.fullmatch(r"w\d+", tok) or tok == "U":
            return True
        if tok[:1] in "RPfba+-":
            if moving and tok[:1] == "a":
                return True
            moving = True
        if tok[:1] in "tT":
            return True  # test sequences run on the clock
    return False


MOTION = re.compile(r"^(R|P|a|f|b|S|X|K|U|\+|-)")


def timed_commands(line: str) -> int:
    """Motion commands whose moment depends on a timed wait before them; a test
    sequence counts as one (it times its own commands)."""
    n = 0
    after_wait = False
    for tok in line.split():
        if re.fullmatch(r"w\d+", tok):
            after_wait = True
        elif tok == "t":
            n = max(n, 1)
        elif after_wait and MOTION.match(tok):
            n += 1
    return max(n, 1) if is_timed(line) else 0


def top_speed_steps_per_us(ref_steps: list[float]) -> float:
    periods = [b - a for a, b in pairwise(ref_steps) if b > a]
    return 1.0 / min(periods) if periods else 0.0


def round_up(x: float, step: float) -> float:
    return math.ceil(x / step - 1e-9) * step if x > 0 else 0


def build(folder: Path, out_dir: Path) -> tuple[str, list[str]]:
    name = folder.name
    line = (folder / "input.txt").read_text().strip()
    result = parse_result(folder / "result.txt")
    run_info = json.loads((folder / "run_info.json").read_text())
    ref_dir = out_dir / "reference" / name
    same = ref_dir.resolve() == folder.resolve()  # importing a local run again
    build_note = run_info.get("build")
    letters = []
    for ch in "AB":
        src = folder / f"steps_{ch}.tsv.gz"
        if src.exists():
            ref_dir.mkdir(parents=True, exist_ok=True)
            if not same:
                shutil.copyfile(src, ref_dir / src.name)
            letters.append(ch)
    ref_dir.mkdir(parents=True, exist_ok=True)
    if (folder / "transcript.txt").exists():
        marked = mark_reference((folder / "transcript.txt").read_bytes(), len(USAGE_NORMAL))
        with gzip.open(ref_dir / "transcript.txt.gz", "wt", encoding="utf-8", newline="") as f:
            f.write(marked)
    if build_note and not same:  # keep what a later import needs (no firmware text)
        for fname in RUN_FILES:
            shutil.copyfile(folder / fname, ref_dir / fname)
    timed = is_timed(line)
    n_timed = timed_commands(line)
    problems: list[str] = []

    # expectations from the reference
    steppers = []
    for ch in "AB":
        step, d, en = result.get(f"Step{ch}"), result.get(f"Dir{ch}"), result.get(f"Enable{ch}")
        if step is None:
            continue
        values = {"pulses": step["rise"], "dir_transitions": [d["rise"], d["fall"]],
                  "enable_transitions": [en["rise"], en["fall"]]}
        if f"Pos{ch}" in result:
            values["position"] = result[f"Pos{ch}"]
        if f"TEnable{ch}" in result:
            values["enable_high_max_us"] = result[f"TEnable{ch}"]
        if step["rise"] and step["total_high"]:
            values["step_high_total_us"] = step["total_high"]
        steppers.append(StepperExpectation(ch, values, {}))

    # run our model once without tolerances to measure the deviations
    sc = Scenario(path=out_dir / "conformance" / f"{name}.toml", name=name, input=line,
                  end="firmware", max_time_s=math.ceil(run_info["simulated_us"] / 1e6) + 60,
                  reference=ref_dir if letters else None, steppers=steppers,
                  transcript_ref=ref_dir / "transcript.txt.gz")
    if letters:
        sc.timing = TimingExpectation(letters, "absolute")
    res = run_scenario(sc)
    dev = {c.what: c.deviation for c in res.checks}
    for c in res.checks:
        if c.what == "transcript matches reference" and not c.ok:
            problems.append(f"{name}: transcript differs: {c.measured}")

    ref_steps = {ch: read_reference_steps(ref_dir / f"steps_{ch}.tsv.gz") for ch in letters}
    v_top = max((top_speed_steps_per_us(s) for s in ref_steps.values()), default=0.0)
    slot_steps = max(1, math.ceil(SLOT_US * v_top))

    reasons: list[str] = []
    reasons_extra: list[str] = []
    exact_counts = not timed
    for exp in steppers:
        ch = exp.letter
        tol = exp.tol
        for key, what in (("position", f"{ch} position"), ("pulses", f"{ch} pulses")):
            d = abs(dev.get(what) or 0)
            bound = 0 if exact_counts else 2 * slot_steps * n_timed
            if d:
                if d > bound:
                    problems.append(f"{name}: {what} deviates by {d} (bound {bound})")
                tol[key] = min(int(d), bound)
        dmax = max(abs(dev.get(f"{ch} dir rising") or 0), abs(dev.get(f"{ch} dir falling") or 0))
        if dmax:
            problems.append(f"{name}: {ch} direction transitions deviate by {dmax}")
        emax = max(abs(dev.get(f"{ch} enable rising") or 0),
                   abs(dev.get(f"{ch} enable falling") or 0))
        if emax:
            problems.append(f"{name}: {ch} enable transitions deviate by {emax}")
        if "enable_high_max_us" in exp.values:
            d = abs(dev.get(f"{ch} enable off time us") or 0)
            bound = START_BOUND_US if d <= START_BOUND_US else SLOT_US + START_BOUND_US
            if d > bound:
                problems.append(f"{name}: {ch} enable off time deviates by {d:.0f} us")
            tol["enable_high_us"] = max(10, round_up(d, 10))
        if "step_high_total_us" in exp.values:
            # the reference truncates its sum to whole microseconds: allow 1 us of that
            pct = 100 * max(0, abs(dev.get(f"{ch} pulse high total us") or 0) - 1) / exp.values[
                "step_high_total_us"]
            if pct > PULSE_PCT_BOUND:
                problems.append(f"{name}: {ch} pulse high total deviates by {pct:.1f} %")
            tol["step_high_total_pct"] = max(1, math.ceil(pct))
    counts_match = all(res.timing[ch]["steps_ours"] == res.timing[ch]["steps_ref"]
                       for ch in letters)
    timing = None
    slot_reason = None
    if letters and counts_match and " e " in f" {line} ":
        # with `e` the steps jump by whole timer wraps at steps that depend on the loop
        # phase; the defining figures are the count (above) and the total duration
        probe = Scenario(path=sc.path, name=name, input=line, end="firmware",
                         max_time_s=sc.max_time_s, reference=ref_dir, steppers=[],
                         timing=TimingExpectation(letters, "first_step"))
        pres = run_scenario(probe)
        ratio = max(abs(pres.timing[ch]["duration_ratio"] - 1) for ch in letters)
        timing = dict(steppers=letters, align="first_step",
                      duration_ratio=max(0.0005, round_up(ratio * 1.2, 0.0005)))
        reasons_extra.append(REASON_E_TIMING)
        if ratio > 0.01:
            problems.append(f"{name}: duration differs by {ratio * 100:.2f} %")
    elif letters and counts_match:
        med = max(res.timing[ch]["median_abs_us"] for ch in letters)
        mx = max(res.timing[ch]["max_abs_us"] for ch in letters)
        align = "absolute"
        start_us = None
        direct = any(t in ("+", "-") for t in line.split())
        bound = START_BOUND_US + 2 * SLOT_US * n_timed + (DIRECT_BOUND_US if direct else 0)
        test_mode = "t" in line.split()
        if mx > bound and not direct and (n_timed == 0 or test_mode):
            # several moves, each issued by the loop after the previous one stopped
            # (console commands after W, or a test sequence): each may start one slot off
            probe = Scenario(path=sc.path, name=name, input=line, end="firmware",
                             max_time_s=sc.max_time_s, reference=ref_dir, steppers=[],
                             timing=TimingExpectation(letters, "each_move"))
            pres = run_scenario(probe)
            align = "each_move"
            med = max(pres.timing[ch]["median_abs_us"] for ch in letters)
            mx = max(pres.timing[ch]["max_abs_us"] for ch in letters)
            off = max(abs(pres.timing[ch]["offset_us"]) for ch in letters)
            start_us = round_up(off * 1.02 + 1, 1)
            reasons_extra.append(REASON_SEQ_MOVES if test_mode else REASON_EACH_MOVE)
            if off > SLOT_US + START_BOUND_US:
                problems.append(f"{name}: a move starts {off:.0f} us off")
        elif any(abs(abs(res.timing[ch]["first_dev_us"]) - SLOT_US) < START_BOUND_US
                 for ch in letters):
            align = "first_step"
            slot_reason = "the texts of " + ", ".join(
                repr(t) for t in line.split() if t[:1] not in "MAVRW" or t == "?")
            probe = Scenario(path=sc.path, name=name, input=line, end="firmware",
                             max_time_s=sc.max_time_s, reference=ref_dir, steppers=[],
                             timing=TimingExpectation(letters, "first_step"))
            pres = run_scenario(probe)
            med = max(pres.timing[ch]["median_abs_us"] for ch in letters)
            mx = max(pres.timing[ch]["max_abs_us"] for ch in letters)
        timing = dict(steppers=letters, align=align, median_us=round_up(med * 1.1 + 0.5, 0.5),
                      max_us=round_up(mx * 1.1 + 0.5, 0.5))
        if start_us is not None:
            timing["start_us"] = start_us
        if direct:
            reasons_extra.append(REASON_DIRECT)
        if mx > bound:
            problems.append(f"{name}: step times deviate by up to {mx:.0f} us (bound "
                            f"{bound:.0f})")
    if build_note:
        reasons.append(REASON_BUILD.format(build=build_note))
    if exact_counts:
        reasons.append(REASON_EXACT)
    else:
        reasons.append(REASON_TIMED.format(slot_steps=slot_steps, n=n_timed))
    if slot_reason:
        reasons.append(REASON_SLOT.format(what=slot_reason))
    reasons += reasons_extra
    reasons.append(REASON_ENABLE)
    if any("step_high_total_us" in e.values for e in steppers):
        reasons.append(REASON_PULSE)
    if letters and not counts_match:
        reasons.append("The step sequences differ in length after the timed command, so "
                       "step times are not compared one by one (see the counts above).")
    text = render(name, line, run_info, steppers, timing, reasons, letters,
                  DESCRIPTION_BUILD.format(build=build_note) if build_note else DESCRIPTION)
    path = out_dir / "conformance" / f"{name}.toml"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return name, problems


def toml_str(s: str) -> str:
    return json.dumps(s, ensure_ascii=False)


def render(name, line, run_info, steppers, timing, reasons, letters,
           description: str = DESCRIPTION) -> str:
    long = run_info["simulated_us"] > 30e6
    out = [f"name = {toml_str(name)}",
           f"description = {toml_str(description)}",
           'profile = "atmega328p"',
           f"input = {toml_str(line)}",
           'end = "firmware"  # the reference ends 1 s after the last input character',
           f"max_time_s = {math.ceil(run_info['simulated_us'] / 1e6) + 60}"]
    if long:
        out.append("long = true")
    if letters:
        out.append(f'reference = "../reference/{name}"')
    out.append("justification = '''")
    for r in reasons:
        out.append(r)
    out.append("'''")
    for exp in steppers:
        out.append("")
        out.append(f"[steppers.{exp.letter}]")
        for key, value in exp.values.items():
            out.append(f"{key} = {json.dumps(value)}")
        if exp.tol:
            items = ", ".join(f"{k} = {json.dumps(v)}" for k, v in exp.tol.items())
            out.append(f"tol = {{ {items} }}")
    out.append("")
    out.append("[transcript]  # status lines (M1: @...) depend on timing: compared up to the @")
    out.append(f'matches = "../reference/{name}/transcript.txt.gz"')
    if timing:
        out.append("")
        out.append("[timing]")
        out.append(f"steppers = {json.dumps(timing['steppers'])}")
        out.append(f"align = {toml_str(timing['align'])}")
        for key in ("median_us", "max_us", "duration_ratio", "start_us"):
            if key in timing:
                out.append(f"{key} = {timing[key]}")
    out.append("")
    return "\n".join(out)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("conformance", nargs="*",
                    default=[str(ROOT.parent / "shared" / "conformance")],
                    help="folders of firmware runs (default: the shared conformance data)")
    ap.add_argument("--out", default=str(ROOT / "sequences"))
    ap.add_argument("-k", help="only folders whose name contains this")
    args = ap.parse_args()
    out = Path(args.out)
    all_problems = []
    folders = sorted(p for src in map(Path, args.conformance) for p in src.iterdir()
                     if p.is_dir() and (p / "result.txt").exists())
    for folder in folders:
        if args.k and args.k not in folder.name:
            continue
        name, problems = build(folder, out)
        all_problems += problems
        print(("!! " if problems else "ok ") + name)
    for p in all_problems:
        print("   ", p)
    return 1 if all_problems else 0


if __name__ == "__main__":
    sys.exit(main())
