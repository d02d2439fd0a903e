"""Smooth motion through USB latency and line faults, prompt stops (issue 18).

Everything runs on the virtual clock: a relay models latency, delivery bursts, baud
pacing, stalls and faults on its wire, so underrun and late-start counts do not
depend on the machine's load.
"""

import pytest

from fas.device.loopback import Loopback
from fas.device.relay import Faults
from fas.sim import SimBackend
from fas.sim.pins import EdgeRecorder
from rigs.demo import decel_start, moving, two_at_25khz
from rigs.serial import TPS, run_serial, run_sim
from stepperdemo.demo.app import StepperDemo

MS = TPS // 1000
# the two runs
TWO_AT_25KHZ = "M1 A100000 V40 R20000 M2 A100000 V40 R-20000 W M2 W"
THREE_MOVES = "M1 A1000 V100 R3200 W M2 A2000 V200 R-1000 W M1 A20000 V50 R-6000 W"
USB_16MS = Faults(chunk_ms=16, baud=115200)
NOISY_2MS = Faults(corrupt=0.01, drop=0.005, dup=0.005, latency_ms=2, seed=1)


def _clean(outcome) -> None:
    c = outcome.counters
    assert c["entries_lost"] == c["entries_duplicated"] == 0
    assert c["underruns"] == 0, "the device queue ran dry"
    assert c["late_starts"] == 0, "a start came after its time"


def _timed(line: str, faults: Faults | None) -> tuple[object, float]:
    with Loopback(faults=faults) as lb:
        backend = lb.backend
        app = StepperDemo(backend, scripted=True)
        t0 = backend.now()
        app.run_script(line, max_ticks=600 * TPS)
        wall_s = (backend.now() - t0) / TPS
    return app, wall_s


# ------------------------------------------------------------ acceptance
def test_16_ms_adapter_latency_two_steppers_at_25_khz():
    ser = run_serial(TWO_AT_25KHZ, faults=USB_16MS)
    sim = run_sim(TWO_AT_25KHZ)
    assert ser.positions == ser.device_positions == sim.positions == [20000, -20000]
    assert ser.pulses == sim.pulses
    _clean(ser)


def test_faulty_line_costs_less_than_a_quarter_of_the_time():
    with Loopback(faults=NOISY_2MS) as lb:
        backend = lb.backend
        app = StepperDemo(backend, scripted=True)
        t0 = backend.now()
        app.run_script(THREE_MOVES, max_ticks=600 * TPS)
        noisy_s = (backend.now() - t0) / TPS
        assert backend.settle() and backend.request_status() is not None
        c, link = backend.device_counters(), backend.link_stats()
        positions = [s.get_current_position() for s in app.steppers]
        assert positions == [lb.device.position(i) for i in (0, 1)]
    assert positions == run_sim(THREE_MOVES).positions
    assert c["entries_lost"] == c["entries_duplicated"] == 0
    assert c["underruns"] == c["late_starts"] == 0
    # selective repeat: about the frames a 2 % byte error rate destroys, not a window each
    assert 0 < link["retransmissions"] < 0.4 * link["frames_sent"]
    assert c["frames_held"] > 0
    _app, clean_s = _timed(THREE_MOVES, Faults(latency_ms=2))
    assert noisy_s <= 1.25 * clean_s


@pytest.mark.parametrize("faults", [None, Faults(baud=115200, chunk_ms=1), USB_16MS],
                         ids=["pty", "115200", "115200-16ms"])
def test_50_ms_host_stall_mid_move_causes_no_underrun(faults):
    with Loopback(faults=faults) as lb:
        backend = lb.backend
        app, moves = two_at_25khz(lb.backend)
        backend.app_spend(700 * MS)  # cruising at 25 kHz
        assert lb.device.running()
        lb.clock.run_until(lb.clock.now_ns() + 50 * 10**6)  # the host does nothing
        backend.wait_until(lambda: not any(s.is_running() for s in app.steppers))
        backend.settle()
        backend.request_status()
        c = backend.device_counters()
        assert c["underruns"] == c["late_starts"] == 0
        assert [lb.device.position(i) for i in (0, 1)] == moves


