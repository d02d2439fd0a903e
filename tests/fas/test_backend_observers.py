"""What observers see through the backend's interface: pins, recording, machine time."""

from __future__ import annotations

from fas import Engine
from fas.device.loopback import Loopback
from fas.sim import SimBackend
from stepperdemo.demo.build import demo_build


def test_the_simulated_chip_shows_its_pins_and_its_recording():
    b = SimBackend("atmega328p", record=True)
    e = Engine(b)
    e.init()
    cfg = demo_build(b.profile).steppers[0]
    s = e.stepper_connect_to_pin(cfg.step)
    s.set_direction_pin(cfg.direction)
    s.set_speed_in_us(200)
    s.set_acceleration(10_000)
    s.move(-100)
    assert b.wait_until(lambda: not s.is_running(), 16_000_000)
    pins = b.pin_states
    assert pins is not None and b.recorder is not None
    assert pins.rise[cfg.step] == 100 == len(b.recorder.rising(cfg.step))
    assert pins.get(cfg.direction) == 0  # counting down: LOW (high counts up)
    assert cfg.step in pins.first_write and pins.level[cfg.step] == 0
    times, levels = b.recorder.pin_edges(cfg.step)
    assert times[-1] <= b.now() and bytes(levels[:2]) == b"\x01\x00"


def test_pwm_edges_reach_the_recording_when_delivered():
    b = SimBackend("esp32", record=True)
    e = Engine(b)
    e.init()
    e.outputs.analog(0, 25, synchronized=False)
    pin = e.outputs.analog_pin(0)
    b.run_for(16_000_000 // 100)  # 10 ms: 50 periods of 5 kHz
    made = len(b.recorder.pin_edges(pin)[0])
    b.deliver_edges()
    times, _ = b.recorder.pin_edges(pin)
    assert len(times) > made and len(times) >= 99
    assert b.pin_states.rise[pin] == len(b.recorder.rising(pin))


def test_a_backend_that_does_not_see_its_pins_says_so():
    """The serial backend: the device drives the pins, the host neither records nor
    sees them."""
    with Loopback("atmega328p") as lb:
        b = lb.backend
        e = Engine(b)
        e.init()
        s = e.stepper_connect_to_pin(demo_build(b.profile).steppers[0].step)
        s.set_speed_in_us(200)
        s.set_acceleration(10_000)
        s.move(50)
        assert b.wait_until(lambda: not s.is_running(), 16_000_000)
        assert b.recorder is None and b.pin_states is None
        b.deliver_edges()  # nothing to deliver
        assert s.get_current_position() == 50
