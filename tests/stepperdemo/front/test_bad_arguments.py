"""Bad arguments are one line and exit code 2, before anything runs (issue 26, item 6):
no traceback, no console whose clock never moves, no file written halfway."""

from __future__ import annotations

import subprocess
import sys

import pytest

from rigs import ROOT
from stepperdemo.front.cli import EXIT_USAGE, main

LINE = "M1 A1000 V100 R100 W"
EXAMPLE = str(ROOT / "sequences" / "examples" / "move_3200.toml")


def _one_line_error(capsys) -> str:
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err
    assert out == ""  # checked before the run: no transcript
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("stepperdemo: "), err
    return lines[0]


@pytest.mark.parametrize(("argv", "says"), [
    (["-c", LINE, "--plot", "/nonexistent/dir/x.png"], "no folder /nonexistent/dir"),
    (["-c", LINE, "--plot", "{tmp}/x.txt"], "a plot file ends in .png, .svg, .pdf"),
    (["-c", LINE, "--plot", "{tmp}"], "a plot file ends in"),
    (["-c", LINE, "--plot", "{tmp}/x.png", "--plot-size", "99999x99999"], "--plot-size"),
    (["-c", LINE, "--plot", "{tmp}/x.png", "--plot-size", "9000x9000"], "40 million"),
    (["-c", LINE, "--speed", "0"], "--speed 0: give a factor 0 < f <= 1000"),
    (["-c", LINE, "--speed", "-2"], "--speed -2: give a factor"),
    (["-c", LINE, "--speed", "nan"], "--speed nan: give a factor"),
    (["-c", LINE, "--speed", "inf"], "--speed inf: give a factor"),
    (["--speed", "-2"], "--speed -2: give a factor"),  # the console: refused, not frozen
    (["-c", LINE, "--max-time", "nan"], "--max-time nan: give seconds 0 < s <= 10000000"),
    (["-c", LINE, "--max-time", "inf"], "--max-time inf: give seconds"),
    (["-c", LINE, "--max-time", "0"], "--max-time 0: give seconds"),
    (["gcode", "-", "--max-time", "nan"], "--max-time nan: give seconds"),
    (["gcode", "-", "--speed", "0"], "--speed 0: give a factor"),
    (["device", "--pty", "--speed", "nan"], "--speed nan: give a factor"),
    (["device", "--pty", "--speed", "-1"], "--speed -1: give a factor"),
    (["run", EXAMPLE, "--plot", "/nonexistent/dir"], "no folder /nonexistent to make it in"),
    (["run", EXAMPLE, "--vcd", "/etc/passwd/dir"], "no folder /etc/passwd"),
    (["run", EXAMPLE, "--steps-csv", "/etc/passwd"], "a file is there"),
    (["run", EXAMPLE, "--vcd", "/proc/sys/x"], "not a folder for the files"),
])
def test_bad_arguments_are_one_line_and_exit_code_2(argv, says, tmp_path, capsys):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    assert main(argv) == EXIT_USAGE
    assert says in _one_line_error(capsys)
    assert list(tmp_path.iterdir()) == []
    assert not (ROOT / "nonexistent").exists()


def test_run_makes_the_named_folder_but_not_the_ones_above_it(tmp_path, capsys):
    assert main(["run", EXAMPLE, "--plot", str(tmp_path / "a" / "b")]) == EXIT_USAGE
    assert f"no folder {tmp_path / 'a'} to make it in" in _one_line_error(capsys)
    assert not (tmp_path / "a").exists()
    assert main(["run", EXAMPLE, "--vcd", str(tmp_path / "a")]) == 0
    assert (tmp_path / "a" / "move_3200.vcd").stat().st_size > 0


def test_a_plot_that_cannot_be_written_after_the_run_is_one_line(tmp_path, capsys,
                                                                monkeypatch):
    """Checked before the run - but a folder can go while it runs (or a disk fill up)."""
    from stepperdemo.watch import plots

    def gone(*_a, **_kw):
        raise FileNotFoundError(2, "No such file or directory")

    monkeypatch.setattr(plots, "write_png", gone)
    assert main(["-c", LINE, "--plot", str(tmp_path / "x.png")]) == EXIT_USAGE
    out, err = capsys.readouterr()
    assert "Move steps 100" in out and "Traceback" not in err
    assert err.splitlines() == [
        f"stepperdemo: cannot write {tmp_path / 'x.png'}: [Errno 2] No such file or directory"]


def test_as_a_user_runs_it_a_bad_speed_is_refused_before_the_console_opens():
    """The installed command, stdin a pipe: no traceback, no console at all."""
    for speed in ("0", "-2", "nan"):
        run = subprocess.run([sys.executable, "-m", "stepperdemo", "--speed", speed],
                             cwd=ROOT, input="", capture_output=True, text=True, timeout=60)
        assert run.returncode == EXIT_USAGE
        assert run.stdout == ""
        assert run.stderr.splitlines() == [
            f"stepperdemo: --speed {speed}: give a factor 0 < f <= 1000"]
