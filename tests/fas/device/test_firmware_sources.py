"""Where the simavr runner finds the firmware's sources and builds them (issue 26):
the checkout's ``firmware/`` with its ``build/``, or the installed package's copy
built into a per-user cache named by a hash of the sources (end to end, from a wheel:
tests/test_installed_package.py)."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from fas.device import simavr
from rigs import ROOT


def test_a_checkout_builds_into_its_firmware_folder(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(simavr.FIRMWARE_DIR_ENV, raising=False)
    assert simavr.firmware_dir() == ROOT / "firmware"
    assert simavr.build_dir() == ROOT / "firmware" / "build"
    assert not simavr.is_built("sim")  # make decides in a checkout (it knows the times)


def test_the_installed_copy_builds_into_a_cache_named_by_its_sources(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    installed = tmp_path / "site" / "firmware"
    shutil.copytree(ROOT / "firmware", installed, ignore=shutil.ignore_patterns("build"))
    monkeypatch.delenv(simavr.FIRMWARE_DIR_ENV, raising=False)
    monkeypatch.setattr(simavr, "_installed_firmware", lambda: installed)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    assert simavr.firmware_dir() == installed
    first = simavr.build_dir()
    assert first.parent == tmp_path / "cache" / "stepperdemo" / "firmware"
    assert first.name == simavr.sources_key(installed) and len(first.name) == 16
    (installed / "build").mkdir()  # build products do not change the key
    (installed / "build" / "x.o").write_bytes(b"\0")
    simavr.sources_key.cache_clear()
    assert simavr.build_dir() == first
    (installed / "stepgen.c").write_text((installed / "stepgen.c").read_text() + "\n")
    simavr.sources_key.cache_clear()
    assert simavr.build_dir() != first  # new sources, a new build
    assert simavr.first_build(115200) and not simavr.is_built("BAUD=115200", "all", "sim")
    simavr.sources_key.cache_clear()
