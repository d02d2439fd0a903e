"""Command lines through the serial backend end where the simulation ends.

Host and simulated device run on one virtual clock and talk through a real pty that
the host opens with pyserial - the same path as ``stepperdemo --port``.
"""

import pytest

from fas.device.relay import Faults
from rigs.serial import LINES, NOISY, run_serial, run_sim


@pytest.mark.parametrize("line", LINES)
def test_serial_run_ends_like_the_simulation(line):
    sim = run_sim(line)
    ser = run_serial(line)
    assert ser.positions == sim.positions
    assert ser.device_positions == sim.positions
    assert ser.pulses == sim.pulses
    c = ser.counters
    assert c["entries_lost"] == c["entries_duplicated"] == c["overflows"] == 0
    assert c["rejected"] == 0


def test_first_line_makes_3200_pulses_on_the_device():
    ser = run_serial(LINES[0])
    assert ser.positions[0] == 3200
    assert ser.pulses[0] == 3200
    assert "M1: @3200" in ser.transcript


@pytest.mark.parametrize("line", [LINES[0], LINES[5], LINES[7]])
def test_noisy_line_loses_and_repeats_no_command(line):
    """1 % corrupted, 0.5 % dropped, 0.5 % duplicated bytes, 1 ms latency each way."""
    sim = run_sim(line)
    ser = run_serial(line, faults=NOISY)
    assert ser.positions == sim.positions == ser.device_positions
    assert ser.pulses == sim.pulses
    c = ser.counters
    assert c["entries_lost"] == 0
    assert c["entries_duplicated"] == 0
    # the faults were there and the link repaired them
    link = ser.link
    assert link["retransmissions"] > 0
    assert link["crc_errors"] + link["framing_errors"] > 0
    assert c["crc_errors"] + c["framing_errors"] > 0
    assert c["frames_duplicate"] + c["frames_out_of_order"] > 0


def test_paced_115200_baud_line_keeps_up_with_two_steppers():
    line = LINES[5]
    ser = run_serial(line, faults=Faults(latency_ms=1.0, baud=115200, chunk_ms=1.0))
    assert ser.positions == run_sim(line).positions
    assert ser.link["retransmissions"] <= 2
    assert ser.counters["underruns"] <= 2


@pytest.mark.parametrize("arch", ["esp32", "sam_due", "atmega2560"])
def test_other_profiles_over_serial(arch):
    line = "M1 A4000 V100 R2000 W R-500 W"
    sim = run_sim(line, arch)
    ser = run_serial(line, arch)
    assert ser.positions == sim.positions
    assert ser.pulses == sim.pulses
