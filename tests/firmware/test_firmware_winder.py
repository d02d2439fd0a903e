"""Issue 13's acceptance lines of the helix winder through ``--port`` on the firmware
(issue 11) in simavr: the pots and switches are the chip's pins - the winder's ``pot``
and ``switch`` turn the simulated board's pots (SetInput, section 18), the firmware
reads them with its A/D converter and pin-change interrupt and reports them, and a
limit switch stops S2 on the chip.  Everything is measured on the chip's pins.
"""

from __future__ import annotations

import pytest

from fas.device.loopback import Loopback
from rigs import ROOT
from rigs.firmware import need_firmware
from rigs.pins import position_by_pins
from stepperdemo.program import make_program
from stepperdemo.winder import figures as fig

TPS = 16_000_000
S1_STEP, S1_DIR, S2_STEP, S2_DIR = 9, 5, 10, 7
A3 = 17
REACTION_TICKS = 20 * 16  # the firmware's limit reaction (docs/serial-protocol.md 18)


@pytest.fixture(scope="module", autouse=True)
def firmware():
    need_firmware()


def run_winder(line: str, seconds: int = 20):
    with Loopback(device="simavr") as lb:
        app = make_program("winder", lb.backend, scripted=True)
        app.run_script(line, max_ticks=seconds * TPS)
        assert lb.backend.settle()
        assert lb.backend.request_status() is not None
        trace = lb.device.trace()
        statuses = dict(lb.backend.statuses)
        counters = lb.backend.device_counters()
        positions = [s.get_current_position() for s in app.steppers[:2]]
        return app.transcript.decode(), trace, statuses, counters, positions, app


def _pins(trace, app) -> list[int]:
    return [position_by_pins(trace.edges, pin, d, s.direction_pin_high_counts_up())
            for pin, d, s in ((S1_STEP, S1_DIR, app.steppers[0]),
                              (S2_STEP, S2_DIR, app.steppers[1]))]


def test_pot_at_the_end_drives_s1_at_20000_steps_per_s_then_stops():
    """``pots pot 1 1023 w2000 pot 1 512 w1000``: the pot's log rule at 1023 is 13
    counts of 4 us (19 231 steps/s, the nearest period to 20 000); the steps on pin 9
    come at exactly that period at the top, and S1 stops once the pot is centred."""
    text, trace, statuses, counters, positions, app = run_winder(
        "pots pot 1 1023 w2000 pot 1 512 w1000")
    assert "ERROR" not in text
    assert "A0 = 1023: S1 forward" in text and "S1 stopped at" in text
    steps = trace.rising(S1_STEP)
    gaps = [b - a for a, b in zip(steps, steps[1:], strict=False)]
    top_ticks = 13 * fig.COUNT_US * 16
    assert min(gaps) == top_ticks  # the top speed, on the tick
    assert sum(1 for g in gaps if g == top_ticks) > 10_000  # cruising there for a while
    assert positions == _pins(trace, app) == [statuses[0].position, statuses[1].position]
    assert positions[0] == len(steps) > 20_000 and positions[1] == 0
    assert counters["entries_lost"] == counters["entries_duplicated"] == 0
    assert counters["underruns"] == 0


def test_limit_switch_stops_s2_with_no_step_after_it():
    """``period 2 50 move 2 65535 w300 switch A3 1 w300``: the switch is pressed on the
    chip's pin A3; the firmware stops S2 on its own, before a further pulse."""
    text, trace, statuses, counters, positions, app = run_winder(
        "period 2 50 move 2 65535 w300 switch A3 1 w300")
    assert "ERROR" not in text
    assert "A3 closed (S2 upper limit)" in text
    assert f"A3: S2 stopped at its upper limit, position {positions[1]}" in text
    times, levels = trace.edges(A3)
    switch = [t for t, lv in zip(times, levels, strict=True) if lv == 0][0]
    steps = trace.rising(S2_STEP)
    after = [t - switch for t in steps if t >= switch]
    assert after == []  # not one step after the switch (this run)
    assert steps[-1] > switch - 50 * fig.COUNT_US * 16  # it was moving (200 us a step)
    assert positions == _pins(trace, app) == [statuses[0].position, statuses[1].position]
    assert positions[1] == len(steps) > 1000
    # the limit's stop time on the chip: the last step came before the switch, the
    # queue stopped within the reaction time
    assert app.limit_stops and app.limit_stops[0][0] == 3


