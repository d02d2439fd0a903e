"""The VCD files a user opens in PulseView, sigrok-cli or GTKWave (issue 26, item 5).

sigrok's VCD input expands a file into samples of its time unit, so its cost grows with
duration / unit: the console writes microseconds by default (``--vcd-timescale``,
``/vcd FILE [UNIT]``; ``exact``: the unit in which every tick is exact).  At 1 us every
step, dir and enable edge stays (the shortest step pulse of any profile is 1 us); a
change that falls on the one before on its pin is counted and said.  The files are read
back with third-party readers: pyvcd's tokenizer and, where installed, sigrok-cli.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from rigs.console import advance, make_console
from rigs.vcd import Vcd, read_vcd_pyvcd
from stepperdemo.front.cli import EXIT_OK, EXIT_USAGE, main
from stepperdemo.scenarios.runner import main as run_main
from stepperdemo.watch.options import is_vcd_unit, vcd_unit

ESP32_FAST = "M1 A1000000 H200000 R3000 W"  # 200 kHz: 1 us pulses, 16 ticks
AVR_MOVE = "M1 A1000 V100 R3200 W"


def report_pulses(lines: list[str] | str) -> list[int]:
    text = lines if isinstance(lines, str) else "\n".join(lines)
    return [int(n) for n in re.findall(r"^  pulses +(\d+) ", text, re.MULTILINE)]


def zero_width(vcd: Vcd) -> int:
    """Changes at the time of the one before on the same signal, as read from the file."""
    return sum(a[0] == b[0] for edges in vcd.changes.values()
               for a, b in zip(edges, edges[1:], strict=False))


def sigrok_rising(path: Path, signal: str) -> int:
    """Rising edges of ``signal`` as sigrok-cli's counter decoder counts them."""
    res = subprocess.run(["sigrok-cli", "-I", "vcd", "-i", str(path), "-P",
                          f"counter:data={signal}:data_edge=rising", "-A", "counter"],
                         capture_output=True, text=True, timeout=120, check=True)
    counts = re.findall(r"counter-1: (\d+)", res.stdout)
    return int(counts[-1]) if counts else 0


def need_sigrok() -> None:
    if shutil.which("sigrok-cli") is None:
        if os.environ.get("CI") == "true":  # .ci/run installs it
            pytest.fail("sigrok-cli is not installed")
        pytest.skip("sigrok-cli is not installed (apt-get install sigrok-cli)")


def test_units_as_given_on_the_command_line_or_to_vcd():
    assert vcd_unit(None) == "1 us"  # the default
    assert vcd_unit("exact") is None and vcd_unit(" Exact ") is None  # the writer's exact
    assert vcd_unit("1us") == "1 us" and vcd_unit("100 ns") == "100 ns"
    assert all(is_vcd_unit(u) for u in ("1us", "10 ns", "100ps", "1 s", "exact"))
    assert not any(is_vcd_unit(u) for u in ("3 us", "1 parsec", "exactly", ""))


