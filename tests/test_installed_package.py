"""The installed package is the product (issue 26): build the wheel from the tracked
files, install it into a fresh virtual environment outside the checkout and run the
front ends from there - ``-c``, ``run``, ``gcode``, ``winder``, a script on stdin, and
``device --simavr`` (which builds the firmware from the package data into a per-user
cache) with one ``--port`` line.

No download: the wheel is built with the setuptools of this environment (the ``test``
extra asks for one that builds wheels itself, ``--no-build-isolation``), the venv sees
this environment's packages after its own (a ``.pth`` file naming them: a venv's
``--system-site-packages`` would be the base interpreter's, not those of a venv this
suite runs in) and the wheel is installed with ``--no-deps --no-index``.
``--ignore-installed``: a stepperdemo installed in this environment must not count as
"already satisfied".  The venv is built once per run and shared by the xdist workers
(a lock in the run's temporary folder).
"""

from __future__ import annotations

import fcntl
import os
import shutil
import site
import subprocess
import sys
import sysconfig
import zipfile
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LIMIT_S = 300  # a bound for one subprocess (a cold firmware build included), no measurement
SKIP_DIRS = {".git", "build", "dist", "__pycache__", ".mypy_cache", ".pytest_cache",
             ".ruff_cache", ".hypothesis"}
MOVE = "M1 A1000 V100 R3200 W"


@dataclass
class Installed:
    venv: Path
    wheel: Path
    work: Path  # the current folder of the commands: outside the checkout
    env: dict[str, str]

    @property
    def stepperdemo(self) -> str:
        return str(self.venv / "bin" / "stepperdemo")

    @property
    def cache(self) -> Path:
        return Path(self.env["XDG_CACHE_HOME"])

    def run(self, *args: str, stdin: str | None = None) -> subprocess.CompletedProcess[str]:
        return subprocess.run([self.stepperdemo, *args], cwd=self.work, env=self.env,
                              input=stdin if stdin is not None else "",
                              capture_output=True, text=True, timeout=LIMIT_S, check=False)


def _tracked_files() -> list[str]:
    """The checkout's files as a clean clone has them (no build/, no egg-info: a stale
    build folder must not hide a file the packaging leaves out)."""
    try:
        out = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True,
                             check=True, timeout=60).stdout.decode()
        names = [n for n in out.split("\0") if n and (ROOT / n).is_file()]
    except (OSError, subprocess.CalledProcessError):
        names = []
    if names:
        return names
    found = []  # not a git checkout (an unpacked archive): everything but build products
    for folder, dirs, files in os.walk(ROOT):
        dirs[:] = [d for d in dirs if d not in SKIP_DIRS and not d.endswith(".egg-info")]
        found += [str(Path(folder, f).relative_to(ROOT)) for f in files]
    return found


def _check(res: subprocess.CompletedProcess[str]) -> None:
    assert res.returncode == 0, res.args and f"{res.args}\n{res.stdout}\n{res.stderr}"


