"""Fuzzing every console program: seeded random input keeps every invariant
(stepperdemo.fuzz).  StepperDemo (its g mode too), the G-code program and the winder run
a small seeded amount on every profile that hosts them; ``bench/fuzz.py`` runs more."""

import contextlib
import os
import re
import resource
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fas.arch import PROFILES
from fas.sim import SimBackend
from stepperdemo.fuzz import TARGETS, check_line, fuzz, fuzz_program, grammar_line, raw_line
from stepperdemo.fuzz.common import BYTES, LINE, Case, FuzzResult, PinTracker, StepTrack
from stepperdemo.fuzz.gcode import REPORT, SETTING_LINE, check_gcode, responses, status_reports
from stepperdemo.fuzz.winder import check_refusal, check_winder, refusing_profiles
from stepperdemo.program import make_program

ROOT = Path(__file__).resolve().parents[2]

# a small seeded amount by default, more in CI (CI=true), anything with FUZZ_LINES=N
LINES = int(os.environ.get("FUZZ_LINES", "300" if os.environ.get("CI") else "60"))


@pytest.mark.parametrize("arch", ["atmega328p", "atmega2560", "esp32", "sam_due", "atmega32u4",
                                  "atmega2560_timer5", "esp32_idf5", "esp32c3", "rp2040"])
