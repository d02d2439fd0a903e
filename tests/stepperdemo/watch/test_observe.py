"""Watching a run: VCD trace, step CSV, timing report, plots (issue 6)."""

from __future__ import annotations

import struct
from dataclasses import dataclass
from pathlib import Path

import pytest

from fas.sim import SimBackend
from fas.sim.trace import IRQ_BLOCKED
from rigs import ROOT
from rigs.vcd import Vcd, read_vcd, read_vcd_pyvcd
from stepperdemo.demo.app import StepperDemo
from stepperdemo.front.cli import EXIT_OK, EXIT_USAGE, main
from stepperdemo.scenarios.scenario import tomllib  # tomli on Python 3.10
from stepperdemo.watch import observe, plots
from stepperdemo.watch.report import report_lines

README_MOVE = "M1 A1000 V100 R3200 W"

# lines that exercise every kind of pin activity; meaningful without sequence files
FIXED_LINES = [
    ("atmega328p", README_MOVE),
    ("atmega328p", "M1 A1000 V100 R3200 W R-3200 W M2 A5000 V200 R1000 W"),
    ("atmega328p", "e M1 A1000000 V40 R20000 W"),
    ("atmega328p", "r M1 A1000000 V40 R20000 W"),
    ("atmega328p", "M1 A100000 V50 f w200 S W M2 A20000 V80 b w100 X"),
    ("atmega328p", "M1 A50000 V60 R3000 M2 A40000 V70 R-2500 W M1 R-1000"),
    ("atmega328p", "M1 + + - N w10 F T"),
    ("atmega328p", "t M1 13 R W x"),
    ("atmega2560", "M3 A2000 V100 R800 W M2 A3000 V90 R-300"),
    ("esp32", "M1 A1000 V100 R500 W M2 A1000 V100 R-500 W"),
    ("sam_due", "M1 A1000 V100 R500 W"),
]


def sequence_files() -> list[Path]:
    return sorted((ROOT / "sequences").glob("**/*.toml"))


def sequence_params():
    params = []
    for path in sequence_files():
        with open(path, "rb") as f:
            data = tomllib.load(f)
        if "input" not in data:
            continue
        marks = [pytest.mark.long] if data.get("long") else []
        params.append(pytest.param(data.get("profile", "atmega328p"), data["input"],
                                   data.get("max_time_s", 600), marks=marks,
                                   id=str(path.relative_to(ROOT))))
    return params


@dataclass
class Run:
    backend: SimBackend
    app: StepperDemo
    obs: observe.Observers
    vcd: Vcd


def traced_run(arch: str, line: str, tmp_path, *, max_s: float = 600, **kw) -> Run:
    backend = SimBackend(arch)
    vcd = str(tmp_path / "run.vcd")
    obs = observe.attach(backend, vcd=vcd, **kw)
    app = StepperDemo(backend, scripted=True)
    app.run_script(line, firmware_end=True, max_ticks=int(max_s * backend.profile.ticks_per_s))
    obs.finish()
    return Run(backend, app, obs, read_vcd(vcd))


def assert_counts_match_simulator(run: Run) -> None:
    backend, obs, vcd = run.backend, run.obs, run.vcd
    pins = backend.machine.pins
    assert obs.stream.late_edges == 0
    assert vcd.times == sorted(vcd.times)
    for pin, names in obs.signals.items():
        if pin == IRQ_BLOCKED:
            continue
        for name in names:
            assert len(vcd.rising(name)) == pins.rising(pin), (name, pin)
            assert len(vcd.falling(name)) == pins.falling(pin), (name, pin)
    windows = vcd.rising("IrqBlocked")
    assert len(windows) <= backend.machine.irq_block_windows
    assert bool(windows) == bool(backend.machine.irq_block_windows)


def position_from_vcd(vcd, step: str, direction: str, up_level: int = 1) -> int:
    dir_edges = vcd.edges(direction)
    level, j, pos = vcd.initial[vcd.ids[direction]], 0, 0
    for t in vcd.rising(step):
        while j < len(dir_edges) and dir_edges[j][0] <= t:
            level = dir_edges[j][1]
            j += 1
        pos += 1 if level == up_level else -1
    return pos


