"""The host side of the serial backend stands alone: importing any of its modules, in a
fresh interpreter, loads nothing of the simulated chip (``fas.sim``) and nothing of
the device side (``fas.device``)."""

from __future__ import annotations

import json
import pkgutil
import subprocess
import sys

import fas.serial
from rigs import ROOT

HOST_MODULES = sorted(f"fas.serial.{m.name}" for m in pkgutil.iter_modules(fas.serial.__path__))
FORBIDDEN = ("fas.sim", "fas.device")


def loaded_after_import(module: str) -> list[str]:
    """The ``fas`` modules a fresh interpreter holds after ``import module``."""
    code = (f"import json, sys, importlib; importlib.import_module({module!r}); "
            "print(json.dumps(sorted(m for m in sys.modules if m.startswith('fas'))))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                         text=True, check=True).stdout
    return json.loads(out)


def forbidden(modules: list[str]) -> list[str]:
    return [m for m in modules if any(m == f or m.startswith(f + ".") for f in FORBIDDEN)]


def test_every_host_module_is_found() -> None:
    assert {"fas.serial.backend", "fas.serial.channel", "fas.serial.clocksync",
            "fas.serial.link", "fas.serial.protocol", "fas.serial.session"} <= set(HOST_MODULES)


def test_no_host_module_loads_the_simulator_or_the_device() -> None:
    found = {m: forbidden(loaded_after_import(m)) for m in HOST_MODULES}
    assert found == {m: [] for m in HOST_MODULES}


def test_the_probe_sees_the_device_side_load_the_simulator() -> None:
    """The device side may use the simulated chip - and the probe notices it does."""
    got = forbidden(loaded_after_import("fas.device"))
    assert "fas.sim" in got and "fas.device.session" in got
