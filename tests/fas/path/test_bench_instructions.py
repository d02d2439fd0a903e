"""bench/bench_instructions.py: the counted run itself, and its one-line errors."""

import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
TOOL = os.path.join(ROOT, "bench", "bench_instructions.py")


def run(*args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, TOOL, *args], capture_output=True, text=True,
                          env=env, timeout=120)


def test_the_counted_run_plays_the_program_in_both_corner_modes() -> None:
    for mode in ("grbl", "blends"):
        p = run("--child", "--segments", "12", "--mode", mode, "--traced")
        assert p.returncode == 0, p.stderr
        assert p.stderr == ""


def test_without_valgrind_one_line_and_exit_2() -> None:
    env = dict(os.environ, PATH=os.path.join(ROOT, "no-such-dir"))
    p = run("--segments", "10", env=env)
    assert p.returncode == 2
    assert p.stderr.strip().splitlines() == [
        "bench_instructions: valgrind not found (apt-get install valgrind)"]


def test_a_root_without_the_bench_is_a_usage_error() -> None:
    p = run("--root", os.path.join(ROOT, "docs"))
    assert p.returncode == 2
    assert "no bench/bench_gcode.py there" in p.stderr.strip().splitlines()[-1]
    assert "Traceback" not in p.stderr
