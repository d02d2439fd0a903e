"""StepperDemo's ESP32 wiring reuses pins: M12's step pin 26 is the enable pin of M1,
M7 and M13, M13's step pin 22 is M4's direction pin (issue 26).  The report counted
those enable and direction edges as pulses of M7, M11, M12, M13, M14 ("pulses 1 (the
channel counted 0)") and missed M1's driver activations.  A rise on such a pin is a
step only when the stepper's channel has a pulse planned for it."""

from __future__ import annotations

import re

import pytest

from fas.arch import get_profile
from fas.sim import SimBackend
from stepperdemo.demo.app import StepperDemo
from stepperdemo.front.cli import EXIT_OK, main
from stepperdemo.watch import report
from stepperdemo.watch.motion import demo_wiring
from stepperdemo.watch.observe import Observers
from stepperdemo.watch.recent import RecentTrace

LINE = "M1 A1000 V100 R500 W M13 A2000 V200 R-300 W"


def shared_step_pins() -> set[int]:
    wiring = demo_wiring(get_profile("esp32"))
    roles = {p for w in wiring for p in (w.direction, w.enable_low) if p is not None}
    return {w.step for w in wiring} & roles


def stepper_blocks(lines: list[str]) -> dict[int, list[str]]:
    blocks: dict[int, list[str]] = {}
    current = None
    for line in lines:
        m = re.match(r"M(\d+)  step pin", line)
        if m:
            current = blocks.setdefault(int(m.group(1)), [])
        elif not line.startswith("  "):
            current = None
        if current is not None:
            current.append(line)
    return blocks


def check(lines: list[str]) -> None:
    blocks = stepper_blocks(lines)
    for block in blocks.values():
        pulses = re.search(r"pulses +(\d+) \(the channel counted (\d+)\)", block[1])
        assert pulses and pulses.group(1) == pulses.group(2), block  # only its own pulses
    assert "pulses       500 (the channel counted 500), net +500" in blocks[1][1]
    assert "pulses       300 (the channel counted 300), net -300" in blocks[13][1]
    enable = next(ln for ln in blocks[1] if ln.startswith("  enable"))
    first = re.search(r"enable-to-first-step ([\d.]+) \.\.", enable)
    assert first and float(first.group(1)) > 0  # M1's driver activation, seen on pin 26
    for n in (11, 12, 14):  # nothing of theirs moved: no pulses invented for them
        assert n not in blocks or "pulses       0 " in blocks[n][1]


def test_the_wiring_shares_step_pins():
    assert {26, 22, 25, 21, 14} <= shared_step_pins()


def test_report_counts_only_the_channels_pulses(capsys):
    assert main(["--arch", "esp32", "-c", "0 " + LINE, "--report"]) == EXIT_OK
    out = capsys.readouterr().out
    check(out[out.index("timing report"):].splitlines())


@pytest.mark.parametrize("max_edges", [None, 1024])
def test_a_replay_sorts_the_edges_the_same_way(max_edges):
    b = SimBackend("esp32")
    app = StepperDemo(b, scripted=False)
    ring = (RecentTrace(b) if max_edges is None else
            RecentTrace(b, max_edges=max_edges, chunk_edges=64)).start()
    live = Observers(b).start()
    tps = b.profile.ticks_per_s
    for line, seconds in (("0", 6.0), (LINE, 8.0)):
        app.feed(line + "\n")
        app.run_until(b.now() + int(seconds * tps))
    positions = report.library_positions(app)
    lines = report.report_lines(live, positions=positions)
    check(lines)
    replayed = report.report_lines(ring.window(), positions=positions)
    if max_edges is None:
        assert replayed == lines
    else:  # the head was dropped: what is left is still sorted
        assert ring.dropped > 0
        for block in stepper_blocks(replayed).values():
            pulses = re.search(r"pulses +(\d+) \(the channel counted (\d+)\)", block[1])
            assert pulses.group(1) == pulses.group(2), block
