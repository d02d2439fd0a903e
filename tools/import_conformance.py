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
result (docs/tolerances.md): counts exact without timed input, else max(10 steps,
0.5 %) (the acceptance rule of issues 16 and 23); times within the firmware's own
spread between two builds (336 us); pulse high time within upstream's tolerance.
The file is then run once: every check it does not meet is written as a
``[known_deviation]`` entry naming the measured value (a strict expected failure in the
suite, until the model meets it; importing again after a model change refreshes them).

The runs e01-e18 come from another build of the firmware than the others (the
conformance README): their files name the firmware build ``e`` (``fas.sim.builds``), and
each `e` run is also checked window by window: the number of ~4.1 ms timer-wrap gaps per
256 ms window within 1 of the firmware's (issue 23).  The board of a run follows from its
data: a third step channel is the ATmega2560 (upstream's timer-1 variant), an empty
transcript the ATmega32U4 (its USB serial is not connected in the simulator).
"""

from __future__ import annotations

import argparse
import gzip
import json
import math
import re
import shutil
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from stepperdemo.messages import USAGE_NORMAL  # noqa: E402
from stepperdemo.scenarios.evaluate import read_reference_steps  # noqa: E402
from stepperdemo.scenarios.runner import run_scenario  # noqa: E402
from stepperdemo.scenarios.scenario import (  # noqa: E402
    GapsExpectation,
    Scenario,
    StepperExpectation,
    TimingExpectation,
)
from stepperdemo.scenarios.transcript import mark_reference  # noqa: E402

DESCRIPTION = ("Conformance: the original firmware (FastAccelStepper 1.2.6 StepperDemo, "
               "ATmega328P in an AVR simulator) for this input line")
DESCRIPTION_E = ("Conformance: the original firmware (FastAccelStepper 1.2.6 StepperDemo, "
                 "{board} in an AVR simulator), the build of the runs e01-e18 (firmware "
                 "build \"e\"), for this input line")
BOARDS = {"atmega328p": "ATmega328P", "atmega2560_timer1": "ATmega2560, timer 1",
          "atmega32u4": "ATmega32U4"}
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
DIRECT_BOUND_US = 1500.0
# --- tolerances, from the reference (docs/tolerances.md) ---
# two builds of the same firmware source land its commands 200-336 us apart (the e-runs of
# the shared conformance data against the d-runs, README there): a time of the firmware
# (enable-off end, step times, move starts) is known no better than that
BUILD_SPREAD_US = 336
# positions and pulse counts of timed input: max(10 steps, 0.5 %) (issues 16 and 23)
COUNT_MIN_STEPS = 10
COUNT_PER_MILLE = 5
# pulse high total: upstream's own tolerance where its test has this input ...
UPSTREAM_TOTAL_HIGH_US = {
    "test_sd_04_timing_328p": {"A": 60, "B": 270},
    "test_sd_04_timing_328p_37k": {"A": 50},
    "test_sd_05_328p": {"A": 800},
    "test_sd_14_328p": {"A": 1000},
}
# ... else the widest relative one upstream grants on the 328P: 800 of 55477 us (sd_05)
UPSTREAM_TOTAL_HIGH_PCT = 1.44
# Max High (the longest pulse): upstream's tolerance in its timing tests' expect.txt
UPSTREAM_MAX_HIGH_US = {
    "test_sd_04_timing_328p": {"A": 5, "B": 6},
    "test_sd_04_timing_328p_37k": {"A": 5},
}
E_GAPS_PER_WINDOW = 1  # issue 23: each window's gap count within 1 of the firmware's
E_WINDOW_PERIOD_US = 256_000  # `e` blocks while millis() & 0xff < 0x40
E_WINDOW_US = 65_000
E_GAP_US = 4096.0  # one missed compare: the 16-bit timer wraps

REASON_EXACT = ("No timed wait and no speed change while running: which commands reach the "
                "ramp generator, and in which order, does not depend on console timing, so "
                "positions and pulse, direction and enable counts are exact.")
REASON_TIMED = ("Timed input (w<ms> waits, speed changes while running, test sequences): "
                "the moment a command takes effect depends on console timing (115200-baud "
                "UART, the firmware's message-table lookups) and lands on the 4.096 ms ramp "
                "task.  Positions and pulse counts are held to max(10 steps, 0.5 %) of the "
                "firmware's, the acceptance rule of issues 16 and 23; transitions are exact.")
REASON_TIMES = ("Times (the enable-off time, step times, move starts) are held to 336 us: two "
                "builds of the same firmware source land its commands 200-336 us apart (the "
                "e-runs against the d-runs of the shared conformance data), so the firmware's "
                "own times are known no better than that.")
REASON_SLOT = ("The firmware starts the first move one ramp-task slot (4.096 ms) later than "
               "the model: its console needs more CPU time for {what} than our model of its "
               "message table gives (docs/timing-model.md).  Step timing is therefore "
               "compared from the first step on (align = first_step); the enable-off time "
               "shows the slot.")
REASON_E_TIMING = ("With `e` the step interrupt misses its compare whenever it is held "
                   "back more than one period; the next step then waits for the 16-bit timer "
                   "to wrap (4.1 ms).  Which steps are hit depends on the loop's phase to the "
                   "microsecond, so steps are not compared one by one; the step count and the "
                   "duration from first to last step are: the duration within one 4.1 ms gap "
                   "per `e` window the motion spans ({windows}), the acceptance rule of "
                   "issue 23 (gaps per window within +-1 of the firmware's).")
REASON_E_GAPS = ("Per 256 ms window of `e` the number of these gaps is compared within "
                 "1 of the firmware's (issue 23's acceptance rule).")
REASON_BUILD_E = ("The runs e01-e18 come from another build of the firmware than the d* and "
                  "test_sd_* runs (its code takes fewer cycles: commands land 200-336 us "
                  "earlier, the conformance README): firmware build \"e\" (fas/sim/builds.py, "
                  "docs/timing-model.md).")
REASON_BUILD_TM = ("This run was built with the library's SIMAVR_TIME_MEASUREMENT, as "
                   "upstream's timing tests are (its evaluation reports the time in the step "
                   "and fill interrupts): the step interrupt sets a port bit before it clears "
                   "the step pin (firmware build \"d_time_measurement\").")
REASON_MAX_HIGH = ("Upstream's timing test has this input: the longest pulse (Max High) is "
                   "compared with upstream's tolerance ({what} us, its expect.txt).")
REASON_DIRECT = ("Single steps (+/-) are started by the console command itself, not by the "
                 "ramp task, so their time is the console's.")
REASON_EACH_MOVE = ("Each move is started by a console command after the previous one "
                    "stopped (W) and the usage was printed; step times are compared move by "
                    "move (align = each_move) and each move's start offset is bounded by "
                    "start_us.")
REASON_SEQ_MOVES = ("The test sequence starts each move from the loop once the previous one "
                    "has stopped; step times are compared move by move (align = each_move) "
                    "and each move's start offset is bounded by start_us.")
REASON_ENABLE = ("Enable-off time = start-up to the first auto-enable; it depends on when "
                 "the console took the first move command (see the timing model).")
REASON_PULSE = ("Pulse high time: the compare raises the step pin and the step interrupt "
                "clears it, so a pulse lasts as long as that interrupt waits behind the others "
                "(timing model, interrupt contention).  Its total is held to {what}.")
REASON_KNOWN = ("[known_deviation] lists the checks the model does not meet yet, each with the "
                "value measured at import; the suite runs them as strict expected failures.")
KNOWN_WHY = (  # check name suffix -> what it is about
    ("pulse high total us", "pulse widths under interrupt contention (issue 23 item 2)"),
    ("duration ratio", "the `e` model (issue 23 item 1)"),
    ("gaps per window", "the `e` model (issue 23 item 1)"),
    ("pulse high max us", "pulse widths under interrupt contention (issue 23 item 2)"),
    ("enable off time us", "console timing: the first move command lands elsewhere"),
    ("step time median |dev| us", "console timing: step times"),
    ("step time max |dev| us", "console timing: step times"),
    ("move start |offset| us", "console timing: a move starts in another ramp-task slot"),
    ("position", "a timed command takes effect in another ramp-task slot"),
    ("pulses", "a timed command takes effect in another ramp-task slot"),
)

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
    elif (ref_dir / "transcript.txt.gz").exists():  # importing a local run again: marked
        transcript_ref = ref_dir / "transcript.txt.gz"
    if build_note and not same:  # keep what a later import needs (no firmware text)
        for fname in RUN_FILES:
            shutil.copyfile(folder / fname, ref_dir / fname)
    timed = is_timed(line)
    n_timed = timed_commands(line)
    problems: list[str] = []
    exact_counts = not timed

    # expectations from the reference, tolerances by rule (docs/tolerances.md)
    steppers = []
    upstream_total = UPSTREAM_TOTAL_HIGH_US.get(name, {})
    upstream_max = UPSTREAM_MAX_HIGH_US.get(name, {})
    for ch in "ABC":
        step, d, en = result.get(f"Step{ch}"), result.get(f"Dir{ch}"), result.get(f"Enable{ch}")
        if step is None:
            continue
        values = {"pulses": step["rise"], "dir_transitions": [d["rise"], d["fall"]],
                  "enable_transitions": [en["rise"], en["fall"]]}
        tol: dict = {}
        if f"Pos{ch}" in result:
            values["position"] = result[f"Pos{ch}"]
        if not exact_counts and step["rise"]:  # a stepper that never stepped: exact
            for key in ("position", "pulses"):
                if key in values:
                    tol[key] = max(COUNT_MIN_STEPS, abs(values[key]) * COUNT_PER_MILLE // 1000)
        if f"TEnable{ch}" in result:
            values["enable_high_max_us"] = result[f"TEnable{ch}"]
            tol["enable_high_us"] = BUILD_SPREAD_US
        if step["rise"] and step["total_high"]:
            values["step_high_total_us"] = step["total_high"]
            if ch in upstream_total:
                tol["step_high_total_us"] = upstream_total[ch]
            else:
                tol["step_high_total_pct"] = UPSTREAM_TOTAL_HIGH_PCT
        if ch in upstream_max and step["max_high"] is not None:
            values["step_high_max_us"] = step["max_high"]
            tol["step_high_max_us"] = upstream_max[ch]
        steppers.append(StepperExpectation(ch, values, tol))

    def scenario(timing: TimingExpectation | None, with_steppers: bool = True) -> Scenario:
        sc = Scenario(path=out_dir / "conformance" / f"{name}.toml", name=name, input=line,
                      profile=profile, build=fw_build, end="firmware",
                      max_time_s=math.ceil(run_info["simulated_us"] / 1e6) + 60,
                      reference=ref_dir if letters else None,
                      steppers=steppers if with_steppers else [],
                      transcript_ref=transcript_ref)
        sc.timing = timing
        sc.gaps = gaps
        return sc

    gaps = None
    # one run without step-time limits: how the step sequences compare
    res = run_scenario(scenario(TimingExpectation(letters, "absolute") if letters else None))
    ref_steps = {ch: read_reference_steps(ref_dir / f"steps_{ch}.tsv.gz") for ch in letters}
    reasons: list[str] = []
    reasons_extra: list[str] = []
    counts_match = all(res.timing[ch]["steps_ours"] == res.timing[ch]["steps_ref"]
                       for ch in letters)
    timing = None
    slot_reason = None
    gaps = None
    if letters and with_e:
        gaps = GapsExpectation(letters, E_GAPS_PER_WINDOW)
    if letters and counts_match and with_e:
        # with `e` the steps jump by whole timer wraps at steps that depend on the loop
        # phase; the defining figures are the count (above) and the total duration
        first = min(s[0] for s in ref_steps.values() if s)
        last = max(s[-1] for s in ref_steps.values() if s)
        windows = sum(1 for k in range(int(last // E_WINDOW_PERIOD_US) + 1)
                      if k * E_WINDOW_PERIOD_US + E_WINDOW_US > first
                      and k * E_WINDOW_PERIOD_US < last)
        timing = dict(steppers=letters, align="first_step",
                      duration_ratio=round(max(1, windows) * E_GAP_US / (last - first), 6))
        reasons_extra.append(REASON_E_TIMING.format(windows=windows))
    elif letters and counts_match:
        mx = max(res.timing[ch]["max_abs_us"] for ch in letters)
        align = "absolute"
        start_us = None
        direct = any(t in ("+", "-") for t in line.split())
        bound = START_BOUND_US + 2 * SLOT_US * n_timed + (DIRECT_BOUND_US if direct else 0)
        test_mode = "t" in line.split()
        if mx > bound and not direct and (n_timed == 0 or test_mode):
            # several moves, each issued by the loop after the previous one stopped
            # (console commands after W, or a test sequence): compared move by move
            align = "each_move"
            start_us = BUILD_SPREAD_US
            reasons_extra.append(REASON_SEQ_MOVES if test_mode else REASON_EACH_MOVE)
        elif any(abs(abs(res.timing[ch]["first_dev_us"]) - SLOT_US) < START_BOUND_US
                 for ch in letters):
            align = "first_step"
            slot_reason = "the texts of " + ", ".join(
                repr(t) for t in line.split() if t[:1] not in "MAVRW" or t == "?")
        timing = dict(steppers=letters, align=align, median_us=BUILD_SPREAD_US,
                      max_us=BUILD_SPREAD_US)
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
    reasons.append(REASON_EXACT if exact_counts else REASON_TIMED)
    reasons.append(REASON_TIMES)
    if slot_reason:
        reasons.append(REASON_SLOT.format(what=slot_reason))
    reasons += reasons_extra
    reasons.append(REASON_ENABLE)
    if any("step_high_total_us" in e.values for e in steppers):
        what = (", ".join(f"{ch} {v} us" for ch, v in upstream_total.items())
                + " (upstream's tolerance in its expect.txt for this input)" if upstream_total
                else f"{UPSTREAM_TOTAL_HIGH_PCT} %, the widest relative tolerance upstream's "
                "expect.txt grant the Total High of the 328P (test_sd_05: 800 of 55477 us)")
        reasons.append(REASON_PULSE.format(what=what))
    if upstream_max:
        reasons.append(REASON_MAX_HIGH.format(what=", ".join(
            f"{ch} {v}" for ch, v in upstream_max.items())))
    if gaps:
        reasons.append(REASON_E_GAPS)
    if letters and not counts_match and not with_e:
        reasons.append("The step sequences differ in length after the timed command, so "
                       "step times are not compared one by one (see the counts above).")

    # the file as written, run once: what it does not meet is a known deviation
    sc = scenario(None if timing is None else TimingExpectation(
        timing["steppers"], timing["align"], timing.get("median_us"), timing.get("max_us"),
        timing.get("duration_ratio"), timing.get("start_us")))
    final = run_scenario(sc)
    known = {}
    for c in final.checks:
        if c.ok:
            continue
        why = next((w for suffix, w in KNOWN_WHY if c.what.endswith(suffix)), None)
        if (c.what == "transcript matches reference"
                and re.search(r"'M\d: @.*', reference 'M\d: @", str(c.measured))):
            # a status line (printed every 100 ms while a stepper runs) that sees the
            # steppers at another moment: timing, not text
            why = "console timing: a status line sees the steppers at another moment"
        if with_e and why is not None and c.what.endswith(("position", "pulses")):
            why = "the `e` model (issue 23 item 1)"
        if why is None:  # a count, a transition, the transcript: not a tolerance matter
            problems.append(f"{name}: {c.what}: expected {c.expected}, measured {c.measured}")
            continue
        measured = round(c.measured, 3) if isinstance(c.measured, float) else c.measured
        known[c.what] = dict(measured=measured, reason=f"{why}; the firmware: {c.expected} "
                             f"+- {_num(c.tolerance)}")
    if known:
        reasons.append(REASON_KNOWN)
    description = (DESCRIPTION_E.format(board=BOARDS[profile]) if fw_build == "e" else
                   DESCRIPTION_BUILD.format(build=build_note) if build_note else DESCRIPTION)
    text = render(name, line, run_info, steppers, timing, reasons, letters, description,
                  known, profile=profile, fw_build=fw_build, gaps=gaps,
                  transcript=transcript_ref is not None)
    path = out_dir / "conformance" / f"{name}.toml"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return name, problems


def _num(v: float | None) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.4f}".rstrip("0").rstrip(".") if v < 1 else f"{v:.1f}".removesuffix(".0")
    return str(v)


def toml_str(s: str) -> str:
    return json.dumps(s, ensure_ascii=False)


def render(name, line, run_info, steppers, timing, reasons, letters,
           description: str = DESCRIPTION, known: dict | None = None, *,
           profile: str = "atmega328p", fw_build: str | None = None,
           gaps: GapsExpectation | None = None, transcript: bool = True) -> str:
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
    if known:
        out.append("")
        out.append("[known_deviation]  # not met yet: the value measured at import "
                   "(tools/import_conformance.py)")
        for what, entry in known.items():
            out.append(f"{toml_str(what)} = {{ measured = {json.dumps(entry['measured'])}, "
                       f"reason = {toml_str(entry['reason'])} }}")
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
