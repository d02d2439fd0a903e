"""How close the simulated `e` (100 us interrupt blocks) comes to the firmware's runs.

For every conformance folder with the `e` injection (e01..e18, d35..d38) this runs the
folder's input on the simulated chip and compares, per stepper, the pin-derived
position and pulse count with the firmware's, and per 256 ms window of `e` the number
of ~4.1 ms gaps (a step compare missed, the 16-bit timer wrapped) in both.

    python3 bench/e_fidelity.py [--conformance DIR] [--build NAME] [--windows] [CASE ...]
    python3 bench/e_fidelity.py --holdout | --pulses | --starts | --phase [CASE ...]
    python3 bench/e_fidelity.py --first-steps | --tasks [CASE ...]

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

``--first-steps`` prints each stepper's first step, firmware beside model (ticks off).

``--set [CHIP:]FIELD=VALUE`` (repeatable) runs every view with another figure of build
e's timing (a field of ``fas.sim.timing.SimTiming``; CHIP: the profiles whose name
starts with it), e.g. ``--set atmega2560:fill_start_ticks=2190``: a variant measured
without a patch (docs/timing-model.md, "fourteenth pass").

``--tasks`` compares the pitch between two blocks across each ramp task (the task plus
the rest of the loop's pass) with the model's, task by task (paired where the model's
task falls between the two blocks of both), beside what the model's task did: the
queued entries it summed per running stepper (all but the running one, as the library's
``ticksInQueue()``), split into entries of one step or a pause and entries of more steps
(whose ticks the library multiplies by their steps), and the commands it planned.  Its
last line fits, over the tasks that plan commands, the firmware's pitch minus the
model's against the one-step entries summed: what such an entry costs the firmware
beside the model's ``fill_queued_entry_ticks``.  A last line fits all the cases given
together against the one-step entries summed, the one-step commands and the other
commands planned (plus a constant), leaving out tasks ``POOLED_OUTLIER_TICKS`` off the
first fit (a command planned a task apart).
"""

from __future__ import annotations