def test_line_stalls_of_50_ms_cause_no_underrun():
    stalls = Faults(baud=115200, chunk_ms=1, stall_ms=50, stall_every_ms=300)
    with Loopback(faults=stalls) as lb:
        backend = lb.backend
        app, moves = two_at_25khz(lb.backend)
        backend.wait_until(lambda: not any(s.is_running() for s in app.steppers))
        backend.settle()
        backend.request_status()
        assert backend.device_counters()["underruns"] == 0
        assert [lb.device.position(i) for i in (0, 1)] == moves


# ------------------------------------------------------- planning, ring
def test_planning_follows_the_measured_link_and_can_be_set():
    with Loopback() as lb:
        direct = lb.backend.planning_extra_ticks
    with Loopback(faults=USB_16MS) as lb:
        usb = lb.backend.planning_extra_ticks
        assert lb.backend.round_trip_ticks() >= 16 * MS  # two bursts of 16 ms at least
    assert 50 * MS < direct < usb
    with Loopback(faults=USB_16MS, link_planning_ms=30) as lb:
        assert lb.backend.planning_extra_ticks == 30 * MS


def test_host_queue_is_as_deep_as_the_device_says():
    with Loopback() as lb:
        assert lb.backend.profile.queue_len == 64  # the Uno's RAM (fas/arch.py)
        assert lb.backend.link.window == 9 and lb.backend.link.max_payload == 32
    line = "M1 A6000 V90 R5000 M2 A5000 V110 R-4000 W M1 W"
    ser = run_serial(line, device_options={"queue_len": 16, "rx_slots": 0})
    assert ser.positions == ser.device_positions == run_sim(line).positions
    assert ser.counters["entries_lost"] == ser.counters["entries_duplicated"] == 0


def test_first_fill_plans_only_the_librarys_time_so_the_start_is_early():
    with Loopback(faults=Faults(baud=115200, chunk_ms=1)) as lb:
        backend = lb.backend
        app = StepperDemo(backend, scripted=True)
        app.setup()
        s = app.steppers[0]
        s.set_speed_in_us(40)
        s.set_acceleration(100_000)
        s.move(20_000)
        backend.app_spend(5 * MS)  # the first ramp task ran
        assert 0 < s.queue_entries() < 40
        backend.app_spend(100 * MS)
        assert s.queue_entries() > 40  # then the link's planning fills the ring


# ------------------------------------------------------------- stops
def _cruise(lb: Loopback):
    return moving(lb.backend)[1]


def _decel_start(rising: list[int], t_call: int) -> int:
    ticks = decel_start(rising, t_call)
    assert ticks is not None, "no deceleration"
    return ticks


def test_s_decelerates_from_where_the_motor_is():
    with Loopback(faults=Faults(latency_ms=1, baud=115200, chunk_ms=1), record=True) as lb:
        backend, dev = lb.backend, lb.device
        s = _cruise(lb)
        queued = s.queue.ticks_in_queue()
        assert queued > 60 * MS  # a deep queue: the chip would stop after 20 ms
        t_call = dev.tick_at(lb.clock.now_ns())
        s.stop_move()
        backend.wait_until(lambda: not s.is_running())
        backend.settle()
        backend.request_status()
        latency = _decel_start(dev.recorder.rising(9), t_call)
        assert latency < 35 * MS < queued
        c = backend.device_counters()
        assert c["cuts"] == 1 and c["cuts_refused"] == 0 and c["underruns"] == 0
        assert s.get_current_position() == dev.position(0) == dev.pulses(0)


