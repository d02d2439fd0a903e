"""Issue 25 item 5: a G-code program planned with look-ahead, through ``--port`` on
our firmware in simavr (the loopback's virtual clock, as ``stepperdemo gcode --port``
drives a device).  Measured on the chip's pins: the blocks are one run, no command
lost, refused, late or run dry, every axis within one step of the commanded path, the
position where the program ends, the time against stopping at every block (the
Python device: tests/stepperdemo/gcode/test_gcode_lookahead.py)."""

from __future__ import annotations

import math

import pytest

from fas.device.loopback import Loopback
from rigs.firmware import need_firmware
from rigs.gcode import SETUP, cam_program
from rigs.path import (
    commanded_deviation,
    instants,
    path_as_run,
    timed_deviation,
    tracked_deviation,
)
from rigs.pins import steps_by_pins
from stepperdemo.program import make_program

TPS = 16_000_000
S1_STEP, S1_DIR, S2_STEP, S2_DIR = 9, 5, 10, 7  # the Uno's StepperDemo wiring


@pytest.fixture(scope="module", autouse=True)
def firmware():
    need_firmware()


def run_on_firmware(blends: bool = False) -> dict:
    text, verts = cam_program()
    with Loopback(device="simavr") as lb:
        app = make_program("gcode", lb.backend, scripted=True, axes=2,
                           setup_lines=list(SETUP) + [f"$172={int(blends)}"])
        app.run_script("G21\n", max_ticks=TPS)  # the machine is made: record its blends
        app.machine.executor.group.blend_log = log = []
        app.run_script(text, max_ticks=120 * TPS)
        assert lb.backend.settle()
        m = app.machine
        ups = [s.direction_pin_high_counts_up() for s in m.steppers]
        trace = lb.device.trace()
        steps = [steps_by_pins(trace.edges, S1_STEP, S1_DIR, ups[0]),
                 steps_by_pins(trace.edges, S2_STEP, S2_DIR, ups[1])]
        return {"out": app.transcript.decode(), "machine": m, "verts": verts,
                "counters": lb.backend.device_counters(), "steps": steps,
                "positions": m.positions(), "blends": log}


@pytest.fixture(scope="module")
def firmware_run() -> dict:
    return run_on_firmware()


def test_lookahead_program_through_port_on_the_firmware(firmware_run):
    r = firmware_run
    m, counters, steps, verts = r["machine"], r["counters"], r["steps"], r["verts"]
    assert "error" not in r["out"] and "ALARM" not in r["out"]
    assert m.executor.kind == "lookahead"
    assert len(m.motion_log) == 1  # every block joined the one before: no stop
    assert m.executor.group.stats.underruns == 0
    assert counters["underruns"] == counters["late_starts"] == counters["rejected"] == 0
    assert counters["entries_lost"] == counters["entries_duplicated"] == 0
    points = instants(steps, (0, 0))
    assert points[-1][1] == verts[-1] == tuple(r["positions"])
    assert tracked_deviation(points, verts) <= 1.0  # every axis within a step of the path
    assert r["blends"] == []  # the default: Grbl's junctions
    # the look-ahead took the polygon near its feed: well under half the time of
    # stopping at each of its 90 vertices and 120 raster segments (each from rest to
    # rest at 1000 mm/s^2 takes at least 2 sqrt(L / 1000 mm/s^2))
    xs = [t for t, _ in steps[0]]
    chord = 2 * math.pi * 6.0 / 90
    exact = 90 * 2 * math.sqrt(chord / 1000) + 120 * 2 * math.sqrt(0.5 / 1000)
    assert (xs[-1] - xs[0]) / TPS < 0.5 * exact


def test_lookahead_program_with_corner_blends_through_port_on_the_firmware():
    """``$172=1`` through ``--port`` on the firmware: one run, nothing lost, refused,
    late or run dry; every axis within one step of the path as run (its corners
    blended) and within $11 + 1 step of the commanded path (why that bound:
    tests/fas/path/test_path_blends.py); the end exact."""
    r = run_on_firmware(blends=True)
    m, counters, steps, verts = r["machine"], r["counters"], r["steps"], r["verts"]
    assert "error" not in r["out"] and "ALARM" not in r["out"]
    assert len(m.motion_log) == 1 and m.executor.group.stats.underruns == 0
    assert counters["underruns"] == counters["late_starts"] == counters["rejected"] == 0
    assert counters["entries_lost"] == counters["entries_duplicated"] == 0
    assert r["blends"]
    points = instants(steps, (0, 0))
    assert points[-1][1] == verts[-1] == tuple(r["positions"])
    path = path_as_run(verts, r["blends"], points, (80.0, 80.0))
    assert timed_deviation(points, path, int(0.02 * TPS)) <= 1.0
    jd = m.settings.junction_deviation
    dev = commanded_deviation(points, verts, r["blends"], int(0.02 * TPS))
    assert dev <= jd * 80 + 1.0
    assert jd * 80 < 1.0 and dev <= 1.0, dev  # at Grbl's $11: the 1 step