import argparse
import bisect
import dataclasses
import gzip
import re
import sys
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from fas.sim import SimBackend  # noqa: E402
from fas.sim import timing as sim_timing_module  # noqa: E402
from fas.sim.channel import SimChannel  # noqa: E402
from fas.sim.timing import SimTiming  # noqa: E402
from stepperdemo.demo import build as demo_build_module  # noqa: E402
from stepperdemo.program import make_program  # noqa: E402
from stepperdemo.scenarios.evaluate import (  # noqa: E402
    WINDOW_PERIOD_US,
    WINDOW_SPAN_US,
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


# named sets of ``--set`` (``--variant``): the variants of docs/timing-model.md by the
# names the passes give them
VARIANTS: dict[str, tuple[str, ...]] = {
    # timer 0, the ramp task and the console's first character at the firmware's phase
    # (sixteenth pass; its task phase as the eighteenth pass's U has it)
    "TH": ("boot_data_align=2", "atmega328p:boot_data_bytes=408",
           "atmega2560:boot_data_bytes=433", "atmega328p:boot_ticks=7309",
           "atmega2560:boot_ticks=11712", "atmega328p:setup_head_ticks=368",
           "atmega2560:setup_head_ticks=412"),
    # the UART's 63-byte ring and the task phases that go with it (eighteenth pass)
    "U": ("atmega328p:uart_tx_buffer=63", "atmega2560:uart_tx_buffer=63",
          "atmega328p:task_phase_ticks=67955", "atmega2560:task_phase_ticks=68714"),
    # the twenty-first pass's I M F K
    "IMFK": ("atmega328p:idle_task_ticks=429", "atmega2560:idle_task_ticks=512",
             "fill_cmd_maths=1", "atmega328p:fill_cmd_ticks=1741",
             "atmega328p:fill_dec_cmd_ticks=1802", "atmega2560:fill_cmd_ticks=1784",
             "atmega2560:fill_dec_cmd_ticks=1814", "fill_plan_ticks=11",
             "atmega328p:fill_coast_cmd_ticks=1712", "atmega2560:fill_coast_cmd_ticks=1750"),
    # the interrupts nested in the ramp task move its writes and queue starts
    "N2": ("atmega328p:task_nested_isrs=2", "atmega2560:task_nested_isrs=2"),
    # the start task's figures re-read from the replica's lone starts (twenty-eighth
    # pass): a one-step command, a pause, auto enable's bare pause, the CPU from the last
    # write to the queue's compare (startQueue() + 70), the task's CPU after it, and the
    # task's fixed part split into before the first write and after the last
    "R28": ("atmega328p:fill_single_ticks=1868", "atmega328p:fill_pause_ticks=1316",
            "atmega328p:fill_bare_pause_ticks=640", "atmega328p:fill_start_ticks=1045",
            "atmega328p:fill_start_tail_ticks=362", "atmega328p:fill_entry_ticks=379",
            "atmega328p:fill_exit_ticks=54",
            "atmega2560:fill_single_ticks=1922", "atmega2560:fill_pause_ticks=1332",
            "atmega2560:fill_bare_pause_ticks=697", "atmega2560:fill_start_ticks=1058",
            "atmega2560:fill_start_tail_ticks=308", "atmega2560:fill_entry_ticks=312",
            "atmega2560:fill_exit_ticks=205"),
    # a starting ramp's commands of several steps and the queue start after one
    # (thirty-second pass; the ATmega328P's replica only: no such start on the 2560's)
    "R32": ("atmega328p:fill_unstarted_multi_cmd_ticks=2115",
            "atmega328p:fill_start_after_cmd_ticks=1097"),
    # a running ramp's one-step commands apart from a starting one's (the replica's
    # single -> single pitches in tasks without a start: 1 831 / 1 866; 1 868 / 1 922
    # in a start task, twenty-eighth pass) and the fill's sum of a one-step entry
    # (the replica's 46, fourteenth pass) (thirty-second pass)
    "Q32": ("atmega328p:fill_single_ticks=1831", "atmega328p:fill_unstarted_cmd_extra_ticks=37",
            "atmega2560:fill_single_ticks=1866", "atmega2560:fill_unstarted_cmd_extra_ticks=56",
            "atmega328p:fill_queued_single_ticks=46"),
    # a running stepper's fixed fill work after its writes (thirty-second pass)
    "O32": ("fill_charges_after_writes=1",),
    # the step interrupt writes its next compare later where it takes up the next queue
    # entry: channel A 24 ticks, B and C 28 (the replica's interrupts, 328P and 2560: 49
    # / 54 against 25 / 26 cycles after the pin's clear; thirty-fourth pass)
    "P33": ("isr_ocr_next_ticks=24,28",),
}


def variant_settings(names: list[str]) -> list[str]:
    """The ``--set`` settings of the named variants (``--variant``), in order.  Raises
    ValueError on an unknown name."""
    out: list[str] = []
    for name in names:
        if name not in VARIANTS:
            raise ValueError(f"--variant {name!r}: not one of {', '.join(VARIANTS)}")
        out.extend(VARIANTS[name])
    return out


def set_timing(settings: list[str]) -> None:
    """Change figures of build e's timing for this process (``--set``): each setting is
    ``FIELD=VALUE`` (every chip of build e) or ``CHIP:FIELD=VALUE`` (the chips whose
    profile name starts with CHIP: ``atmega328p``, ``atmega32u4``, ``atmega2560``), a
    field of :class:`fas.sim.timing.SimTiming` - a figure to try, or one of the
    mechanisms it holds switched off (``fill_reads_queue_live``, ``task_nested_isrs``,
    docs/timing-model.md, "fourteenth pass") - or of StepperDemo's
    :class:`stepperdemo.demo.build.DemoBuild` (``wake_mid_pass``, "fifteenth pass").
    Raises ValueError on an unknown field."""
    fields = {f.name: f for f in dataclasses.fields(SimTiming)}
    demo_fields = {f.name: f for f in dataclasses.fields(demo_build_module.DemoBuild)}
    for setting in settings:
        chip, _, assignment = setting.rpartition(":")
        name, sep, value = assignment.partition("=")
        if sep and name not in fields and name in demo_fields:  # StepperDemo's own figures
            table = demo_build_module.BY_BUILD["e"]
        elif not sep or name not in fields:
            raise ValueError(f"--set {setting!r}: not FIELD=VALUE with a SimTiming field "
                             "(or a DemoBuild field)")
        else:
            table = sim_timing_module.BY_BUILD["e"]
        current = getattr(next(iter(table.values())), name)
        new: object
        if isinstance(current, bool):
            new = value.lower() in ("1", "true", "yes")
        elif isinstance(current, tuple):  # a figure per channel: comma-separated
            new = tuple(int(x) for x in value.split(","))
        else:
            new = int(value)
        chips = [k for k in table if k.startswith(chip)]
        if not chips:
            raise ValueError(f"--set {setting!r}: no chip of build e named {chip!r}...")
        for k in chips:
            table[k] = dataclasses.replace(table[k], **{name: new})


# --replay-starts: per input, the firmware's first block of each window (ticks)
REPLAY_STARTS: dict[tuple[str, str], list[int]] = {}


def replay_starts(conf: Path) -> None:
    """Make every run put each window's first block at the firmware's (``--replay-starts``:
    an oracle, not a model; docs/timing-model.md, "twenty-second pass")."""
    for case in CASES:
        folder = conf / case
        fw = firmware_blocks(folder)
        if fw:
            key = ((folder / "input.txt").read_text().strip(), PROFILE.get(case, "atmega328p"))
            REPLAY_STARTS[key] = window_firsts(fw)


def _replay(backend: SimBackend, firsts: list[int]) -> None:
    """Delay the model's first block of each window to the firmware's first block of
    the same window (never earlier than the model's)."""
    m = backend.machine
    block = backend.block_interrupts
    last = [-(1 << 62)]
    window = 256_000 * TICKS_PER_US

    def replayed(ticks: int) -> None:
        if m.now - last[0] > 50_000 * TICKS_PER_US:
            fw = [t for t in firsts if t // window == m.now // window]
            if fw and fw[0] > m.now:
                m.consume(fw[0] - m.now)
        block(ticks)
        last[0] = m.now

    backend.block_interrupts = replayed  # type: ignore[method-assign]


# --align-first-steps: per input, ticks added to each step pin's first queue start
ALIGN_FIRST_STEPS: dict[tuple[str, str], dict[int, int]] = {}
_ALIGNING: dict[int, dict[int, int]] = {}  # per machine (id): the shifts of its run


def align_first_steps(conf: Path) -> None:
    """Make every run start each stepper's first queue where its first step comes at
    the firmware's first rise (``--align-first-steps``: an oracle, not a model; the
    shift is added to the ramp task's time line at that start)."""
    plain_start = SimChannel.start

    def start(ch: SimChannel) -> None:
        shifts = _ALIGNING.get(id(ch.m))
        if shifts and not ch.starts and ch.m.in_task and ch.step_pin in shifts:
            ch.m.task_offset += shifts[ch.step_pin]
        plain_start(ch)

    SimChannel.start = start  # type: ignore[method-assign]
    for case in CASES:
        folder = conf / case
        if not (folder / "input.txt").exists():
            continue
        inp, profile = (folder / "input.txt").read_text().strip(), PROFILE.get(case, "atmega328p")
        shifts: dict[int, int] = {}
        for _ in range(3):  # an interrupt the shift moves across can leave a rest
            ALIGN_FIRST_STEPS[inp, profile] = shifts
            backend = run_model(inp, profile, build_of(case))
            for sp in stepper_pins(backend.profile):
                path = folder / f"steps_{sp.letter}.tsv.gz"
                if path.exists():
                    fw, ours = read_reference_track(path)[0], step_times_us(backend, sp.step)
                    if fw and ours:
                        off = round((fw[0] - ours[0]) * TICKS_PER_US)
                        shifts = {**shifts, sp.step: shifts.get(sp.step, 0) + off}
        ALIGN_FIRST_STEPS[inp, profile] = shifts


def run_model(inp: str, profile: str, build: str,
              blocks: list[tuple[int, int]] | None = None) -> SimBackend:
    backend = SimBackend(profile, record=True, build=build)
    if (inp, profile) in REPLAY_STARTS:
        _replay(backend, REPLAY_STARTS[inp, profile])
    if (inp, profile) in ALIGN_FIRST_STEPS:
        _ALIGNING[id(backend.machine)] = ALIGN_FIRST_STEPS[inp, profile]
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


def window_split(rises: list[int], blocks: list[tuple[int, int]]) -> dict[int, list[int]]:
    """Per `e` window (its number; rises outside every window under -1): [rises, pulses
    held by a block, their summed ticks from the rise to the block's end]."""
    period, span = round(WINDOW_PERIOD_US * TICKS_PER_US), round(WINDOW_SPAN_US * TICKS_PER_US)
    out: dict[int, list[int]] = {}
    for c in rises:
        k = c // period
        n, extra = held_extra([c], blocks)
        cell = out.setdefault(k if c - k * period < span else -1, [0, 0, 0])
        cell[0] += 1
        cell[1] += n
        cell[2] += extra
    return out


def _window_rows(case: str, letter: str, fw: dict[int, list[int]], model: dict[int, list[int]],
                 gaps_fw: dict[int, int], gaps: dict[int, int]) -> None:
    print(f"    {case} {letter} per window: rises fw/model | held | their extra (us) "
          "| extra per held pulse (us) | gaps")
    for k in sorted(set(fw) | set(model), key=lambda k: (k < 0, k)):
        a, b = fw.get(k, [0, 0, 0]), model.get(k, [0, 0, 0])
        name = "outside" if k < 0 else f"window {k}"
        per = [x[2] / TICKS_PER_US / max(1, x[1]) for x in (a, b)]
        print(f"      {name}: {a[0]}/{b[0]} | {a[1]}/{b[1]} | {a[2] / TICKS_PER_US:.0f}/"
              f"{b[2] / TICKS_PER_US:.0f} | {per[0]:.1f}/{per[1]:.1f} "
              f"| {gaps_fw.get(k, 0)}/{gaps.get(k, 0)}")


def firmware_high_totals(folder: Path) -> dict[str, int]:
    """Total High (us) per step pin letter, from the firmware run's ``result.txt``."""
    text = (folder / "result.txt").read_text()
    return {m.group(1): int(m.group(2))
            for m in re.finditer(r"Step(\w):.*Total High=(\d+)us", text)}


def pulses(conf: Path, cases: list[str], windows: bool = False) -> int:
    """Pulse-high totals split into the blocks' part and the plain pulses' mean
    (``windows``: and per `e` window, with the rises and gaps of each)."""
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
            if windows:
                _window_rows(case, sp.letter, window_split(fw_rises, fw_blocks),
                             window_split(our_rises, ours), gaps_per_window(wrap_gaps(ref)),
                             gaps_per_window(wrap_gaps([t / TICKS_PER_US for t in our_rises])))
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
    pairs: list[tuple[int, int]] = []
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
        if case != "e15":  # the 32U4's timer 0 lies elsewhere (no T H for it)
            pairs += [(f, o) for f, o in zip(*rel, strict=False)
                      if f < STARTS_PLAIN and o < STARTS_PLAIN]
    print(start_histograms(pairs))
    return 0


STARTS_PLAIN = 1000  # a window start beyond this waits for a ramp task or a print
STARTS_BIN = 100


def start_histograms(pairs: list[tuple[int, int]]) -> str:
    """The window starts' distributions, firmware beside model (the windows where both
    start within ``STARTS_PLAIN`` ticks: the loop's pass, not a task or a print), and
    their distance window by window (docs/timing-model.md, "twenty-second pass")."""
    if not pairs:
        return "no window starts both sides"
    lines = [f"windows starting within {STARTS_PLAIN} ticks on both sides: {len(pairs)}"]
    for name, values in (("firmware", [f for f, _ in pairs]), ("model", [o for _, o in pairs])):
        mean = sum(values) / len(values)
        sd = (sum((v - mean) ** 2 for v in values) / len(values)) ** 0.5
        c = Counter(v // STARTS_BIN * STARTS_BIN for v in values)
        lines.append(f"  {name:8s} mean {mean:.0f} sd {sd:.0f}: "
                     + " ".join(f"{b}:{c[b]}" for b in sorted(c)))
    dist = sum(abs(o - f) for f, o in pairs) / len(pairs)
    lines.append(f"  window by window, |model - firmware| {dist:.0f} ticks on average")
    return "\n".join(lines)


def first_steps(conf: Path, cases: list[str]) -> int:
    """Each stepper's first step: firmware beside model."""
    print("| case | pin | first step fw (us) | model (us) | off (ticks) |")
    print("| --- " * 5 + "|")
    for case in cases:
        folder = conf / case
        backend = run_model((folder / "input.txt").read_text().strip(),
                            PROFILE.get(case, "atmega328p"), build_of(case))
        for sp in stepper_pins(backend.profile):
            path = folder / f"steps_{sp.letter}.tsv.gz"
            if not path.exists():
                continue
            fw, ours = read_reference_track(path)[0], step_times_us(backend, sp.step)
            if fw and ours:
                off = round((ours[0] - fw[0]) * TICKS_PER_US)
                print(f"| {case} | {sp.letter} | {fw[0]:.3f} | {ours[0]:.3f} | {off:+d} |")
    return 0


TASK_CROSSING = (1700, 32768)  # a pitch between two blocks across a ramp task (ticks)


def _crossings(blocks: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """(end of the block before, start of the block after) of every pitch across a task."""
    return [(blocks[i][1], blocks[i + 1][0]) for i in range(len(blocks) - 1)
            if TASK_CROSSING[0] <= blocks[i + 1][0] - blocks[i][1] < TASK_CROSSING[1]]


def _crossing_at(crossings: list[tuple[int, int]], t: int, early: int) -> int | None:
    """The pitch of the crossing whose stretch holds tick ``t`` (``early`` ticks of
    slack before its first block's end), or None."""
    i = bisect.bisect_right(crossings, (t + early, 1 << 62)) - 1
    if i >= 0 and crossings[i][0] - early <= t < crossings[i][1]:
        return crossings[i][1] - crossings[i][0]
    return None


def tasks(conf: Path, cases: list[str]) -> int:
    """Per ramp task inside a window: the firmware's pitch across it beside the model's,
    and what the model's task summed and planned."""
    plain_task, plain_added = SimBackend._task, SimChannel.entry_added  # noqa: SLF001
    # per task: tick, one-step entries, longer entries, commands, commands of one step
    log: list[list[int]] = []
    pooled: list[tuple[int, int, int, int]] = []

    def task(self: SimBackend, index: int) -> None:
        ones = longer = 0
        for ch in self.channels:
            if ch.running:
                q = ch.q
                for k in range(1, (q.next_write_idx - q.read_idx) & 0xFF):
                    if q.entries[(q.read_idx + k) % q.queue_len].total_steps > 1:
                        longer += 1
                    else:
                        ones += 1
        log.append([self.machine.now, ones, longer, 0, 0])
        plain_task(self, index)

    def added(ch: SimChannel) -> None:
        if ch.m.in_task and log:
            log[-1][3] += 1
            q = ch.q
            if q.entries[(q.next_write_idx - 1) % q.queue_len].total_steps == 1:
                log[-1][4] += 1  # a command of one step
        plain_added(ch)

    SimBackend._task = task  # type: ignore[method-assign]  # noqa: SLF001
    SimChannel.entry_added = added  # type: ignore[method-assign]
    try:
        for case in cases:
            folder = conf / case
            fw = firmware_blocks(folder)
            if not fw:
                continue
            log.clear()
            ours: list[tuple[int, int]] = []
            run_model((folder / "input.txt").read_text().strip(),
                      PROFILE.get(case, "atmega328p"), build_of(case), ours)
            pooled += _tasks_table(case, fw, ours, log)
        _pooled_fit(pooled)
    finally:
        SimBackend._task = plain_task  # type: ignore[method-assign]  # noqa: SLF001
        SimChannel.entry_added = plain_added  # type: ignore[method-assign]
    return 0


def _tasks_table(case: str, fw: list[tuple[int, int]], ours: list[tuple[int, int]],
                 log: list[list[int]]) -> list[tuple[int, int, int, int]]:
    """Print the case's tasks; return (one-step entries summed, commands of one step,
    longer commands, fw - model) of each paired task that plans commands."""
    cf, cm = _crossings(fw), _crossings(ours)
    rows = []
    planned = []
    for t, ones, longer, cmds, singles in log:
        pm = _crossing_at(cm, t, 0)
        pf = _crossing_at(cf, t, 600)  # the firmware's task may start up to ~250 later
        if pm is not None and pf is not None:
            rows.append((t, pf, pm, ones, longer, cmds))
            if cmds:
                planned.append((ones, singles, cmds - singles, pf - pm))
    print(f"{case}: {len(rows)} tasks inside windows (tick, pitch fw / model, fw - model, "
          "entries summed: one-step / longer, commands planned); those with one-step "
          "entries summed:")
    for t, pf, pm, ones, longer, cmds in rows:
        if ones:
            print(f"    {t / 16000:9.3f} ms  {pf:6d} / {pm:6d}  {pf - pm:+6d}  "
                  f"{ones:2d} / {longer:2d}  {cmds}")
    fit = [(ones, pf - pm) for _, pf, pm, ones, _, cmds in rows
           if cmds and abs(pf - pm) < 1500]  # larger: a command planned a task apart
    n = len(fit)
    if n < 2:
        return planned
    sx = sum(x for x, _ in fit)
    sy = sum(y for _, y in fit)
    sxx = sum(x * x for x, _ in fit)
    sxy = sum(x * y for x, y in fit)
    den = n * sxx - sx * sx
    if den:
        slope = (n * sxy - sx * sy) / den
        print(f"    fit over {n} tasks that plan commands: fw - model = "
              f"{(sy - slope * sx) / n:+.0f} {slope:+.1f} per one-step entry summed")
    return planned


POOLED_OUTLIER_TICKS = 1000  # a larger residual: a command planned a task apart


def _solve(a: list[list[float]], b: list[float]) -> list[float] | None:
    """Solve the small linear system a x = b (Gauss-Jordan, partial pivoting)."""
    n = len(b)
    m = [row[:] + [b[i]] for i, row in enumerate(a)]
    for c in range(n):
        p = max(range(c, n), key=lambda r: abs(m[r][c]))
        if abs(m[p][c]) < 1e-9:
            return None
        m[c], m[p] = m[p], m[c]
        for r in range(n):
            if r != c:
                f = m[r][c] / m[c][c]
                m[r] = [x - f * y for x, y in zip(m[r], m[c], strict=True)]
    return [m[i][n] / m[i][i] for i in range(n)]


def _pooled_fit(rows: list[tuple[int, int, int, int]]) -> None:
    """Least squares over the tasks of all cases given that plan commands: fw - model
    against the one-step entries summed, the commands of one step and the longer
    commands planned (plus a constant); rows whose residual exceeds
    POOLED_OUTLIER_TICKS (a command planned a task apart) are dropped and the fit redone
    once."""
    def fit(use: list[tuple[int, int, int, int]]) -> list[float] | None:
        xs = [(o, s, lg, 1) for o, s, lg, _ in use]
        ata = [[sum(x[i] * x[j] for x in xs) for j in range(4)] for i in range(4)]
        aty = [sum(x[i] * r[3] for x, r in zip(xs, use, strict=True)) for i in range(4)]
        return _solve(ata, aty)

    sol = fit([r for r in rows if abs(r[3]) < 5 * POOLED_OUTLIER_TICKS])
    if sol is None:
        return
    kept = [r for r in rows if abs(r[3] - (sol[0] * r[0] + sol[1] * r[1] + sol[2] * r[2]
                                            + sol[3])) < POOLED_OUTLIER_TICKS]
    sol = fit(kept) or sol
    print(f"pooled fit over {len(kept)} of {len(rows)} tasks that plan commands: fw - model"
          f" = {sol[0]:+.1f} per one-step entry summed {sol[1]:+.1f} per command of one "
          f"step {sol[2]:+.1f} per other command (a pause or more steps) {sol[3]:+.0f}")


# the scenario files' tolerance on an `e` run's pulse-high total (sequences/conformance/e*.toml:
# the widest upstream's expect.txt grant a Total High on the 328P, test_sd_05's 800 of 55 477 us)
HIGH_TOTAL_PCT = 1.44
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
    n_win = in_win = n_high = 0
    high_off = 0.0  # summed |model's mean over the phases - firmware| / tolerance
    for case in cases:
        folder = conf / case
        inp = (folder / "input.txt").read_text().strip()
        profile = PROFILE.get(case, "atmega328p")
        counts: dict[str, dict[int, set[int]]] = {}
        fw_win: dict[str, dict[int, int]] = {}
        highs: dict[str, list[float]] = {}  # pulse-high total (us) per phase
        fw_high = firmware_high_totals(folder)
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
                highs.setdefault(sp.letter, []).append(
                    pin_activity(backend, sp.step).high_total_us)
                per = counts.setdefault(sp.letter, {})
                for k in set(w) | set(fw_win[sp.letter]) | set(per):
                    per.setdefault(k, set()).add(w.get(k, 0))
        for letter, per in counts.items():
            cells = []
            for k in sorted(per):
                lo, hi, f = min(per[k]), max(per[k]), fw_win[letter].get(k, 0)
                n_win += 1
                in_win += lo <= f <= hi
                cells.append(f"{f} in {lo}-{hi}" if lo <= f <= hi else f"{f} NOT in {lo}-{hi}")
            print(f"{case} {letter}: firmware's count per window against the model's over "
                  f"0-{PHASE_SPAN_TICKS} ticks: {'; '.join(cells)}")
            if letter in fw_high:
                print("    " + high_spread(fw_high[letter], highs[letter]))
                tol = fw_high[letter] * HIGH_TOTAL_PCT / 100 + 1
                n_high += 1
                high_off += abs(sum(highs[letter]) / len(highs[letter]) - fw_high[letter]) / tol
    print(f"windows whose firmware count lies in the model's range: {in_win} of {n_win}; "
          f"pulse-high totals: the model's mean over the phases off by "
          f"{high_off / max(1, n_high):.2f} tolerances on average ({n_high} pins)")
    return 0


def high_spread(fw: int, totals: list[float], pct: float = HIGH_TOTAL_PCT) -> str:
    """The pulse-high totals the model makes over the window start's phases against the
    firmware's total and the scenario files' tolerance (``pct`` of it, + 1 us)."""
    tol = fw * pct / 100 + 1
    inside = sum(abs(t - fw) <= tol for t in totals)
    mean = sum(totals) / len(totals)
    return (f"pulse-high total: firmware {fw} +- {tol:.0f} us, model {min(totals):.0f}-"
            f"{max(totals):.0f} (mean {mean:.0f}, {mean - fw:+.0f}), inside at {inside} of "
            f"{len(totals)} phases")


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
    ap.add_argument("--windows", action="store_true", help="print the gap start times "
                    "(with --pulses: the split per `e` window)")
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
    ap.add_argument("--first-steps", action="store_true",
                    help="each stepper's first step, firmware beside model")
    ap.add_argument("--tasks", action="store_true",
                    help="pitches across each ramp task, firmware beside model, with "
                    "the entries the model's task summed and the commands it planned")
    ap.add_argument("--start-shift", default="",
                    help="with --phase: ticks added to the first step of the 1st, 2nd, "
                    "... queue start of a ramp task, comma-separated")
    ap.add_argument("--replay-starts", action="store_true",
                    help="an oracle: each window's first block at the firmware's measured "
                    "tick (with timer 0 at the firmware's phase: the sixteenth pass's T H)")
    ap.add_argument("--align-first-steps", action="store_true",
                    help="an oracle: each stepper's first step at the firmware's (its "
                    "first queue start shifted by the model's offset)")
    ap.add_argument("--set", action="append", default=[], metavar="[CHIP:]FIELD=VALUE",
                    help="a figure or mechanism of build e's timing (SimTiming field) "
                    "for this run, e.g. fill_reads_queue_live=1, "
                    "atmega2560:fill_start_ticks=2190; repeatable")
    ap.add_argument("--variant", action="append", default=[], choices=sorted(VARIANTS),
                    help="a named set of --set settings (docs/timing-model.md: TH, U, "
                    "IMFK, N2, R28, R32, Q32, O32, P33), applied before --set; repeatable")
    args = ap.parse_args(argv)
    try:
        set_timing(variant_settings(args.variant) + args.set)
    except ValueError as exc:
        print(f"e_fidelity: {exc}", file=sys.stderr)
        return 2
    conf = Path(args.conformance)
    if args.align_first_steps:
        align_first_steps(conf)
    if args.replay_starts:
        replay_starts(conf)
    missing = [c for c in (args.cases or CASES) if not (conf / c / "input.txt").is_file()]
    if missing:
        print(f"e_fidelity: no firmware run {', '.join(missing)} in {conf} "
              "(give the conformance folder with --conformance DIR)", file=sys.stderr)
        return 2
    e_cases = args.cases or [c for c in CASES if c.startswith("e")]
    if args.starts:
        return starts(conf, e_cases)
    if args.first_steps:
        return first_steps(conf, e_cases)
    if args.tasks:
        return tasks(conf, e_cases)
    if args.phase:
        shifts = tuple(int(x) for x in args.start_shift.split(",") if x.strip())
        return phase(conf, e_cases, shifts)
    if args.pulses:
        return pulses(conf, args.cases or [c for c in CASES if c.startswith("e")],
                      args.windows)
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