def test_s_on_the_simulated_chip_waits_for_its_20_ms_queue():
    backend = SimBackend("atmega328p")
    rec = EdgeRecorder()
    backend.machine.pins.sinks.append(rec)
    _app, s = moving(backend)
    t_call = backend.now()
    s.stop_move()
    backend.wait_until(lambda: not s.is_running(), 10 * TPS)
    assert 15 * MS < _decel_start(rec.rising(9), t_call) < 30 * MS


@pytest.mark.parametrize("how", ["S", "force_stop"])
def test_a_late_cut_is_refused_and_the_stop_comes_from_the_queue_end(how):
    with Loopback(faults=Faults(latency_ms=5), record=True) as lb:
        backend, dev = lb.backend, lb.device
        s = _cruise(lb)
        backend.cut_margin_ticks = lambda report_ns: 0  # cut right after the read point
        if how == "S":
            s.stop_move()
        else:
            s.force_stop()
        backend.wait_until(lambda: not s.is_running())
        backend.settle()
        backend.request_status()
        c = backend.device_counters()
        assert c["cuts_refused"] == 1 and c["cuts"] == 0
        assert c["underruns"] == c["entries_lost"] == c["entries_duplicated"] == 0
        assert backend.channels[0].cuts_refused == 1
        assert s.get_current_position() == dev.position(0) == dev.pulses(0)
        if how == "S":  # decelerated (not stopped at full speed)
            periods = [b - a for a, b in zip(dev.recorder.rising(9),
                                             dev.recorder.rising(9)[1:], strict=False)]
            assert periods[-1] > 5 * 640
        # the queue is usable again
        s.move(100)
        backend.wait_until(lambda: not s.is_running())
        backend.settle()
        assert s.get_current_position() == dev.position(0)


def test_force_stop_ends_within_the_cut_margin():
    with Loopback(faults=Faults(latency_ms=1, baud=115200, chunk_ms=1)) as lb:
        backend, dev = lb.backend, lb.device
        s = _cruise(lb)
        t_call = dev.tick_at(lb.clock.now_ns())
        s.force_stop()
        backend.wait_until(lambda: not s.is_running())
        backend.settle()
        assert dev.steppers.stop_ticks.get(0) is None  # it ran out, nothing forced it
        last = dev.machine.pins.rise.get(9)
        assert last - t_call < 35 * MS
        assert s.get_current_position() == dev.position(0)


@pytest.mark.parametrize("faults", [Faults(latency_ms=1, baud=115200, chunk_ms=1),
                                    Faults(corrupt=0.01, drop=0.005, dup=0.005,
                                           latency_ms=1, seed=3)],
                         ids=["clean", "noisy"])
def test_x_halts_the_device_at_once(faults):
    with Loopback(faults=faults) as lb:
        backend, dev = lb.backend, lb.device
        s = _cruise(lb)
        t_call = dev.tick_at(lb.clock.now_ns())
        s.force_stop_and_new_position(0)  # StepperDemo's X
        assert not s.is_running()
        backend.app_spend(100 * MS)
        backend.settle()
        assert dev.steppers.stop_ticks[0] - t_call < 25 * MS  # not after the 60+ ms queued
        assert dev.counters["halts"] == 1
        assert dev.position(0) == 0 == s.get_current_position()
        made = dev.pulses(0)
        s.move(-250)
        backend.wait_until(lambda: not s.is_running())
        backend.settle()
        assert dev.position(0) == -250 == s.get_current_position()
        assert dev.pulses(0) == made + 250
        assert dev.counters["entries_lost"] == dev.counters["entries_duplicated"] == 0


def test_emergency_stop_acts_at_once():
    with Loopback(faults=Faults(latency_ms=1, baud=115200, chunk_ms=1)) as lb:
        backend, dev = lb.backend, lb.device
        s = _cruise(lb)
        t_call = dev.tick_at(lb.clock.now_ns())
        assert backend.emergency_stop()
        assert dev.session.estop_tick - t_call < 25 * MS
        assert s.get_current_position() == dev.position(0)
