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
``sequences/reference/<name>/``.  Tolerances come from the reference, never from our
result: exact counts where console timing cannot move them, the promise
max(10 steps, 0.5 %) where a timed command can land a ramp-task slot off, the bounds of
the timing model for times (a move starts in the firmware's ramp-task slot, within
200 us), the spread of the firmware's own pulse widths, and for `e` each window's gap
count within 1 (issue 23).  The file states the reasons.  What our simulation does
not meet is written as the file's ``[expected_failure]`` naming the measured value
(strict: the scenario fails the day it passes), and printed.

The runs e01-e18 come from another build of the firmware than the others (the
conformance README): their files name the firmware build ``e`` (``fas.sim.builds``).
The board of a run follows from its data: a third step channel is the ATmega2560
(upstream's timer-1 variant), an empty transcript the ATmega32U4 (its USB serial is not
connected in the simulator).
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
from stepperdemo.scenarios.scenario import (  # noqa: E402
    ExpectedFailure,
    GapsExpectation,
    Scenario,
    StepperExpectation,
    TimingExpectation,
)
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
DESCRIPTION_E = ("Conformance: the original firmware (FastAccelStepper 1.2.6 StepperDemo, "
                 "{board} in an AVR simulator), the build of the runs e01-e18 (firmware "
                 "build \"e\"), for this input line")
RUN_FILES = ("input.txt", "result.txt", "run_info.json")
SLOT_US = 4096.0  # the ramp task period of the ATmega328P (65536 ticks)
START_BOUND_US = 200.0  # start of a move inside the same ramp-task slot (fill CPU model)
PULSE_PCT_BOUND = 10.0
# the firmware's mean step pulse over the single-stepper runs without `e` spreads from
# 60.4 to 61.8 ticks (+-1.2 % about its mean): what a model of the mean can promise
PULSE_PCT = 2.0
COUNT_STEPS, COUNT_PCT = 10, 0.5  # timed input: within max(10 steps, 0.5 %) (issue 23)
# upstream's timing tests (extras/tests/simavr_based/*/expect.txt): per step pin the
# tolerance of Max High and of Total High, in us, as upstream states them
UPSTREAM_TIMING_TOL = {
    "test_sd_04_timing_328p": {"A": (5, 60), "B": (6, 270)},
    "test_sd_04_timing_328p_37k": {"A": (5, 50)},
}
BOARDS = {"atmega328p": "ATmega328P", "atmega2560_timer1": "ATmega2560, timer 1",
          "atmega32u4": "ATmega32U4"}

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
REASON_PULSE = ("Pulse high time: the step interrupt clears the pin; it waits for the "
                "interrupts that hold the CPU (timing model).  The firmware's mean pulse "
                "spreads by +-1.2 % between runs (the interrupted instruction, the loop's "
                "short critical sections), so the total is compared within 2 %; with `e` "
                "(pulses held to the end of a blocked section) within 10 %.")
REASON_COUNTS_TIMED = ("Counts and positions: within max(10 steps, 0.5 %) of the firmware, "
                       "the promise for timed input (issue 23).")
REASON_E_GAPS = ("With `e` the step interrupt misses its compare whenever a blocked section "
                 "holds it back past the next compare; the step then waits for the 16-bit "
                 "timer to wrap (4.1 ms).  Per 256 ms window of `e` the number of these gaps "
                 "is compared within 1 (issue 23).")
REASON_BUILD_E = ("The runs e01-e18 come from another build of the firmware than the d* and "
                  "test_sd_* runs (its code takes fewer cycles; the conformance README): "
                  "firmware build \"e\" (fas/sim/builds.py, docs/timing-model.md).")
REASON_BUILD_TM = ("This run was built with the library's SIMAVR_TIME_MEASUREMENT, as "
                   "upstream's timing tests are (its evaluation reports the time in the step "
                   "and fill interrupts): the step interrupt sets a port bit before it clears "
                   "the step pin (firmware build \"d_time_measurement\").")
REASON_UPSTREAM_TIMING = ("This is upstream's timing test: the longest and the summed "
                          "step pulse are compared with upstream's tolerances (its "
                          "expect.txt).  The step interrupt clears the pin once no other "
                          "interrupt holds the CPU: the other channel's step interrupt, "
                          "timer 0, the UART, the ramp task's entry and exit (timing model).")
