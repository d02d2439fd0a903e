"""QuickStep through the serial backend: its orders run on the device's step timer."""

from __future__ import annotations

from rigs.serial import run_serial

QS_LINES = [
    ("c M1 l1 p8 x M1 A1000 V100 R3200 W", [3200, 0], [3200, 0]),
    ("c M1 q4 p4 l1 x M1 A5000 V200 R1000 R-300 W", [700, 0], [1300, 0]),
    ("c M2 l1 p3 x M2 A3000 V300 R-1500 M1 A3000 V300 R1500 W M2 W", [1500, -1500],
     [1500, 1500]),
]


def test_quickstep_moves_end_where_they_should_on_a_device():
    for line, positions, pulses in QS_LINES:
        out = run_serial(line)
        assert out.positions == positions, line
        assert out.device_positions == positions, line
        assert out.pulses == pulses, line
        assert "ERROR" not in out.transcript