# ------------------------------------------------------------------- VCD
def test_vcd_of_the_readme_move_has_its_3200_steps_and_position(tmp_path):
    run = traced_run("atmega328p", README_MOVE, tmp_path)
    backend, app, quick = run.backend, run.app, run.vcd
    vcd = read_vcd_pyvcd(str(tmp_path / "run.vcd"))  # pyvcd's own reader
    assert (vcd.ids, vcd.initial, vcd.changes, vcd.times) == (
        quick.ids, quick.initial, quick.changes, quick.times)
    assert len(vcd.rising("StepA")) == 3200
    assert len(vcd.falling("StepA")) == 3200
    assert vcd.rising("StepB") == []
    pins = backend.machine.pins
    for name, pin in (("DirA", 5), ("EnableA", 6), ("DirB", 7), ("EnableB", 8)):
        assert len(vcd.rising(name)) == pins.rising(pin)
        assert len(vcd.falling(name)) == pins.falling(pin)
    # the enable pin (LOW active) went LOW before the first step and stays there
    first_step = vcd.rising("StepA")[0]
    assert vcd.level_at("EnableA", first_step) == 0
    assert position_from_vcd(vcd, "StepA", "DirA") == 3200 == app.steppers[0].get_current_position()
    assert vcd.timescale == "100 ps"


@pytest.mark.parametrize("arch,line", FIXED_LINES, ids=[f"{a}:{x}" for a, x in FIXED_LINES])
def test_vcd_counts_equal_the_simulators_counters(arch, line, tmp_path):
    assert_counts_match_simulator(traced_run(arch, line, tmp_path, analyse=False))


@pytest.mark.parametrize("arch,line,max_s", sequence_params())
def test_vcd_counts_equal_the_simulators_counters_for_sequence_files(arch, line, max_s,
                                                                      tmp_path):
    assert_counts_match_simulator(traced_run(arch, line, tmp_path, max_s=max_s, analyse=False))


def test_two_steppers_positions_from_the_vcd(tmp_path):
    line = "M1 A1000 V100 R3200 W R-1200 W M2 A5000 V200 R-1000 W"
    vcd = traced_run("atmega328p", line, tmp_path).vcd
    assert position_from_vcd(vcd, "StepA", "DirA") == 2000
    assert position_from_vcd(vcd, "StepB", "DirB") == -1000


def test_shared_direction_pin_is_one_variable_with_an_alias(tmp_path):
    vcd = traced_run("esp32", "M1 A1000 V100 R300 W", tmp_path).vcd
    assert vcd.ids["DirA"] == vcd.ids["DirB"]  # both steppers use GPIO 18
    assert len(vcd.rising("StepA")) == 300


# ------------------------------------------------------------------- CSV
def test_steps_csv_has_one_row_per_step(tmp_path):
    csv = tmp_path / "steps.csv"
    rc = main(["-c", "M1 A1000 V100 R300 W R-100 W", "--steps-csv", str(csv)])
    assert rc == EXIT_OK
    rows = csv.read_text().splitlines()
    assert rows[0] == "time_us,stepper,direction,position,tick"
    data = [r.split(",") for r in rows[1:]]
    assert len(data) == 400
    assert [int(r[3]) for r in data[:300]] == list(range(1, 301))
    assert [int(r[3]) for r in data[300:]] == list(range(299, 199, -1))
    assert {r[2] for r in data[:300]} == {"1"} and {r[2] for r in data[300:]} == {"-1"}
    ticks = [int(r[4]) for r in data]
    assert ticks == sorted(ticks)
    assert all(float(r[0]) == int(r[4]) / 16 for r in data)


# ---------------------------------------------------------------- report
def figures(line: str, tmp_path, arch: str = "atmega328p"):
    """Stepper 1's figures and the observers of a traced run."""
    run = traced_run(arch, line, tmp_path)
    return run.obs.analysis.steppers[0], run.obs


