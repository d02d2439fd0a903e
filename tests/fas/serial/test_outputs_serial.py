"""User outputs over the serial protocol: messages, ordering on the device, cancel."""

import pytest

from fas import Engine
from fas.device.loopback import Loopback
from fas.outputs import OutputResult
from fas.pwm import duty_count
from fas.serial.protocol import (
    F_TIMED_OUTPUTS,
    O_ANALOG,
    O_SYNCHRONIZED,
    T_CANCEL,
    TIMED_SLOTS,
    OutputAt,
    OutputCancel,
    OutputNext,
    OutputPwm,
    OutputSet,
    decode_messages,
)
from rigs.laser import high_time
from stepperdemo.program import make_program

TPS = 16_000_000


@pytest.mark.parametrize("message", [
    OutputPwm(1, 16, 500, 8192, 1955),
    OutputPwm(0, 2, 2, 2**32 - 1, 7),
    OutputSet(O_ANALOG | O_SYNCHRONIZED, 3, 14, 4095),
    OutputSet(0, 0, 32, 1),
    OutputCancel(),
    OutputAt(O_ANALOG, 1, 11, 128, 2**32 - 1),
    OutputAt(T_CANCEL, 0, 0, 0, 0),
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
    assert len(OutputAt(O_ANALOG, 1, 11, 128, 5).encode()) == 12


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


def test_timed_outputs_are_made_at_their_ticks_on_the_device_beyond_its_slots():
    """OutputAt: 3 x TIMED_SLOTS changes 2 ms apart, given at once: the host sends them
    as the device's slots come free; each is made at its own tick there, none is
    refused.  (An OutputAt takes ~1 ms of a 115 200 baud line: changes much closer
    than that cannot all travel.)"""
    with Loopback("atmega328p", record=True) as lb:
        e = Engine(lb.backend)
        e.init()
        b = lb.backend
        assert b.ident.features & F_TIMED_OUTPUTS
        assert e.outputs.analog(1, 0.0, synchronized=False) == OutputResult.OK
        b.app_wait_until(b.now() + TPS // 100)
        made: list[tuple[int, int]] = []
        lb.device.board.sim.output_listeners.append(lambda ch, t: made.append((t, ch.value)))
        start = b.now() + TPS // 50
        ticks = [start + k * TPS * 2 // 1000 for k in range(3 * TIMED_SLOTS)]
        for k, tick in enumerate(ticks):
            assert e.outputs.analog(1, k + 1.0, synchronized=False, at=tick) == OutputResult.OK
        b.app_wait_until(ticks[-1] + TPS // 100)
        assert e.outputs.poll_timed(b.now()) == len(ticks)
        assert b.device_counters()["rejected"] == 0
        counts = e.outputs.analog_state(1).setting.counts
        assert [v for _t, v in made] == [duty_count(counts, k + 1.0)
                                         for k in range(len(ticks))]
        for (t_got, _v), tick in zip(made, ticks, strict=True):
            assert t_got & 0xFFFFFFFF == b.sync.device_tick32(tick)
        assert e.outputs.analog_applied(1)[0] == float(len(ticks))


def test_a_device_without_timed_outputs_gets_them_when_the_host_polls():
    with Loopback("atmega328p", record=True) as lb:
        lb.device.features = lb.device.features & ~F_TIMED_OUTPUTS
        lb.backend.reconnect()
        e = Engine(lb.backend)
        e.init()
        b = lb.backend
        assert not b.ident.features & F_TIMED_OUTPUTS
        at = b.now() + TPS // 100
        assert e.outputs.analog(1, 25.0, synchronized=False, at=at) == OutputResult.OK
        assert e.outputs.next_timed_tick() == at
        b.app_wait_until(at)
        assert e.outputs.analog_applied(1)[0] == 0.0  # not made before the poll
        assert e.outputs.poll_timed(b.now()) == 1
        assert e.outputs.analog_applied(1)[0] == 25.0
        assert b.settle() and b.device_counters()["rejected"] == 0


def test_output_next_counts_from_the_sessions_last_timed_change():
    """OutputNext (5 bytes): the next change of the output the last OutputAt / OutputNext
    named, ``after`` ticks later; another output, a gap of 2^16 ticks or more, or a new
    session: OutputAt again.  The device refuses an OutputNext with nothing before it."""
    from fas.backend import OutputChange
    from fas.serial.outputs import OutputState

    s = OutputState()
    pwm11 = OutputChange(True, 1, 11, 10)
    assert s.timed(pwm11, 1000) == OutputAt(O_ANALOG, 1, 11, 10, 1000)
    assert s.timed(OutputChange(True, 1, 11, 12), 1500) == OutputNext(12, 500)
    assert s.timed(OutputChange(True, 1, 11, 13), 2**32 + 100) == OutputAt(
        O_ANALOG, 1, 11, 13, 100)  # (65 536 ticks and more after: OutputAt)
    assert s.timed(OutputChange(True, 1, 11, 14), 100 + 0xFFFF) == OutputNext(14, 0xFFFF)
    assert s.timed(OutputChange(False, 0, 2, 1), 70000) == OutputAt(0, 0, 2, 1, 70000)
    assert s.timed(pwm11, 70001) == OutputAt(O_ANALOG, 1, 11, 10, 70001)
    s.replay()  # a new session
    assert s.timed(pwm11, 70002) == OutputAt(O_ANALOG, 1, 11, 10, 70002)
    assert len(OutputNext(1, 2).encode()) == 5
    with Loopback("atmega328p", record=True) as lb:
        b = lb.backend
        b.send(OutputNext(5, 10))
        assert b.settle() and lb.device.board.counters["rejected"] == 1


def test_the_host_leaves_out_a_timed_change_that_a_later_one_replaces_in_its_period():
    """PwmGrid tells where the device's PWM periods begin; of the changes that wait on
    the host (the device's slots are full) and fall in one period only the last goes
    (OutputNext), and the pin shows the same duty it would have shown."""
    with Loopback("atmega328p", record=True) as lb:
        e = Engine(lb.backend)
        e.init()
        b = lb.backend
        assert e.outputs.set_frequency(1, 1000.0) == OutputResult.OK
        assert e.outputs.analog(1, 0.0, synchronized=False) == OutputResult.OK
        b.app_wait_until(b.now() + TPS // 100)
        origin, period = b.pwm_grids[11]  # Aout1: pin 11, timer 2
        assert period == 16384  # 1.024 ms: prescaler 64, 256 counts
        sent = []
        timed = b.outputs.timed

        def spy(change, device_tick):  # type: ignore[no-untyped-def]
            msg = timed(change, device_tick)
            sent.append(msg)
            return msg

        b.outputs.timed = spy  # type: ignore[method-assign]
        made: list[int] = []
        lb.device.board.sim.output_listeners.append(lambda ch, t: made.append(ch.value))
        now_dev = b.sync.device_tick32(b.now())
        k0 = ((now_dev - origin) & 0xFFFFFFFF) // period + 30  # a period 30 ms ahead
        boundary = origin + k0 * period  # (device ticks)

        def at(dev_tick: int) -> int:  # the host tick of a device tick
            return b.sync.host_tick(dev_tick & 0xFFFFFFFF)

        for k in range(TIMED_SLOTS):  # the device's slots: full
            e.outputs.analog(1, 1.0 + k, synchronized=False, at=at(boundary - 20 * period
                                                                   + 2 * k * period))
        e.outputs.analog(1, 30.0, synchronized=False, at=at(boundary + 1000))  # replaced
        e.outputs.analog(1, 40.0, synchronized=False, at=at(boundary + period - 300))
        e.outputs.analog(1, 50.0, synchronized=False, at=at(boundary + period + 300))
        e.outputs.analog(1, 60.0, synchronized=False, at=at(boundary + 2 * period + 300))
        b.app_wait_until(at(boundary + 8 * period))
        counts = e.outputs.analog_state(1).setting.counts
        duty = [duty_count(counts, d) for d in (1, 2, 3, 4, 5, 6, 7, 8, 40, 50, 60)]
        assert [m.value for m in sent] == duty and made == duty
        # 2 periods apart: OutputNext; 7 periods (more than 2^16 ticks): OutputAt
        assert [type(m) for m in sent] == [OutputAt, *[OutputNext] * 7, OutputAt, OutputNext,
                                           OutputNext]
        assert b.device_counters()["rejected"] == 0
        assert lb.device.machine.now < 2**32  # (device ticks: the machine's, not wrapped)
        machine = lb.device.machine
        machine.outputs.deliver_until(machine.now)  # (edges are made when asked for)
        times, levels = lb.device.recorder.pin_edges(11)

        def shown(k: int) -> int:  # the duty count period k0 + k shows on the pin
            start = boundary + k * period
            return round(high_time(list(times), bytes(levels), start, start + period)
                         * counts / period)

        # each period shows the last change made in the period before it
        assert [shown(k) for k in range(4)] == [duty_count(counts, d) for d in (8, 40, 50, 60)]