REASON_XFAIL = ("Not met yet (expected failure, strict): {what}.")


def parse_result(path: Path) -> dict:
    res: dict = {}
    for line in path.read_text().splitlines():
        line = line.strip()
        m = re.match(r"(\w+):\s+(\d+)\*L->H,\s+(\d+)\*H->L"
                     r"(?:, Max High=(\d+)us Total High=(\d+)us)?", line)
        if m:
            res[m.group(1)] = dict(rise=int(m.group(2)), fall=int(m.group(3)),
                                   max_high=int(m.group(4)) if m.group(4) else None,
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


def firmware_build(folder: Path) -> str | None:
    """The firmware build of a run: e01.. come from the build of the `e` runs (the
    conformance README); a run whose evaluation reports the time in the step and fill
    interrupts was built with the library's SIMAVR_TIME_MEASUREMENT (upstream's timing
    tests); the others come from the default build."""
    if re.fullmatch(r"e\d+", folder.name):
        return "e"
    if "Time in StepISR" in (folder / "result.txt").read_text():
        return "d_time_measurement"
    return None


def board_of(folder: Path, result: dict) -> str:
    """The profile of a run's board, from its data."""
    if "StepC" in result:
        return "atmega2560_timer1"  # a third step channel: upstream's timer-1 variant
    transcript = folder / "transcript.txt"
    if transcript.exists() and not transcript.read_bytes().strip():
        return "atmega32u4"  # its USB serial is not connected in the simulator
    return "atmega328p"


def build(folder: Path, out_dir: Path) -> tuple[str, list[str]]:
    name = folder.name
    line = (folder / "input.txt").read_text().strip()
    result = parse_result(folder / "result.txt")
    run_info = json.loads((folder / "run_info.json").read_text())
    ref_dir = out_dir / "reference" / name
    same = ref_dir.resolve() == folder.resolve()  # importing a local run again
    build_note = run_info.get("build")
    fw_build = firmware_build(folder)
    profile = board_of(folder, result)
    with_e = " e " in f" {line} "
    letters = []
    for ch in "ABC":
        src = folder / f"steps_{ch}.tsv.gz"
        if src.exists():
            ref_dir.mkdir(parents=True, exist_ok=True)
            if not same:
                shutil.copyfile(src, ref_dir / src.name)
            letters.append(ch)
    ref_dir.mkdir(parents=True, exist_ok=True)
    transcript_ref = None
    if (folder / "transcript.txt").exists() and (folder / "transcript.txt").read_bytes().strip():
        marked = mark_reference((folder / "transcript.txt").read_bytes(), len(USAGE_NORMAL))
        transcript_ref = ref_dir / "transcript.txt.gz"
        with gzip.open(transcript_ref, "wt", encoding="utf-8", newline="") as f:
            f.write(marked)
    if build_note and not same:  # keep what a later import needs (no firmware text)
        for fname in RUN_FILES:
            shutil.copyfile(folder / fname, ref_dir / fname)
    timed = is_timed(line)
    n_timed = timed_commands(line)
    problems: list[str] = []

    # expectations from the reference, tolerances by rule (never from our result)
    steppers = []
    for ch in "ABC":
        step, d, en = result.get(f"Step{ch}"), result.get(f"Dir{ch}"), result.get(f"Enable{ch}")
        if step is None:
            continue
        values = {"pulses": step["rise"], "dir_transitions": [d["rise"], d["fall"]],
                  "enable_transitions": [en["rise"], en["fall"]]}
        tol: dict = {}
        if f"Pos{ch}" in result:
            values["position"] = result[f"Pos{ch}"]
        if timed and step["rise"]:
            tol.update(position=COUNT_STEPS, position_pct=COUNT_PCT, pulses=COUNT_STEPS,
                       pulses_pct=COUNT_PCT)
        if f"TEnable{ch}" in result:
            values["enable_high_max_us"] = result[f"TEnable{ch}"]
            tol["enable_high_us"] = START_BOUND_US
        upstream = UPSTREAM_TIMING_TOL.get(name, {}).get(ch)
        if upstream:  # upstream's own timing test: its tolerances on Max and Total High
            values["step_high_total_us"] = step["total_high"]
            values["step_high_max_us"] = step["max_high"]
            tol["step_high_max_us"], tol["step_high_total_us"] = upstream
        elif step["rise"] and step["total_high"] and fw_build is None:
            values["step_high_total_us"] = step["total_high"]
            tol["step_high_total_pct"] = PULSE_PCT_BOUND if with_e else PULSE_PCT
        steppers.append(StepperExpectation(ch, values, tol))

    sc = Scenario(path=out_dir / "conformance" / f"{name}.toml", name=name, input=line,
                  profile=profile, build=fw_build, end="firmware",
                  max_time_s=math.ceil(run_info["simulated_us"] / 1e6) + 60,
                  reference=ref_dir if letters else None, steppers=steppers,
                  transcript_ref=transcript_ref)
    if letters:
        sc.timing = TimingExpectation(letters, "absolute")
    res = run_scenario(sc)

    ref_steps = {ch: read_reference_steps(ref_dir / f"steps_{ch}.tsv.gz") for ch in letters}
    v_top = max((top_speed_steps_per_us(s) for s in ref_steps.values()), default=0.0)
    slot_steps = max(1, math.ceil(SLOT_US * v_top))

    reasons: list[str] = []
    reasons_extra: list[str] = []
    counts_match = all(res.timing[ch]["steps_ours"] == res.timing[ch]["steps_ref"]
                       for ch in letters)
    timing = None
    gaps = None
    slot_reason = None
    if letters and with_e:
        # with `e` the steps jump by whole timer wraps at steps that depend on the loop
        # phase: the defining figures are the counts (above) and the gaps per window
        gaps = GapsExpectation(letters, 1)
        reasons_extra.append(REASON_E_GAPS)
    elif letters and counts_match:
        align = "absolute"
        start_us = None
        direct = any(t in ("+", "-") for t in line.split())
        bound = START_BOUND_US + 2 * SLOT_US * n_timed + (DIRECT_BOUND_US if direct else 0)
        mx = max(res.timing[ch]["max_abs_us"] for ch in letters)
        test_mode = "t" in line.split()
        if mx > bound and not direct and (n_timed == 0 or test_mode):
            # several moves, each issued by the loop after the previous one stopped
            # (console commands after W, or a test sequence): each may start one slot off
            align = "each_move"
            start_us = SLOT_US + START_BOUND_US
            reasons_extra.append(REASON_SEQ_MOVES if test_mode else REASON_EACH_MOVE)
        elif any(abs(abs(res.timing[ch]["first_dev_us"]) - SLOT_US) < START_BOUND_US
                 for ch in letters):
            align = "first_step"
            slot_reason = "the texts of " + ", ".join(
                repr(t) for t in line.split() if t[:1] not in "MAVRW" or t == "?")
        timing = dict(steppers=letters, align=align, median_us=bound, max_us=bound)
        if start_us is not None:
            timing["start_us"] = start_us
        if direct:
            reasons_extra.append(REASON_DIRECT)
    if build_note:
        reasons.append(REASON_BUILD.format(build=build_note))
    if fw_build == "e":
        reasons.append(REASON_BUILD_E)
    if fw_build == "d_time_measurement":
        reasons.append(REASON_BUILD_TM)
    if not timed:
        reasons.append(REASON_EXACT)
    else:
        reasons.append(REASON_TIMED.format(slot_steps=slot_steps, n=n_timed))
        reasons.append(REASON_COUNTS_TIMED)
    if slot_reason:
        reasons.append(REASON_SLOT.format(what=slot_reason))
    reasons += reasons_extra
    reasons.append(REASON_ENABLE)
    if name in UPSTREAM_TIMING_TOL:
        reasons.append(REASON_UPSTREAM_TIMING)
    elif any("step_high_total_us" in e.values for e in steppers):
        reasons.append(REASON_PULSE)
    if letters and not counts_match and not with_e:
        reasons.append("The step sequences differ in length after the timed command, so "
                       "step times are not compared one by one (see the counts above).")

    # what our simulation does not meet: strict expected failures naming the values
    final = Scenario(path=sc.path, name=name, input=line, profile=profile, build=fw_build,
                     end="firmware", max_time_s=sc.max_time_s, reference=sc.reference,
                     steppers=steppers, transcript_ref=transcript_ref, gaps=gaps,
                     timing=None if timing is None else TimingExpectation(
                         timing["steppers"], timing["align"], timing.get("median_us"),
                         timing.get("max_us"), None, timing.get("start_us")))
    fres = run_scenario(final)
    failing = [c for c in fres.checks if not c.ok and c.what != "end"]
    xfail = None
    if failing:
        what = "; ".join(f"{c.what} measured {c.measured} (expected {c.expected}, "
                         f"tolerance {c.tolerance})" for c in failing)
        xfail = ExpectedFailure([c.what for c in failing], what)
        reasons.append(REASON_XFAIL.format(what=what))
        problems.append(f"{name}: not met: {what}")
    description = (DESCRIPTION_E.format(board=BOARDS[profile]) if fw_build == "e" else
                   DESCRIPTION_BUILD.format(build=build_note) if build_note else DESCRIPTION)
    text = render(name, line, run_info, steppers, timing, reasons, letters, description,
                  profile=profile, fw_build=fw_build, gaps=gaps, xfail=xfail,
                  transcript=transcript_ref is not None)
    sc.path.parent.mkdir(parents=True, exist_ok=True)
    sc.path.write_text(text)
    return name, problems


def toml_str(s: str) -> str:
    return json.dumps(s, ensure_ascii=False)


def render(name, line, run_info, steppers, timing, reasons, letters,
           description: str = DESCRIPTION, *, profile: str = "atmega328p",
           fw_build: str | None = None, gaps: GapsExpectation | None = None,
           xfail: ExpectedFailure | None = None, transcript: bool = True) -> str:
    long = run_info["simulated_us"] > 30e6
    out = [f"name = {toml_str(name)}",
           f"description = {toml_str(description)}",
           f"profile = {toml_str(profile)}"]
    if fw_build:
        out.append(f"build = {toml_str(fw_build)}  # the firmware build (fas/sim/builds.py)")
    out += [f"input = {toml_str(line)}",
            'end = "firmware"  # the reference ends 1 s after the last input character',
            f"max_time_s = {math.ceil(run_info['simulated_us'] / 1e6) + 60}"]
    if long:
        out.append("long = true")
    if letters:
        out.append(f'reference = "../reference/{name}"')
    out.append("justification = \'\'\'")
    for r in reasons:
        out.append(r)
    out.append("\'\'\'")
    for exp in steppers:
        out.append("")
        out.append(f"[steppers.{exp.letter}]")
        for key, value in exp.values.items():
            out.append(f"{key} = {json.dumps(value)}")
        if exp.tol:
            items = ", ".join(f"{k} = {json.dumps(v)}" for k, v in exp.tol.items())
            out.append(f"tol = {{ {items} }}")
    if transcript:
        out.append("")
        out.append("[transcript]  # status lines (M1: @...) depend on timing: compared up to "
                   "the @")
        out.append(f'matches = "../reference/{name}/transcript.txt.gz"')
    if timing:
        out.append("")
        out.append("[timing]")
        out.append(f"steppers = {json.dumps(timing['steppers'])}")
        out.append(f"align = {toml_str(timing['align'])}")
        for key in ("median_us", "max_us", "duration_ratio", "start_us"):
            if key in timing:
                out.append(f"{key} = {timing[key]}")
    if gaps:
        out.append("")
        out.append("[gaps]  # the timer-wrap gaps of `e`, per 256 ms window, against the "
                   "reference")
        out.append(f"steppers = {json.dumps(gaps.steppers)}")
        out.append(f"per_window = {gaps.per_window}")
    if xfail:
        out.append("")
        out.append("[expected_failure]  # strict: the scenario fails the day these pass")
        out.append(f"checks = {json.dumps(xfail.checks)}")
        out.append(f"reason = {toml_str(xfail.reason)}")
    out.append("")
    return "\n".join(out)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    shared = next((f / "shared" / "conformance" for f in ROOT.parents
                   if (f / "shared" / "conformance").is_dir()),
                  ROOT.parent / "shared" / "conformance")
    ap.add_argument("conformance", nargs="*", default=[str(shared)],
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
