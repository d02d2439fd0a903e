"""Issue 25's laser through ``--port``: the M4 power's timed output changes (OutputAt,
docs/serial-protocol.md section 16) arrive on time on the Python device and on our
firmware in simavr, measured on the device's PWM pin (the Uno's pin 11, timer 2).

Every duty change the host sends for a queue command's tick must show on the pin from
the first PWM period that begins after that tick (the compare registers are
double-buffered), unless a later change replaced it before then; that is, within one
PWM period of its queue command."""

from __future__ import annotations

import bisect
from collections import Counter

import pytest

from fas.device.loopback import Loopback
from rigs.firmware import need_firmware
from rigs.gcode import SETUP
from stepperdemo.program import make_program

TPS = 16_000_000
LASER_PIN = 11  # Aout1 on the Uno: OC2A
PROGRAM = "M4 S1000\nG1 X40 F3000\nG0 X0\n"
LASER = ["$30=2000", "$32=1", "$141=1000"]  # full feed: 50 % duty; ~1 kHz PWM


def high_time(times: list[int], levels: bytes, a: int, b: int) -> int:
    """Ticks the pin is high within [a, b)."""
    k = bisect.bisect_right(times, a) - 1
    level = levels[k] if k >= 0 else 0
    t, total = a, 0
    k += 1
    while k < len(times) and times[k] < b:
        if level:
            total += times[k] - t
        t, level = times[k], levels[k]
        k += 1
    return total + (b - t if level else 0)


def run(device: str, baud: int = 115200) -> dict:
    with Loopback(device=device, record=device == "python", baud=baud) as lb:
        sent = []  # (device tick, duty count) of every OutputAt
        timed = lb.backend.outputs.timed

        def spy(change, device_tick):
            msg = timed(change, device_tick)
            sent.append((msg.at, msg.value))
            return msg

        lb.backend.outputs.timed = spy
        app = make_program("gcode", lb.backend, scripted=True, axes=2,
                           setup_lines=SETUP + LASER)
        app.run_script(PROGRAM, max_ticks=30 * TPS)
        assert lb.backend.settle()
        setting = app.machine.engine.outputs.frequency_setting(1)
        if device == "python":
            times, levels = lb.device.recorder.pin_edges(LASER_PIN)
        else:
            times, levels = lb.device.trace().edges(LASER_PIN)
        return {"out": app.transcript.decode(), "sent": sent, "times": list(times),
                "levels": bytes(levels), "counts": setting.counts,
                "period": setting.clock_div * setting.counts,
                "counters": lb.backend.device_counters()}


FIRMWARE_115200_LATE = (
    "firmware at 115 200 baud: 9 of 61 changes show late, the latest 34.3 ms after its "
    "tick (measured): in the deceleration about three changes come per PWM period, an "
    "OutputAt takes ~1 ms of the line and waits behind the look-ahead's entries, and the "
    "device holds 8 (at 1 000 000 baud, and on the Python device at 115 200, every one "
    "is on time)")


@pytest.mark.parametrize(("device", "baud"), [
    ("python", 115200), ("simavr", 1_000_000),
    pytest.param("simavr", 115200, marks=pytest.mark.xfail(strict=True,
                                                           reason=FIRMWARE_115200_LATE))])
def test_laser_timed_outputs_arrive_on_time_on_the_device(device, baud):
    if device == "simavr":
        need_firmware()
    r = run(device, baud)
    assert "error" not in r["out"] and "ALARM" not in r["out"]
    assert r["counters"]["rejected"] == 0
    sent, times, levels, per, counts = (r["sent"], r["times"], r["levels"], r["period"],
                                        r["counts"])
    assert len(sent) > 30
    rises = [t for t, v in zip(times, levels, strict=True) if v]
    origin = Counter(t % per for t in rises).most_common(1)[0][0]  # the periods' grid
    checked = 0
    for i, (at, value) in enumerate(sent):
        first = at - (at - origin) % per + per  # the first period that begins after `at`
        if i + 1 < len(sent) and sent[i + 1][0] < first:
            continue  # replaced before it could show
        # the duty count that period shows (a count is 64 ticks; simavr's trace may put an
        # edge a tick off)
        shown = round(high_time(times, levels, first, first + per) * counts / per)
        assert shown == value, (i, at, value, first, shown)
        checked += 1
    assert checked > 20
    # and the power is off at the end
    assert levels[-1] == 0