def test_report_of_a_clean_move(tmp_path):
    m, obs = figures(README_MOVE, tmp_path)
    assert m.pulses == 3200 == m.channel_count("pulses")
    assert m.position == 3200
    assert m.dev_compared == 3199 and m.dev_late == m.dev_early == 0
    assert m.gaps == 0 and m.motions == 1 and m.restarts == 0
    # 3200 steps at 1000 steps/s^2 top out at sqrt(2*1000*1600) = 1789 steps/s
    assert 1750 < 16_000_000 / m.period_min < 1800
    assert 900 < m.acc_max < 1200 and 900 < m.dec_max < 1200
    # the pin falls 60 ticks after the step interrupt enters (build d's plain pulse read
    # from its replica, the default since the fiftieth pass; 61 before); where timer
    # 0's or the UART's interrupt holds the CPU at the compare, the pulse waits for it (up
    # to the rest of that interrupt; the firmware's longest: test_clean_moves_longest_pulse)
    assert m.high_min == 60
    assert 60 < m.high_max <= 60 + 120
    assert m.enables == 1 and len(m.enable_to_step) == 1
    text = "\n".join(report_lines(obs))
    assert f"pulse high   min 3.75 us, max {m.high_max / 16} us" in text
    assert "pulses       3200 (the channel counted 3200), net +3200 steps" in text
    assert "all 3199 step intervals as planned" in text
    assert "M2" not in text  # stepper 2 did nothing


@pytest.mark.xfail(strict=True, reason="the longest pulse 179 ticks (11.19 us: 11 whole us) "
                   "against the firmware's Max High 10 us (conformance test_sd_01a_328p) with "
                   "the eight of the forty-second to forty-seventh passes as build d's "
                   "default (fiftieth pass; 156 ticks, 9 whole us, before them, 171 with "
                   "the figures fitted before the fortieth).  Build d's replica of this very "
                   "line: 174 ticks, held by the UART's transmit interrupt entered 10 ticks "
                   "before the rise (test_sd_01a's own: 163, the same); the model's: a "
                   "transmit interrupt requested 5 ticks before the rise, a draw of the W "
                   "pass chain's phase (forty-eighth pass)")
def test_clean_moves_longest_pulse_as_the_firmware(tmp_path):
    m, _ = figures(README_MOVE, tmp_path)
    assert m.high_max == 179  # (the value the reason names)
    assert int(m.high_max / 16) == 10  # whole us, as upstream's Max High


def test_report_shows_the_e_injection_as_late_steps_gaps_and_long_pulses(tmp_path):
    m, obs = figures("e M1 A1000000 V40 R20000 W", tmp_path)
    missed = m.channel_count("missed_compares")
    assert missed > 0
    assert m.dev_late == missed  # each timer wrap makes one step late
    assert m.dev_max_late == 65536  # by one 16-bit timer wrap (4.096 ms)
    assert m.gaps == missed
    # the falling edge waited for the blocked interrupt (1 599 ticks with interrupts off):
    # longer than any other routine holds it (the UART's 122, timer 0's 96, the ramp
    # task's sections up to 116).  The model's longest 1 557 ticks since the fiftieth
    # pass (the earliest compare 102 ticks into a block); 100 us and more before
    assert m.high_max > 1000
    assert m.position == 20000  # and no step is lost
    assert obs.analysis.irq_windows > 0
    text = "\n".join(report_lines(obs))
    assert "max +4096 us" in text
    assert "interrupts blocked  0 window" not in text


def test_report_shows_stray_reads_but_no_timing_change_for_r(tmp_path):
    m, obs = figures("r M1 A1000000 V40 R20000 W", tmp_path)
    reads, during = obs.analysis.stray_reads
    assert reads > 0 and 0 < during < reads
    assert m.dev_late == m.dev_early == 0 and m.gaps == 0
    assert "all 19999 step intervals as planned" in "\n".join(report_lines(obs))


