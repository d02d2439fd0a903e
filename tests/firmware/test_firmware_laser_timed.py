"""Issue 25's laser through ``--port``: the M4 power's timed output changes (OutputAt,
docs/serial-protocol.md section 16) arrive on time on the Python device and on our
firmware in simavr, measured on the device's PWM pin (the Uno's pin 11, timer 2;
``rigs/laser.py``).

Every duty change the host sends for a queue command's tick must show on the pin from
the first PWM period that begins after that tick (the compare registers are
double-buffered), unless a later change replaced it before then; that is, within one
PWM period of its queue command.  At 115 200 baud that needs the host to send only
the changes that show (PwmGrid), in 5 bytes each (OutputNext), ahead of queue entries
not yet framed and with the line kept clear of entries while changes wait for the
device's slots (docs/serial-protocol.md, section 16)."""

from __future__ import annotations

import pytest

from rigs.firmware import need_firmware
from rigs.laser import run


@pytest.mark.parametrize(("device", "baud"), [
    ("python", 115200), ("simavr", 1_000_000), ("simavr", 115200)])
def test_laser_timed_outputs_arrive_on_time_on_the_device(device, baud):
    if device == "simavr":
        need_firmware()
    r = run(device, baud)
    assert "error" not in r.out and "ALARM" not in r.out
    assert r.counters["rejected"] == 0
    assert len(r.asked) > 30 and len(r.sent) <= len(r.asked)
    checks = r.checks()
    assert len(checks) > 20
    # the duty count each change's first period shows (a count is 64 ticks; simavr's
    # trace may put an edge a tick off, hence the count, not the ticks)
    for at, value, first, _late in checks:
        assert r.shown(first) == value, (at, value, first, r.shown(first))
    assert r.levels[-1] == 0  # and the power is off at the end
    # the device told where its periods begin (PwmGrid): 1.024 ms on pin 11 (timer 2)
    assert r.grids[11][1] == r.period