def _install(base: Path) -> Installed:
    src, dist, venv, work = base / "src", base / "dist", base / "venv", base / "work"
    for name in _tracked_files():
        (src / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / name, src / name)
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "VIRTUAL_ENV", "PYTHONHOME", "STEPPERDEMO_FIRMWARE_DIR")}
    env["XDG_CACHE_HOME"] = str(base / "cache")
    env["XDG_STATE_HOME"] = str(base / "state")
    pip = [sys.executable, "-m", "pip", "--disable-pip-version-check"]
    for cmd in ([*pip, "wheel", "-q", "--no-deps", "--no-build-isolation", "--no-index",
                 "-w", str(dist), str(src)],
                [sys.executable, "-m", "venv", "--without-pip", str(venv)]):
        _check(subprocess.run(cmd, cwd=base, env=env, capture_output=True, text=True,
                              timeout=LIMIT_S, check=False))
    res = subprocess.run([str(venv / "bin" / "python"), "-c",
                          "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                         capture_output=True, text=True, timeout=LIMIT_S, check=True)
    ours = {sysconfig.get_paths()[k] for k in ("purelib", "platlib")} | set(site.getsitepackages())
    Path(res.stdout.strip(), "this-environment.pth").write_text(
        "".join(f"{folder}\n" for folder in sorted(ours) if Path(folder).is_dir()))
    (wheel,) = dist.glob("stepperdemo-*.whl")
    _check(subprocess.run([*pip, "--python", str(venv / "bin" / "python"), "install", "-q",
                           "--no-deps", "--no-index", "--ignore-installed", str(wheel)],
                          cwd=base, env=env, capture_output=True, text=True, timeout=LIMIT_S,
                          check=False))
    shutil.rmtree(src)  # nothing of the checkout is left to be found by accident
    work.mkdir()
    return Installed(venv, wheel, work, env)


@pytest.fixture(scope="session")
def installed(tmp_path_factory: pytest.TempPathFactory, worker_id: str) -> Installed:
    root = tmp_path_factory.getbasetemp()
    if worker_id != "master":  # the folder all workers of this run share
        root = root.parent
    base = root / "installed-wheel"
    with open(root / "installed-wheel.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (base / "ready").is_file():
            shutil.rmtree(base, ignore_errors=True)
            base.mkdir()
            _install(base)
            (base / "ready").write_text("ok\n")
    (wheel,) = (base / "dist").glob("stepperdemo-*.whl")
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "VIRTUAL_ENV", "PYTHONHOME", "STEPPERDEMO_FIRMWARE_DIR")}
    env["XDG_CACHE_HOME"] = str(base / "cache")
    env["XDG_STATE_HOME"] = str(base / "state")
    return Installed(base / "venv", wheel, base / "work", env)


def test_the_wheel_holds_every_module_and_the_firmware_sources(installed: Installed) -> None:
    names = set(zipfile.ZipFile(installed.wheel).namelist())
    tracked = [n for n in _tracked_files() if n.split("/")[0] in ("fas", "stepperdemo")
               and n.endswith(".py")]
    firmware = [n for n in _tracked_files() if n.startswith("firmware/")]
    assert "fas/quickstep/planner.py" in tracked  # a folder without __init__.py
    assert sorted(set(tracked) - names) == []
    assert sorted({"fas/device/" + n for n in firmware} - names) == []


def test_the_package_is_imported_from_the_venv_and_finds_its_firmware(
        installed: Installed) -> None:
    res = subprocess.run(
        [str(installed.venv / "bin" / "python"), "-c",
         "import fas, stepperdemo; from fas.device import simavr; "
         "print(fas.__file__); print(stepperdemo.__file__); print(simavr.firmware_dir()); "
         "print(simavr.build_dir())"],
        cwd=installed.work, env=installed.env, capture_output=True, text=True,
        timeout=LIMIT_S, check=False)
    _check(res)
    fas_file, sd_file, firmware, build = res.stdout.splitlines()
    site = str(installed.venv)
    assert fas_file.startswith(site) and sd_file.startswith(site), res.stdout
    assert firmware.startswith(site) and Path(firmware, "Makefile").is_file(), firmware
    # built into the per-user cache, named by the sources, not into site-packages
    assert build.startswith(str(installed.cache / "stepperdemo" / "firmware")), build


def test_console_run_gcode_and_winder_from_the_installed_package(installed: Installed) -> None:
    res = installed.run("-c", MOVE, "--lf")
    _check(res)
    assert res.stdout.splitlines()[-2].startswith(">> M1: @3200 "), res.stdout
    res = installed.run("--lf", stdin=MOVE + "\n")  # a pipe into the console: a script
    _check(res)
    assert res.stdout.splitlines()[-2].startswith(">> M1: @3200 "), res.stdout
    shutil.copy(ROOT / "sequences" / "examples" / "move_3200.toml", installed.work)
    res = installed.run("run", "move_3200.toml")
    _check(res)
    assert "1 scenarios, 0 failed" in res.stdout, res.stdout
    res = installed.run("gcode", "-", "--lf", stdin="G1 X100 F6000\nM2\n")
    _check(res)
    assert res.stdout.splitlines()[-3:] == ["ok", "[MSG:Pgm End]", "ok"], res.stdout
    res = installed.run("winder", "-c", "move 1 100 w500 status", "--lf")
    _check(res)
    assert "S1 spindle  @100 " in res.stdout, res.stdout


def test_device_simavr_from_the_installed_package(installed: Installed) -> None:
    from fas.device import simavr

    problem = simavr.toolchain_problem()
    if problem and os.environ.get("CI") != "true":  # CI installs the toolchain (.ci/run)
        pytest.skip(problem)
    dev = subprocess.Popen([installed.stepperdemo, "device", "--simavr", "--quiet"],
                           cwd=installed.work, env=installed.env, stdin=subprocess.DEVNULL,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        path = dev.stdout.readline().strip()  # after the build: the pty's path
        assert path.startswith("/dev/"), dev.stderr.read() if dev.poll() is not None else path
        res = installed.run("--port", path, "-c", "M1 A10000 V100 R3200 W", "--lf")
        _check(res)
        assert res.stdout.splitlines()[-2].startswith(">> M1: @3200 "), res.stdout
        assert "device M1: position 3200, 3200 pulses, 0 underruns" in res.stderr, res.stderr
    finally:
        dev.terminate()
        _out, err = dev.communicate(timeout=60)
    assert "building the firmware" in err, err  # said before the first, cold build
    (build,) = (installed.cache / "stepperdemo" / "firmware").iterdir()
    harness, elf = build / "fas-simavr", build / "115200" / "fasdevice.elf"
    assert harness.is_file() and elf.is_file()
    site_firmware = next(installed.venv.glob("lib/python*/site-packages/fas/device/firmware"))
    assert not (site_firmware / "build").exists()  # nothing written into site-packages

    # a firmware built elsewhere: the harness is taken from the cache, not built again
    made = harness.stat().st_mtime_ns
    dev = subprocess.Popen([installed.stepperdemo, "device", "--simavr", "--quiet",
                            "--firmware", str(elf)], cwd=installed.work, env=installed.env,
                           stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                           stderr=subprocess.PIPE, text=True)
    try:
        path = dev.stdout.readline().strip()
        assert path.startswith("/dev/"), dev.stderr.read() if dev.poll() is not None else path
    finally:
        dev.terminate()
        _out, err = dev.communicate(timeout=60)
    assert "building" not in err, err
    assert harness.stat().st_mtime_ns == made