def test_report_direction_and_enable_delays(tmp_path):
    # stepper 2: enable delay 5000 us (demo wiring), a direction change between moves
    run = traced_run("atmega328p", "M2 A5000 V200 R300 W R-300 W", tmp_path)
    vcd = run.vcd
    m = run.obs.analysis.steppers[1]
    assert m.dir_changes >= 1
    assert m.enables >= 1 and min(m.enable_to_step) >= 5000 * 16
    # the measured delays are the edges in the VCD
    first = vcd.rising("StepB")[0] // 625
    enable = vcd.falling("EnableB")[0] // 625
    assert min(m.enable_to_step) == first - enable
    backward = vcd.rising("StepB")[300] // 625
    dir_edge = [t // 625 for t, _ in vcd.edges("DirB") if t // 625 < backward][-1]
    assert m.dir_to_step_min == backward - dir_edge


def test_report_without_steps(tmp_path):
    lines = report_lines(traced_run("atmega328p", "M1 A1000", tmp_path).obs)
    assert lines[1] == "  no stepper made a step or changed a pin"


def test_cli_report_follows_the_transcript(tmp_path, capsys):
    rc = main(["-c", README_MOVE, "--report", "--lf"])
    out = capsys.readouterr().out
    assert rc == EXIT_OK
    transcript, report = out.split("timing report: atmega328p")
    assert ">> M1: @3200" in transcript
    assert "step period  min 560 us, median 792 us, max 22368 us" in report


def test_cli_rejects_an_unwritable_vcd(tmp_path, capsys):
    rc = main(["-c", README_MOVE, "--vcd", str(tmp_path / "no" / "such" / "dir.vcd")])
    assert rc == EXIT_USAGE
    assert "stepperdemo:" in capsys.readouterr().err


# ----------------------------------------------------------------- plots
def png_size(path: Path) -> tuple[int, int]:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    assert data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


@pytest.mark.skipif(not plots.png_available(), reason="matplotlib (extra 'plot') not installed")
def test_png_of_the_readme_move_has_the_requested_size(tmp_path):
    png = tmp_path / "run.png"
    rc = main(["-c", README_MOVE, "--plot", str(png), "--plot-size", "640x480"])
    assert rc == EXIT_OK
    assert png_size(png) == (640, 480)


def test_plot_without_matplotlib_names_the_extra(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(plots, "png_available", lambda: False)
    rc = main(["-c", README_MOVE, "--plot", str(tmp_path / "x.png")])
    assert rc == EXIT_USAGE
    err = capsys.readouterr().err
    # what works for an installed wheel too (stepperdemo is not on the package index)
    assert "pip install matplotlib" in err and "'stepperdemo[plot]'" not in err
    assert not (tmp_path / "x.png").exists()


def test_bad_plot_size_is_a_usage_error(capsys):
    assert main(["-c", README_MOVE, "--plot", "x.png", "--plot-size", "big"]) == EXIT_USAGE
    assert "--plot-size" in capsys.readouterr().err


def test_speed_series_is_the_triangle_of_the_readme_move(tmp_path):
    _, obs = figures(README_MOVE, tmp_path)
    (series,) = plots.series_of(obs)
    peak = max(series.speed)
    t_peak = series.t_s[series.speed.index(peak)]
    assert 1750 < peak < 1800
    # accelerating before the peak, decelerating after it: a symmetric ramp
    assert abs((t_peak - series.t_s[0]) - (series.t_s[-1] - t_peak)) < 0.05
    assert series.position[-1] == 3200 and series.speed[-1] == 0


def test_terminal_plot_draws_braille_charts(tmp_path):
    _, obs = figures("M1 A1000 V1000 R1000 W", tmp_path)
    lines = plots.terminal_plot(plots.series_of(obs), width=40, height=6)
    assert lines[0] == "M1 position [steps]"
    chart = lines[1:7]
    assert all(len(row.split("|", 1)[1]) == 40 for row in chart)
    assert all(0x2800 <= ord(c) <= 0x28FF for row in chart for c in row.split("|", 1)[1])
    assert chart[0].strip().startswith("1000 |")
    assert "M1 speed [steps/s]" in lines
    assert plots.terminal_plot([]) == ["nothing to plot: no steps recorded"]


def test_cli_vcd_with_a_coarser_timescale(tmp_path):
    path = tmp_path / "us.vcd"
    assert main(["-c", README_MOVE, "--vcd", str(path), "--vcd-timescale", "1 us"]) == EXIT_OK
    vcd = read_vcd(str(path))
    assert vcd.timescale == "1 us"
    assert len(vcd.rising("StepA")) == 3200
    assert position_from_vcd(vcd, "StepA", "DirA") == 3200


def test_cli_observer_option_problems(capsys):
    assert main(["-c", README_MOVE, "--vcd", "x.vcd", "--vcd-timescale", "3 us"]) == EXIT_USAGE
    assert "--vcd-timescale" in capsys.readouterr().err
    assert main(["--report"]) == EXIT_USAGE  # interactive: the console has /report
    assert "/report" in capsys.readouterr().err