def test_interlock_keeps_s2_within_one_step_of_s1_over_3_on_the_pins():
    """``ratio 1:3 interlock 1 pots pot 1 900 w800 pot 1 700 w800 pot 1 512 w600``:
    S2 follows S1 at 1:3 through S1's acceleration, speed change and stop; at every
    step instant |S2 - S1/3| <= 1, counted on pins 9 and 10 with the direction pins."""
    text, trace, statuses, counters, positions, app = run_winder(
        "ratio 1:3 interlock 1 pots pot 1 900 w800 pot 1 700 w800 pot 1 512 w600")
    assert "ERROR" not in text
    assert "interlock engaged: S2 follows S1 at 1:3" in text
    events = sorted([(t, 0) for t in trace.rising(S1_STEP)]
                    + [(t, 1) for t in trace.rising(S2_STEP)])
    pos = [0, 0]
    worst = 0.0
    i = 0
    while i < len(events):
        t = events[i][0]
        while i < len(events) and events[i][0] == t:
            pos[events[i][1]] += 1
            i += 1
        worst = max(worst, abs(pos[1] - pos[0] / 3))
    assert pos[0] > 2000 and abs(pos[1] - pos[0] / 3) <= 1  # the simulation: 2233, 744
    assert worst <= 1.0
    assert positions == _pins(trace, app) == [statuses[0].position, statuses[1].position]
    assert counters["underruns"] == 0 and counters["late_starts"] == 0


def test_winder_port_on_device_simavr_as_a_user_runs_it():
    """``stepperdemo device --simavr`` (sped up) and ``stepperdemo winder --port PTY -c
    LINE``: the limit line as a user types it; waiting is done by reading what the
    processes print.  The host's clock runs ahead of a chip that falls behind real time
    on a loaded machine, and the move starts a planning margin (~100 ms) after the
    command: ``w2000`` before the switch leaves S2 running for more than a second even
    then (``w300`` left it none, position 0, under four busy loops on 2 cores; ``w1000``
    300-460 steps)."""
    import re
    import signal
    import subprocess
    import sys

    dev = subprocess.Popen([sys.executable, "-m", "stepperdemo", "device", "--simavr",
                            "--speed", "4"], cwd=ROOT, stdout=subprocess.PIPE, text=True)
    try:
        first = dev.stdout.readline()
        path = re.search(r" on (/dev/pts/\d+)", first).group(1)
        res = subprocess.run([sys.executable, "-m", "stepperdemo", "winder", "--port", path,
                              "-c", "period 2 50 move 2 65535 w2000 switch A3 1 w300",
                              "--watchdog-ms", "2000"], cwd=ROOT, capture_output=True,
                             text=True, timeout=120, check=False)
        assert res.returncode == 0, res.stderr
        assert "ERROR" not in res.stdout
        stop = re.search(r"A3: S2 stopped at its upper limit, position (\d+)", res.stdout)
        assert stop, res.stdout
        assert int(stop.group(1)) > 0, res.stdout  # S2 was running when the switch came
        assert f"device M2: position {stop.group(1)}, {stop.group(1)} pulses" in res.stderr
    finally:
        dev.send_signal(signal.SIGINT)
        out, _ = dev.communicate(timeout=30)
    assert f"pin 10: {stop.group(1)} rising" in out
    assert "inputs set: 1" in out  # the switch, pressed by the host's SetInput


def test_device_simavr_inputs_from_the_command_line_and_stdin():
    """``device --simavr --input A4=0 --inputs-from-stdin``: the fixture switch closed at
    power-up and a switch pressed by a line typed at the device - both on the chip's
    pins, read back by the winder through the firmware's reports."""
    import re
    import signal
    import subprocess
    import sys

    dev = subprocess.Popen([sys.executable, "-m", "stepperdemo", "device", "--simavr",
                            "--speed", "4", "--input", "A4=0", "--inputs-from-stdin"],
                           cwd=ROOT, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        first = dev.stdout.readline()
        path = re.search(r" on (/dev/pts/\d+)", first).group(1)
        dev.stdin.write("A5=0\n")
        dev.stdin.flush()
        assert dev.stdout.readline().strip() == "device: input A5=0"
        res = subprocess.run([sys.executable, "-m", "stepperdemo", "winder", "--port", path,
                              "-c", "status"], cwd=ROOT, capture_output=True, text=True,
                             timeout=120, check=False)
        assert res.returncode == 0, res.stderr
        assert "A4 closed at power-up: fixture mode" in res.stdout
        assert "A0 512 A1 512" in res.stdout  # the harness's centred pots
        assert "A2 open A3 open A4 closed A5 closed" in res.stdout
    finally:
        dev.send_signal(signal.SIGINT)
        dev.communicate(timeout=30)
