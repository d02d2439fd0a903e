"""Random real-time traffic on the executor (issue 24): moves interrupted by feed holds,
resumes, override changes and jog cancels at random moments, on profiles with different
queues and clocks.  Whatever happens, no queue command is refused, every axis ends
where the steps counted from its pins say, and where the program said."""

import random

import pytest

from stepperdemo.demo.build import demo_build
from stepperdemo.gcode.program import RawGrbl
from stepperdemo.scenarios.evaluate import position_from_pins

OVERRIDES = [b"\x91", b"\x92", b"\x93", b"\x94", b"\x90", b"\x95", b"\x96", b"\x97"]


def random_program(rng: random.Random, axes: int, n: int) -> list[str]:
    lines = []
    for _ in range(n):
        words = [f"{'XYZ'[i]}{rng.randint(0, 2000)}" for i in range(axes)
                 if rng.random() < 0.7] or ["X0"]
        if rng.random() < 0.5:
            lines.append(f"G1 {' '.join(words)} F{rng.choice([6000, 60000, 300000])}")
        else:
            lines.append(f"G0 {' '.join(words)}")
    return lines


# axes that may move both ways together: the ESP32 wiring shares one direction pin
# between X and Y, the RP2040's Y and Z have none
@pytest.mark.parametrize("arch, seed, axes", [("atmega2560", 1, 3), ("esp32s3", 2, 1),
                                              ("sam_due", 3, 1), ("rp2040", 4, 1),
                                              ("atmega328p", 5, 2)])
def test_holds_resumes_and_overrides_at_random_moments_lose_no_step(arch, seed, axes):
    rng = random.Random(seed)
    g = RawGrbl(arch, record=True, axes=3)
    lines = random_program(rng, axes, 12)
    for line in lines:
        g.send(line.encode() + b"\n")
        for _ in range(rng.randint(0, 3)):
            g.advance(rng.uniform(0.0, 0.2))
            action = rng.random()
            if action < 0.4:
                g.send(b"!")
                g.advance(rng.uniform(0.0, 0.3))
                g.send(b"~")  # maybe still decelerating: lost, as in Grbl ...
                g.advance(0.5)
                g.send(b"~")  # ... so resume once more when it stands
            elif action < 0.8:
                g.send(rng.choice(OVERRIDES))
        while g.machine.rx.pending or g.machine.pending is not None:
            g.advance(0.05)
    assert g.settle(600)
    out = g.take().decode()
    assert "ALARM" not in out and "error" not in out, out
    m = g.machine
    assert m.positions() == m.interp.position_steps  # where the program said
    build = demo_build(g.backend.profile)
    for i, stepper in enumerate(m.steppers):
        pins = build.steppers[i]
        assert position_from_pins(g.backend, pins.step, pins.direction,
                                  pins.direction_high_counts_up) == stepper.get_current_position()


def test_random_jog_cancels_leave_the_parser_where_the_machine_stopped():
    rng = random.Random(7)
    g = RawGrbl("atmega2560", record=True)
    for _ in range(10):
        g.send(f"$J=G91 X{rng.randint(-3000, 3000)} Y{rng.randint(1, 300)} "
               f"F{rng.choice([6000, 60000])}\n".encode())
        g.advance(rng.uniform(0.0, 0.3))
        g.send(b"\x85")
        assert g.settle(60)
        m = g.machine
        assert m.positions() == m.interp.position_steps
    assert "error" not in g.take().decode()
