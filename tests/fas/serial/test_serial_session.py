"""Sessions on the serial backend: watchdog, lost devices, reconnection, stops."""

from fas.device.loopback import Loopback
from rigs.demo import moving
from rigs.serial import TPS
from stepperdemo.demo.app import StepperDemo


def _moving(lb: Loopback, steps: int = 100_000, run_ms: int = 500):
    return moving(lb.backend, steps=steps, speed_us=100, accel=1000, after_ms=run_ms)


def test_device_stops_within_its_watchdog_time_when_the_host_dies():
    with Loopback(watchdog_ms=200) as lb:
        _app, s = _moving(lb)
        dev = lb.device
        assert dev.running()
        last_host_frame = dev.session.last_rx_tick
        # the host is gone: nobody drives the link any more, the device runs on
        lb.clock.run_until(lb.clock.now_ns() + 2 * 10**9)
        assert not dev.running()
        assert dev.board.watchdog_tripped
        assert dev.counters["watchdog_trips"] == 1
        assert dev.session.halt_tick - last_host_frame <= dev.session.watchdog_ticks + 1
        pulses = dev.pulses(0)
        assert 0 < pulses < 100_000
        assert dev.position(0) == pulses  # where the pulses stopped
        lb.clock.run_until(lb.clock.now_ns() + 10**9)
        assert dev.pulses(0) == pulses
        # a host that was only frozen learns it at once and stops its steppers
        events = []
        lb.backend.listeners.append(lambda e, t: events.append((e, t)))
        lb.backend.app_spend(50 * TPS // 1000)
        assert events == [("lost", "device watchdog stopped the motion")]
        assert not s.is_running()


def test_heartbeats_keep_an_idle_session_alive():
    with Loopback(watchdog_ms=200) as lb:
        lb.backend.app_spend(3 * TPS)  # three seconds without any command
        assert lb.backend.connected
        assert not lb.device.board.watchdog_tripped


def test_unplugged_device_is_reported_once_and_reconnect_keeps_the_position():
    with Loopback(watchdog_ms=300) as lb:
        backend = lb.backend
        _app, s = _moving(lb)
        events = []
        backend.listeners.append(lambda e, t: events.append(e))
        lb.unplug()
        backend.app_spend(100 * TPS // 1000)
        assert events == ["lost"]
        assert not backend.connected
        assert not s.is_running()
        backend.app_spend(1000 * TPS // 1000)  # time goes on without a device
        assert events == ["lost"]
        lb.replug()
        backend.reconnect()
        assert backend.connected and backend.sessions == 2
        dev_pos = lb.device.position(0)
        assert dev_pos > 0
        assert s.get_current_position() == dev_pos  # the device's coordinates are kept
        s.move(1000)
        backend.wait_until(lambda: not s.is_running())
        backend.settle()
        assert s.get_current_position() == dev_pos + 1000
        assert lb.device.position(0) == dev_pos + 1000


def test_force_stop_with_new_position_names_the_devices_stop_point():
    with Loopback() as lb:
        backend = lb.backend
        _app, s = _moving(lb)
        s.force_stop_and_new_position(0)  # StepperDemo's X
        assert not s.is_running()
        backend.settle()
        made = lb.device.pulses(0)
        assert lb.device.position(0) == 0 == s.get_current_position()
        s.move(-250)
        backend.wait_until(lambda: not s.is_running())
        backend.settle()
        assert lb.device.position(0) == -250 == s.get_current_position()
        assert lb.device.pulses(0) == made + 250


def test_emergency_stop_halts_and_takes_the_devices_positions():
    with Loopback() as lb:
        backend = lb.backend
        _app, s = _moving(lb)
        assert backend.emergency_stop()
        assert backend.connected
        assert not s.is_running()
        assert not lb.device.running()
        assert s.get_current_position() == lb.device.position(0) == lb.device.pulses(0)
        s.move(100)
        backend.wait_until(lambda: not s.is_running())
        backend.settle()
        assert s.get_current_position() == lb.device.position(0)


def test_set_position_while_moving_shifts_the_device_too():
    with Loopback() as lb:
        backend = lb.backend
        _app, s = _moving(lb, steps=4000, run_ms=300)
        s.set_current_position(s.get_current_position() + 10_000)
        backend.wait_until(lambda: not s.is_running())
        backend.settle()
        assert s.get_current_position() == 14_000 == lb.device.position(0)
        assert lb.device.pulses(0) == 4000


def test_pulse_counter_counts_on_the_device():
    with Loopback("esp32") as lb:
        backend = lb.backend
        app = StepperDemo(backend, scripted=True)
        app.setup()
        s = app.steppers[0]
        assert s.attach_to_pulse_counter(7, -16384, 16384)
        s.set_speed_in_us(50)
        s.set_acceleration(20000)
        s.move(3000)
        backend.wait_until(lambda: not s.is_running())
        backend.settle()
        assert s.read_pulse_counter() == 3000
        s.clear_pulse_counter()
        s.move(-1000)
        backend.wait_until(lambda: not s.is_running())
        backend.settle()
        assert s.read_pulse_counter() == -1000


def test_direct_drive_self_test_reaches_the_device_pins():
    with Loopback() as lb:
        backend = lb.backend
        app = StepperDemo(backend, scripted=True)
        app.run_script("T", max_ticks=60 * TPS)
        backend.settle()
        text = app.transcript.decode()
        assert "test direct drive" in text and "Cannot" not in text
        assert lb.device.step_edges(0) == 2 * 3200
        assert lb.device.pulses(0) == 0  # no queue command was involved
