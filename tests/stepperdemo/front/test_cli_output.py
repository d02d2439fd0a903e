"""What the command line prints: a closed pipe ends it quietly; `run` fits 80 columns."""

from __future__ import annotations

import io
import os
import subprocess
import sys

from rich.console import Console

from rigs import ROOT
from stepperdemo.front.cli import EXIT_CLOSED_PIPE
from stepperdemo.scenarios.runner import Check, ScenarioResult, print_results


def stepperdemo(*args: str) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(ROOT))
    return subprocess.Popen([sys.executable, "-m", "stepperdemo", *args], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def test_head_3_of_a_long_transcript_ends_quietly():
    # 60 usage texts are far more than a pipe holds: the program is still writing
    # when the reader leaves after three lines, as `| head -3` does
    proc = stepperdemo("-c", " ".join(["?"] * 60))
    lines = [proc.stdout.readline() for _ in range(3)]
    proc.stdout.close()
    rc = proc.wait(60)
    err = proc.stderr.read()
    assert lines[0].startswith(b"StepperDemo Version")
    assert rc == EXIT_CLOSED_PIPE
    assert err == b""


def test_run_and_subcommand_help_into_a_closed_pipe_end_quietly(tmp_path):
    scenario = tmp_path / "s.toml"
    scenario.write_text('name = "s"\ninput = "M1 A1000 V100 R30 W"\n[steppers.A]\nposition = 30\n')
    for args, codes in ((("run", str(scenario)), {EXIT_CLOSED_PIPE}),
                        # argparse's help printer itself ignores a closed pipe (exit 0)
                        (("device", "--help"), {0, EXIT_CLOSED_PIPE}),
                        (("--help",), {0, EXIT_CLOSED_PIPE})):
        proc = stepperdemo(*args)
        proc.stdout.close()  # the reader is gone before the first line
        rc = proc.wait(60)
        assert proc.stderr.read() == b"", args
        assert rc in codes, args


def _render(results, verbose: bool) -> list[str]:
    buf = io.StringIO()
    print_results(results, Console(file=buf, width=80, color_system=None), verbose=verbose)
    return buf.getvalue().splitlines()


def _check(what, expected, measured, dev=None, tol=None, ok=True) -> Check:
    return Check(what, expected, measured, dev, tol, ok)


def test_results_fit_80_columns_with_whole_names_and_only_useful_columns():
    long_names = ["test_seq_sd_02_328p", "test_sd_04_timing_328p_37k", "example_two_steppers_x"]
    results = [ScenarioResult(f"/x/{n}.toml", n, True,
                              checks=[_check("A position", 300, 300, 0, 0)] * 5)
               for n in long_names]
    results.append(ScenarioResult("/x/bad.toml", "during_motion_speed_change_12", False, checks=[
        _check("A position", 784, 790, 6, 2, ok=False),
        _check("A step time median |dev| us", 0, 0.062, 0.062, 1),
        _check("transcript contains", "Move steps 3000", False, ok=False)]))
    lines = _render(results, verbose=False)
    text = "\n".join(lines)
    assert max(len(line) for line in lines) <= 80
    for name in long_names + ["during_motion_speed_change_12"]:
        assert name in text  # never cut to "test_seq_sd_…"
    summary = lines[: next(i for i, ln in enumerate(lines) if "failed)" in ln) + 1]
    assert "expected" not in "\n".join(summary)  # nothing to say in the summary
    # only the failing scenario's failed checks are detailed, with their columns
    assert "A position" in text and "784" in text and "790" in text
    assert "median" not in text
    verbose = _render(results, verbose=True)
    assert max(len(line) for line in verbose) <= 80
    assert "A step time median |dev| us" in "\n".join(verbose)


def test_detail_table_drops_columns_without_values():
    res = ScenarioResult("/x/t.toml", "t", False, checks=[
        _check("transcript contains", "OK", False, ok=False)])
    head = next(ln for ln in _render([res], verbose=False) if ln.strip().startswith("check"))
    assert "expected" in head and "measured" in head
    assert "dev" not in head and "tol" not in head


def test_pin_config_answers_the_esp32_prompt_and_bad_values_get_one_line():
    """``--pin-config 1``: the Driver-Types wiring (ESP-IDF 5.3: RMT, I2S, MCPWM/PCNT)
    without the 5 s wait; where there is no prompt, or no such configuration, one line."""
    proc = stepperdemo("--arch", "esp32_idf5", "--pin-config", "1", "-c", "M3 A1000 V100 R50 W")
    out, err = proc.communicate(timeout=120)
    text = out.decode()
    assert proc.returncode == 0 and err == b""
    assert "Press number to select, else 0\r\nUsing config 1: Driver-Types\r\n" in text
    table = [ln for ln in text.splitlines() if ln.startswith((">> M", "   M"))][-3:]
    assert [ln.rsplit(" ", 1)[1] for ln in table] == ["RMT", "I2S_DIRECT", "MCPWM_PCNT"]
    assert table[2].startswith(">> M3: @50 ")
    for args, problem in ((("--pin-config", "1"), "offers no pin configurations"),
                          (("--arch", "esp32", "--pin-config", "2"),
                           "offers 0 (Test-HW), 1 (Driver-Types)")):
        proc = stepperdemo(*args, "-c", "M1")
        out, err = proc.communicate(timeout=120)
        lines = err.decode().splitlines()
        assert proc.returncode == 2 and out == b"" and len(lines) == 1
        assert problem in lines[0] and "Traceback" not in lines[0]


def test_a_line_longer_than_the_firmwares_ring_behind_a_held_w_says_what_it_dropped():
    # StepperDemo's 256-byte input ring: a held W re-reads itself while the line behind
    # it keeps coming in; once the ring is full the W's rewind skips a whole ring, as on
    # the chip.  The transcript stays the firmware's; stderr says what was lost.
    long_line = " ".join(["M1 A1000 V100 R10 W"] * 20)  # 399 characters
    proc = stepperdemo("-c", long_line)
    out, err = proc.communicate(timeout=120)
    assert proc.returncode == 0
    assert b">> M1: @80 " in out  # 8 of the 20 moves: the rest was skipped
    assert err.decode().strip() == (
        "stepperdemo: 256 input characters dropped, as the firmware drops them: its 256-byte "
        "input ring was full while a W held the line; split lines longer than 256 characters")
    fits = " ".join(["M1 A1000 V100 R10 W"] * 13)  # 259 characters: the ring keeps up
    proc = stepperdemo("-c", fits)
    out, err = proc.communicate(timeout=120)
    assert b">> M1: @130 " in out and err == b""