def test_seeded_fuzz_lines_keep_the_invariants(arch):
    failures = [r for r in fuzz(LINES // 4, seed=7, arch_choice=(arch,)) if not r.ok]
    assert not failures, "\n".join(f"{r.line!r}: {r.violations}" for r in failures[:5])


FUZZ = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@FUZZ
@given(st.binary(min_size=1, max_size=120))
def test_raw_bytes_never_break_the_console(data):
    res = check_line(data, max_time_s=5)
    assert res.ok, res.violations


@FUZZ
@given(st.text(min_size=1, max_size=60))
def test_any_unicode_text_is_harmless(text):
    res = check_line(text, max_time_s=5)
    assert res.ok, res.violations


@FUZZ
@given(st.randoms(use_true_random=False))
def test_generated_grammar_lines(rng):
    line = grammar_line(rng)
    res = check_line(line, max_time_s=10)
    assert res.ok, (line, res.violations)
    line = raw_line(rng)
    res = check_line(line, max_time_s=10)
    assert res.ok, (line, res.violations)


# ---- regression tests for what the fuzzing found ----------------------------------
def test_position_invariant_is_checked_modulo_32_bits():
    # positions wrap at 2^31: "@" near the limit and a step over it must agree with
    # the pins (found by fuzzing: the checker itself forgot the wrap)
    res = check_line("M1 A1000 V100 @2147483647 + W", max_time_s=5)
    assert res.ok, res.violations


def test_direct_drive_steps_are_outside_the_auto_enable_rule():
    # `T` drives the pins itself; the library may auto-disable meanwhile (firmware too)
    res = check_line("M1 A100000 V100 R100 W T", arch="esp32", max_time_s=10)
    assert res.ok, res.violations


def test_direct_drive_of_a_stepper_sharing_a_direction_pin_changes_the_frame():
    # ESP32 demo wiring: steppers 1 and 2 share direction pin 18; `T` on stepper 2
    # toggles it while stepper 1 runs (firmware too) - not a library fault
    line = b"H2\ra7702\rU\rH32388\rN\rb\ra37067e3\rM2\rQ\rb\rT\rD1077130787361"
    res = check_line(line, "esp32", max_time_s=20)
    assert res.ok, res.violations


def test_configuring_another_steppers_direction_pin_changes_its_frame():
    # config mode gives stepper 2 stepper 1's direction pin with the other polarity
    res = check_line("e V21153 A100000 ? A1000 P314 c M2 M2 d5,0 M1", max_time_s=20)
    assert res.ok, res.violations


def test_auto_enable_switched_on_during_a_run_covers_the_queued_steps():
    # found by fuzzing: F (driver off), b (run), O (auto enable) left up to 20 ms of
    # queued steps running with the driver off
    line = b"j2147483647 J F a0 E25337 H33408 M9 ? b O P1050215827290 W"
    res = check_line(line, "esp32", max_time_s=10)
    assert res.ok, res.violations


def test_the_checker_follows_an_esp32_restart():
    # found by fuzzing: after `r` the chip reboots with new steppers at position 0,
    # while the pins recorded before still hold the old steps
    res = check_line("M1 A1000 V100 R300 W @5000 r", arch="esp32c6",
                     max_time_s=20)
    assert res.ok, res.violations


def test_raw_commands_then_a_reversing_move_on_the_sam_due():
    # found by fuzzing: sequence 13's raw steps, then 03's first move (back to 1, as
    # upstream: relative to the ramp's old target 0) queued while the channel waited
    # out the last raw step's period; the restart pulse was put before the interrupt
    # that toggled the direction for it
    res = check_line(b"t 05 13 R 03 05 00 09 x", "sam_due")
    assert res.ok, res.violations


# ---- every program on every profile --------------------------------------------------
RUNS = {"demo": 2, "gcode": 3, "winder": 5}  # per profile; more in CI, any with FUZZ_SCALE
SCALE = int(os.environ.get("FUZZ_SCALE", "2" if os.environ.get("CI") else "1"))
MAX_TIME_S = {"demo": 10.0, "gcode": 3.0, "winder": 3.0}  # simulated, per run
SEED = 11


@contextlib.contextmanager
def memory_ceiling(extra_mb: int = 1500):
    """A run that runs away with memory ends in MemoryError (a finding) instead of
    taking the machine: the address space is limited meanwhile."""
    soft, hard = resource.getrlimit(resource.RLIMIT_AS)
    with open("/proc/self/statm", encoding="ascii") as f:
        size = int(f.read().split()[0]) * resource.getpagesize()
    limit = size + extra_mb * 2**20
    if hard != resource.RLIM_INFINITY:
        limit = min(limit, hard)
    resource.setrlimit(resource.RLIMIT_AS, (limit, hard))
    try:
        yield
    finally:
        resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


@pytest.mark.parametrize("program,arch", [(p, a) for p, t in TARGETS.items()
                                          for a in t.profiles()])
def test_seeded_runs_of_every_program_keep_the_invariants(program, arch):
    with memory_ceiling():
        results = list(fuzz_program(program, RUNS[program] * SCALE, SEED, archs=(arch,),
                                    max_time_s=MAX_TIME_S[program]))
    failures = [(run, res) for run, res in results if not res.ok]
    assert not failures, "\n".join(f"run {run}: {res.describe()}: {res.violations[:2]}"
                                    for run, res in failures[:3])


def test_the_targets_cover_every_profile():
    assert TARGETS["demo"].profiles() == TARGETS["gcode"].profiles() == tuple(PROFILES)
    winder = set(TARGETS["winder"].profiles())
    assert winder | set(refusing_profiles()) == set(PROFILES)
    assert {"atmega328p", "atmega2560", "atmega32u4"} <= winder


def test_the_winder_refuses_every_other_profile_with_one_line():
    for arch in refusing_profiles():
        res = check_refusal(arch)
        assert res.ok and res.end == "refused", (arch, res.violations)


def _answers_settings_status_and_a_move(program: str, arch: str, script: str):
    backend = SimBackend(arch, record=True)
    app = make_program(program, backend, scripted=True)
    app.run_until(backend.now())
    x = next(s for s in app.steppers if s is not None)
    start = x.get_current_position()
    app.run_script(script, max_ticks=5 * backend.profile.ticks_per_s)
    text = bytes(app.transcript)
    assert b"$1=" in text or b"$100=" in text, text[-400:]
    assert status_reports(text) >= 2, text[-400:]
    lines = text.decode("latin-1").replace("\r", "").split("\n")
    reports = [ln for ln in lines if ln.startswith("<")]
    assert all(REPORT.match(r) for r in reports), reports  # Grbl's form, three axes at least
    settings = [ln for ln in lines if re.match(r"\$\d+=", ln)]
    assert len(settings) > 20 and all(SETTING_LINE.match(ln) for ln in settings), settings
    assert responses(text).count("ok") >= 4, text[-400:]  # $$, $100=1, G91, the move
    pins = StepTrack(backend, x.get_step_pin(), x.get_direction_pin(),
                     x.direction_pin_high_counts_up()).final
    assert x.get_current_position() - start == pins == 10


@pytest.mark.parametrize("arch", list(PROFILES))
def test_every_profiles_g_mode_answers_settings_status_and_a_move(arch):
    _answers_settings_status_and_a_move("demo", arch,
                                        "g\n$$\n?\n$100=1\nG91\nG1 X10 F6000\n?\nx\n")


@pytest.mark.parametrize("arch", list(PROFILES))
def test_every_profiles_gcode_program_answers_settings_status_and_a_move(arch):
    _answers_settings_status_and_a_move("gcode", arch, "$$\n?\n$100=1\nG91\nG1 X10 F6000\n?")


def test_a_very_slow_feed_is_answered_without_exhausting_memory():
    # the G-code program in a process of its own, with 600 MB of address space: the
    # move (X steps 6e5 s apart) is answered and the chip runs a second of it
    code = ("from fas.sim import SimBackend\n"
            "from stepperdemo.program import make_program\n"
            "b = SimBackend('atmega328p')\n"
            "p = make_program('gcode', b, scripted=True)\n"
            "p.feed(b'G1 X1 Y10 F0.0001\\n')\n"
            "p.run_until(b.profile.ticks_per_s)\n"
            "print(bytes(p.transcript).decode())\n")

    def limit():  # pragma: no cover - runs in the child
        resource.setrlimit(resource.RLIMIT_AS, (600 * 2**20, 600 * 2**20))

    run = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                         text=True, timeout=120, preexec_fn=limit)
    assert run.returncode == 0, run.stderr[-600:]
    assert "ok" in run.stdout.split()


@FUZZ
@given(st.binary(min_size=1, max_size=160))
def test_raw_bytes_never_break_the_gcode_program(data):
    res = check_gcode(Case(BYTES, chunks=((0, data),)), max_time_s=2)
    assert res.ok, res.violations


@FUZZ
@given(st.binary(min_size=1, max_size=120))
def test_raw_bytes_never_break_the_winder(data):
    res = check_winder(Case(BYTES, chunks=((0, data + b"\n"),)), max_time_s=2)
    assert res.ok, res.violations


# ---- the checks themselves ----------------------------------------------------------
def test_an_unanswered_gcode_line_is_a_violation():
    # the program's answers are counted against the lines: a line with content that
    # got no ok/error would be a lost line (as a character-counting sender sees it)
    res = check_gcode(Case(LINE, b"G91\nG1 X5 F600\n$$"), probe_session=False)
    assert res.ok and res.end == "idle", res.violations
    assert res.lines == 3


def test_the_pin_check_catches_a_library_that_disagrees_with_its_pins():
    # the library's position against the pins, with a library whose position is off by
    # five steps: at rest, and when a force stop claims to keep that position
    backend = SimBackend("atmega328p", record=True)
    app = make_program("winder", backend, scripted=True)
    app.run_until(0)
    res = FuzzResult(b"", "atmega328p", "winder")
    tracker = PinTracker(backend, app.steppers, res)
    s1 = app.steppers[0]
    s1.move(300)
    backend.run_for_ms(1000)
    tracker.check()
    assert res.ok, res.violations
    true_position = s1.get_current_position
    s1.get_current_position = lambda: true_position() - 5
    tracker.check()
    assert res.violations == ["stepper 1: position 295 but the pins counted 300 + declared 0"]
    s1.force_stop_and_new_position(s1.get_current_position())
    assert res.violations[1] == ("stepper 1: force stop at position 295, but the pins counted "
                                 "300 + declared 0")
    s1.force_stop_and_new_position(0)  # a new position: declared, not a claim
    assert len(res.violations) == 2


def test_bench_fuzz_runs_every_program_and_replays_a_run():
    # what users run: bench/fuzz.py with a number of runs per program, then a replay
    run = subprocess.run([sys.executable, "bench/fuzz.py", "--program", "gcode=4", "demo=2",
                          "winder=2", "--max-time", "2", "--jobs", "1", "--seed", "5"],
                         cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    assert re.search(r"^gcode +27 profiles +4 runs +\d+ lines +0 failures", run.stdout, re.M)
    assert re.search(r"^8 runs, \d+ input lines, 0 failures \(0 exceptions", run.stdout, re.M)
    n = len(refusing_profiles())
    assert f"refused with one line on {n} of {n} other profiles" in run.stdout
    replay = subprocess.run([sys.executable, "bench/fuzz.py", "--program", "gcode", "--seed",
                             "5", "--replay", "3", "--max-time", "2"], cwd=ROOT,
                            capture_output=True, text=True, timeout=300)
    assert replay.returncode == 0 and replay.stdout.startswith("[gcode "), replay.stdout
