"""The type and lint gates (issue 22, item 8): ``mypy`` on the library and ``ruff check .``
on the whole tree, each with the settings in ``pyproject.toml``, run as CI runs the suite.

Both tools come with the ``test`` extra.  mypy keeps its cache in ``.mypy_cache`` at
the root of the checkout, so after the first run only changed modules are checked again.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from mypy import api as mypy_api

ROOT = Path(__file__).resolve().parent.parent
PYPROJECT = ROOT / "pyproject.toml"


def test_mypy_finds_no_error_in_the_library() -> None:
    # no paths given: the files and the strictness come from [tool.mypy] in pyproject.toml
    cwd = os.getcwd()
    os.chdir(ROOT)  # the configured files are relative to the checkout
    try:
        stdout, stderr, status = mypy_api.run(["--config-file", str(PYPROJECT)])
    finally:
        os.chdir(cwd)
    assert status == 0, stdout + stderr
    assert stdout.startswith("Success: no issues found in "), stdout
    checked = int(stdout.split(" in ")[1].split()[0])
    assert checked == len(list((ROOT / "fas").rglob("*.py"))), stdout  # every module of fas


def test_ruff_is_clean_on_the_whole_tree() -> None:
    run = subprocess.run([sys.executable, "-m", "ruff", "check", "--no-fix",
                          "--config", str(PYPROJECT), "."],
                         cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout + run.stderr
    assert "All checks passed" in run.stdout, run.stdout


def test_the_oldest_python_is_3_10_and_the_gates_check_for_it() -> None:
    # issue 26: Ubuntu 22.04's Python 3.10 is supported (tomli stands in for tomllib,
    # typing_extensions' Self is read by the type checker only); ruff and mypy judge
    # the code as that version would run it
    from stepperdemo.scenarios.scenario import tomllib

    with open(PYPROJECT, "rb") as f:
        config = tomllib.load(f)
    assert config["project"]["requires-python"] == ">=3.10"
    assert "tomli>=1.1; python_version < '3.11'" in config["project"]["dependencies"]
    assert config["tool"]["ruff"]["target-version"] == "py310"
    assert config["tool"]["mypy"]["python_version"] == "3.10"
