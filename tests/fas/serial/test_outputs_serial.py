"""User outputs over the serial protocol: messages, ordering on the device, cancel."""

import pytest

from fas import Engine
from fas.device.loopback import Loopback
from fas.outputs import OutputResult
from fas.serial.protocol import (
    O_ANALOG,
    O_SYNCHRONIZED,
    OutputCancel,
    OutputPwm,
    OutputSet,
    decode_messages,
)
from stepperdemo.program import make_program

TPS = 16_000_000


@pytest.mark.parametrize("message", [
    OutputPwm(1, 16, 500, 8192, 1955),
    OutputPwm(0, 2, 2, 2**32 - 1, 7),
    OutputSet(O_ANALOG | O_SYNCHRONIZED, 3, 14, 4095),
    OutputSet(0, 0, 32, 1),
    OutputCancel(),
])
def test_output_messages_round_trip(message):
    data = message.encode()
    assert data[0] == message.CODE
    assert decode_messages(data) == [message]


def test_output_set_sizes_and_flags():
    m = OutputSet(O_ANALOG | O_SYNCHRONIZED, 1, 16, 1955)
    assert len(m.encode()) == 8 and m.analog and m.synchronized
    assert len(OutputPwm(0, 0, 0, 0, 0).encode()) == 15
    assert len(OutputCancel().encode()) == 1


def test_gcode_acceptance_program_on_the_device():
    program = ("G1 X2000 F600000\nM62 P0\nG1 X0\nM63 P0\nM64 P1\nM67 E1 Q23.87\n"
               "G4 P0.05\nM2\n")
    with Loopback("esp32", record=True) as lb:
        app = make_program("gcode", lb.backend, scripted=True)
        app.run_script(program, max_ticks=60 * TPS)
        assert lb.backend.settle()
        dev = lb.device
        dev.machine.outputs.deliver_until(dev.machine.now)
        rec = dev.recorder
        steps = rec.rising(17)
        assert len(steps) == 4000
        d0 = list(zip(*rec.pin_edges(32), strict=True))
        assert [lv for _, lv in d0] == [1, 0]
        assert steps[1999] < d0[0][0] < steps[2000] and d0[1][0] > steps[-1]
        # M64: at once when its line is read - after M63 changed (it holds the parser)
        assert rec.rising(33)[0] >= d0[1][0]
        rises = rec.rising(16)
        assert rises[0] > d0[1][0]
        assert {b - a for a, b in zip(rises, rises[1:], strict=False)} == {3200}
        assert lb.backend.device_counters()["rejected"] == 0
        assert "error" not in app.transcript.decode()


def engine_on(lb):
    e = Engine(lb.backend)
    e.init()
    s = e.stepper_connect_to_pin(17)
    s.set_direction_pin(18)
    s.set_speed_in_us(100)
    s.set_acceleration(10_000)
    return e, s


def test_cancel_drops_a_synchronized_change_on_the_device():
    with Loopback("esp32", record=True) as lb:
        e, s = engine_on(lb)
        s.move(3000)
        lb.backend.wait_until(lambda: s.is_queue_running(), TPS)
        assert e.outputs.digital(0, True) == OutputResult.OK
        lb.backend.app_wait_until(lb.backend.now() + TPS // 20)
        assert e.outputs.cancel_pending() == 1
        lb.backend.wait_until(lambda: not s.is_running(), 10 * TPS)
        assert lb.backend.settle()
        assert lb.device.recorder.rising(32) == []
        assert lb.device.machine.outputs.level(32, lb.device.machine.now) == 0


def test_outputs_keep_their_state_across_a_new_session():
    with Loopback("esp32", record=True) as lb:
        e, s = engine_on(lb)
        e.outputs.digital(2, True, synchronized=False)
        e.outputs.analog(0, 50, synchronized=False)
        lb.backend.app_wait_until(lb.backend.now() + TPS // 100)
        dev = lb.device
        assert dev.machine.outputs.level(23, dev.machine.now) == 1
        assert dev.machine.outputs.count(5, dev.machine.now) == 4096
        lb.unplug()
        lb.replug()
        lb.backend.reconnect()
        lb.backend.app_wait_until(lb.backend.now() + TPS // 100)
        assert lb.backend.settle()
        assert dev.machine.outputs.level(23, dev.machine.now) == 1
        assert dev.machine.outputs.count(5, dev.machine.now) == 4096
        assert lb.backend.device_counters()["rejected"] == 0