@pytest.mark.parametrize(("arch", "line"), [("atmega328p", AVR_MOVE), ("esp32", ESP32_FAST)])
def test_cli_vcd_is_in_microseconds_with_every_pulse_of_the_report(arch, line, tmp_path,
                                                                   capsys):
    path = tmp_path / "run.vcd"
    assert main(["--arch", arch, "-c", line, "--vcd", str(path), "--report"]) == EXIT_OK
    out, err = capsys.readouterr()
    vcd = read_vcd_pyvcd(str(path))
    assert vcd.timescale == "1 us"
    (pulses, *_) = report_pulses(out)
    assert len(vcd.rising("StepA")) == len(vcd.falling("StepA")) == pulses > 0
    # the stepper's pulses all have a width; what the unit swallows is counted and said
    steps = vcd.edges("StepA")
    assert all(b[0] > a[0] for a, b in zip(steps, steps[1:], strict=False))
    assert "shorter than" not in err  # no pulse of these runs is shorter than 1 us
    exact = tmp_path / "exact.vcd"
    assert main(["--arch", arch, "-c", line, "--vcd", str(exact), "--vcd-timescale",
                 "exact"]) == EXIT_OK
    assert "shorter than" not in capsys.readouterr().err
    vcd_exact = read_vcd_pyvcd(str(exact))
    assert vcd_exact.timescale == "100 ps"
    # the same edges, rounded down to the microsecond (10 000 x 100 ps); changes in one
    # tick (ESP32: pins StepperDemo's wiring shares, set twice at start) are so in both
    for name in vcd.ids:
        assert vcd.edges(name) == [(t // 10_000, v) for t, v in vcd_exact.edges(name)], name
    assert zero_width(vcd) == zero_width(vcd_exact)


def test_pwm_highs_shorter_than_the_unit_are_counted_and_said(tmp_path, capsys):
    # M68 Q0.3: 0.6 us high in every 200 us period of a 5 kHz PWM (ESP32: 13 bits)
    program = tmp_path / "pwm.gcode"
    program.write_text("M68 E0 Q0.3\nG4 P0.1\n")
    path = tmp_path / "pwm.vcd"
    assert main(["gcode", "--arch", "esp32", str(program), "--vcd", str(path)]) == EXIT_OK
    err = capsys.readouterr().err
    vcd = read_vcd_pyvcd(str(path))
    falls = len(vcd.falling("Aout0"))
    assert falls >= 499  # 100 ms of 200 us periods
    assert zero_width(vcd) == falls  # each high starts and ends in one microsecond
    assert f"{path}: {falls} pulse(s) or gap(s) shorter than 1 us start and end" in err
    exact = tmp_path / "exact.vcd"
    assert main(["gcode", "--arch", "esp32", str(program), "--vcd", str(exact),
                 "--vcd-timescale", "exact"]) == EXIT_OK
    assert "shorter than" not in capsys.readouterr().err
    vcd = read_vcd_pyvcd(str(exact))
    assert len(vcd.falling("Aout0")) == falls and zero_width(vcd) == 0
    highs = {f - r for r, f in zip(vcd.rising("Aout0"), vcd.falling("Aout0"), strict=False)}
    assert 0 < min(highs) <= max(highs) < 10_000  # 0.56 .. 0.63 us, in 100 ps


def test_console_vcd_takes_a_unit_and_the_command_lines_default(tmp_path):
    console = make_console(tmp_path, vcd_timescale="100 ns")
    console.handle_line(AVR_MOVE.removesuffix(" W"))
    advance(console, 6.0)
    files = {}
    for name, unit in (("given", ""), ("us", " 1us"), ("spaced", " 1 us"), ("exact", " exact")):
        files[name] = tmp_path / f"{name}.vcd"
        console.handle_line(f"/vcd {files[name]}{unit}")
        assert console.lines[-1].startswith(f"wrote {files[name]}: "), console.lines[-1]
    n = len(console.lines)
    console.handle_line("/report")
    (pulses, *_) = report_pulses(console.lines[n:])
    assert pulses == 3200
    vcds = {name: read_vcd_pyvcd(str(path)) for name, path in files.items()}
    assert {name: v.timescale for name, v in vcds.items()} == {
        "given": "100 ns", "us": "1 us", "spaced": "1 us", "exact": "100 ps"}
    exact = vcds["exact"].rising("StepA")
    assert len(exact) == pulses
    assert vcds["given"].rising("StepA") == [t // 1000 for t in exact]
    assert vcds["us"].rising("StepA") == [t // 10_000 for t in exact]


def test_console_without_the_option_writes_microseconds(tmp_path):
    console = make_console(tmp_path)
    console.handle_line("M1 A10000 V100 R1000")
    advance(console, 1.0)
    path = tmp_path / "recent.vcd"
    console.handle_line(f"/vcd {path}")
    vcd = read_vcd_pyvcd(str(path))
    assert vcd.timescale == "1 us" and len(vcd.rising("StepA")) == 1000


def test_trace_on_recording_is_written_in_the_unit_asked_for(tmp_path):
    # /trace on spools the exact VCD while it records; /vcd rounds the copy down to the unit
    console = make_console(tmp_path)
    console.handle_line("/trace on")
    console.handle_line("M1 A10000 V100 R2000")
    advance(console, 2.0)
    console.handle_line("/trace off")
    us, exact = tmp_path / "us.vcd", tmp_path / "exact.vcd"
    console.handle_line(f"/vcd {us}")
    console.handle_line(f"/vcd {exact} exact")
    a, b = read_vcd_pyvcd(str(us)), read_vcd_pyvcd(str(exact))
    assert (a.timescale, b.timescale) == ("1 us", "100 ps")
    for name in ("StepA", "DirA", "EnableA"):
        assert a.edges(name) == [(t // 10_000, v) for t, v in b.edges(name)], name
    assert len(a.rising("StepA")) == 2000
    assert a.times == sorted(set(a.times))  # one timestamp per instant, in order
    assert a.end == b.end // 10_000


def test_esp32_console_vcd_pulses_counted_by_sigrok_equal_the_report(tmp_path):
    need_sigrok()
    console = make_console(tmp_path, arch="esp32")
    advance(console, 5.5)  # the ESP32 build waits 5 s for a pin configuration
    console.handle_line(ESP32_FAST.removesuffix(" W"))
    advance(console, 1.0)
    path = tmp_path / "esp32.vcd"
    console.handle_line(f"/vcd {path}")
    n = len(console.lines)
    console.handle_line("/report")
    (pulses, *_) = report_pulses(console.lines[n:])
    assert pulses == 3000
    assert len(read_vcd_pyvcd(str(path)).rising("StepA")) == pulses
    assert sigrok_rising(path, "StepA") == pulses  # 1 us pulses: none lost to the unit


def test_cli_vcd_read_by_sigrok(tmp_path, capsys):
    need_sigrok()
    path = tmp_path / "run.vcd"
    assert main(["-c", AVR_MOVE, "--vcd", str(path), "--report"]) == EXIT_OK
    (pulses, *_) = report_pulses(capsys.readouterr().out)
    assert sigrok_rising(path, "StepA") == pulses == 3200


def test_run_writes_microseconds_unless_told(tmp_path, capsys):
    scenario = tmp_path / "move.toml"
    scenario.write_text('name = "move"\ninput = "M1 A10000 V100 R300 W"\n'
                        "[steppers.A]\nposition = 300\n")
    assert run_main([str(scenario), "--vcd", str(tmp_path / "us")]) == EXIT_OK
    assert run_main([str(scenario), "--vcd", str(tmp_path / "exact"),
                     "--vcd-timescale", "exact"]) == EXIT_OK
    a = read_vcd_pyvcd(str(tmp_path / "us" / "move.vcd"))
    b = read_vcd_pyvcd(str(tmp_path / "exact" / "move.vcd"))
    assert (a.timescale, b.timescale) == ("1 us", "100 ps")
    assert a.rising("StepA") == [t // 10_000 for t in b.rising("StepA")]
    assert run_main([str(scenario), "--vcd", str(tmp_path), "--vcd-timescale",
                     "3 us"]) == EXIT_USAGE
    assert "--vcd-timescale '3 us'" in capsys.readouterr().err
