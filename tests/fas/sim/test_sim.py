"""The simulated machine: event clock, interrupt blocking, UART, millis()."""

from fas.arch import ATMEGA328P
from fas.engine import Engine
from fas.sim import SimBackend
from fas.sim.machine import Machine
from fas.sim.timing import sim_timing
from rigs.sim import make, periods, rising, run_until_idle
from stepperdemo.demo.build import demo_build

T328 = sim_timing(ATMEGA328P)


def test_events_run_in_time_order_and_virtual_time_jumps():
    m = Machine(ATMEGA328P)
    seen = []
    m.schedule(300, lambda: seen.append(("b", m.now)))
    m.schedule(100, lambda: seen.append(("a", m.now)))
    ev = m.schedule(200, lambda: seen.append(("x", m.now)))
    m.cancel(ev)
    m.run_until(1000)
    assert seen == [("a", 100), ("b", 300)] and m.now == 1000


def test_millis_follows_arduinos_timer0_bookkeeping():
    m = Machine(ATMEGA328P)
    m.run_until(m._millis_phase + 1000 * 16384)  # noqa: SLF001 - when timer 0 started: no public reader
    assert m.millis() == 1024  # 1000 overflows of 1.024 ms
    for ms in (0, 1, 2, 41, 42, 43, 1000, 123456):
        t = m.tick_at_millis(ms)
        m2 = Machine(ATMEGA328P)
        m2.run_until(t)
        assert m2.millis() >= ms
        m3 = Machine(ATMEGA328P)
        m3.run_until(t - 1)
        assert m3.millis() < ms or ms == 0


def test_uart_blocks_once_its_buffer_is_full():
    b = SimBackend("atmega328p")
    t0 = b.now()
    b.console_write(b"x" * 64)
    # all fit, no waiting: the CPU time to hand them over, plus the transmit interrupts
    # that meanwhile load one character every byte time (the first goes out directly)
    loads = b.machine.uart.isr_loads_between(t0, b.now())
    assert loads == (b.now() - t0) // T328.uart_byte_ticks
    assert b.now() - t0 == 64 * T328.char_ticks + loads * T328.uart_isr_ticks
    b.console_write(b"y" * 100)
    byte = T328.uart_byte_ticks
    # character k can be handed over once character k-64 went onto the wire
    assert b.now() - t0 >= (164 - 64 - 1) * byte


def test_blocked_interrupts_at_25khz_make_timer_wrap_gaps_without_losing_steps():
    backend, _, s = make()
    s.set_speed_in_us(40)
    s.set_acceleration(1_000_000)
    s.move(5000)
    backend.run_for_ms(50)  # at full speed now
    m = backend.machine
    for _ in range(200):  # the loop of StepperDemo with `e`: 100 us blocked, 25 us free
        m.block_interrupts(1600)
        m.consume(400)
    run_until_idle(backend, s)
    steps = rising(backend, 9)
    assert len(steps) == 5000 and s.get_current_position() == 5000
    p = periods(steps)
    gaps = [x for x in p if x > 65536]
    assert gaps and all(x == 65536 + 640 for x in gaps)  # compare missed: one timer wrap
    times, levels = backend.recorder.pin_edges(9)
    high = [b - a for a, b, lv in zip(times, times[1:], levels, strict=False) if lv]
    assert max(high) > 1000  # pulses stretched to the end of a blocked section


def test_blocked_interrupts_at_low_rate_do_not_move_steps():
    results = []
    for block in (False, True):
        backend, _, s = make()
        s.set_speed_in_us(2000)
        s.set_acceleration(100_000)
        s.move(200)
        m = backend.machine
        while s.is_running():
            if block:
                m.block_interrupts(1600)
            m.consume(400)
        results.append(periods(rising(backend, 9)))
    # the start may wait for a blocked ramp task, but every step time is kept
    assert results[0] == results[1]


def test_esp32_steps_ignore_blocked_interrupts():
    backend, _, s = make("esp32", dir_pin=18, enable_pin=26)
    s.set_speed_in_us(40)
    s.set_acceleration(1_000_000)
    s.move(3000)
    m = backend.machine
    while s.is_running():
        m.block_interrupts(1600)
        m.consume(400)
    assert max(periods(rising(backend, 17))) < 65536


def test_stray_reads_are_counted_and_change_nothing():
    counts = []
    for stray in (False, True):
        backend, _, s = make()
        s.set_speed_in_us(60)
        s.set_acceleration(20_000)
        s.move(3000)
        while s.is_running():
            if stray:
                backend.stray_read((9, 10))
            backend.machine.consume(400)
        counts.append(rising(backend, 9))
        if stray:
            assert backend.stray_reads > 1000
            assert 0 < backend.stray_reads_during_pulse < backend.stray_reads
    assert counts[0] == counts[1]


def test_uart_loads_wait_while_the_main_loop_blocks_interrupts():
    from fas.sim.uart import Uart
    u = Uart(1496, 64)
    for _ in range(3):
        u.put(0)
    assert [c[2] for c in u.records] == [0, 1496, 2992]
    # interrupts off in [1000, 5000): character 1 already sits in the data register and
    # goes out; character 2 can only be loaded by the interrupt once they are back on
    u.interrupts_blocked(1000, 5000)
    assert [c[2] for c in u.records] == [0, 1496, 5000]
    assert u.idle_at() == 5000 + 1496
    u.interrupts_blocked(20000, 30000)  # after the text: nothing moves
    assert [c[2] for c in u.records] == [0, 1496, 5000]


def test_uart_interrupts_stretch_the_ramp_task_while_text_goes_out():
    m = Machine(ATMEGA328P)
    byte, isr = T328.uart_byte_ticks, T328.uart_isr_ticks
    assert m.stretched(10_000) == 10_000  # quiet console: no stretch
    for _ in range(20):
        m.uart.put(0)
    # characters 2.. are loaded by the interrupt at 1 x byte, 2 x byte, ...
    t = 10_000
    while True:
        n = sum(1 for k in range(1, 20) if 0 < k * byte <= t)
        if 10_000 + n * isr == t:
            break
        t = 10_000 + n * isr
    assert m.stretched(10_000) == t > 10_000


def test_step_interrupts_take_their_time_from_the_main_loop():
    backend, _, s = make()
    s.set_speed_in_us(40)
    s.set_acceleration(1_000_000)
    s.move(20_000)
    backend.run_for_ms(60)  # at 25 kHz, pulses simulated as blocks
    m = backend.machine
    isr = T328.isr_duration_ticks
    m.stolen_ticks = 0
    t0 = m.now
    m.consume(16_000)  # 1 ms of loop work
    spent = m.now - t0
    steps = [t for t in rising(backend, 9) if t0 <= t < m.now]
    assert spent > 16_000 + 20 * isr  # ~25 interrupts in the first ms alone
    assert abs(spent - (16_000 + len(steps) * isr)) <= 2 * isr + T328.fill_entry_ticks * 4


def test_interrupts_during_an_idle_wait_do_not_delay_the_loop_afterwards():
    backend, _, s = make()
    s.set_speed_in_us(40)
    s.set_acceleration(1_000_000)
    s.move(20_000)
    backend.app_wait_until(backend.now() + 16_000 * 100)  # 100 ms idle: 2500 interrupts
    assert backend.machine.stolen_ticks <= T328.isr_duration_ticks


def test_a_running_stepper_whose_ramp_is_done_costs_the_ramp_task_nothing(monkeypatch):
    # build e (fas.sim.builds): the library's fill returns at its first check once the
    # ramp has planned everything, so a task while the queue drains costs what an idle
    # one does; while the ramp plans, the fill sums the queue first
    b = SimBackend("atmega328p", build="e")
    t = b.machine.timing
    assert t.fill_skips_done_ramps
    engine = Engine(b)
    engine.init()
    s = engine.stepper_connect_to_pin(demo_build(b.profile).steppers[0].step)
    assert s is not None
    plain = vars(SimBackend)["_task"]
    seen: list[tuple[bool, int, int]] = []  # planning, queued entries, task cost

    def task(self: SimBackend, index: int) -> None:
        q = self.channels[0].q
        planning = any(x is q for x in engine.planning_queues())
        queued = (q.next_write_idx - q.read_idx) & 0xFF if self.channels[0].running else 0
        before = self.machine.stolen_ticks
        plain(self, index)
        seen.append((planning, queued, self.machine.stolen_ticks - before))

    monkeypatch.setattr(SimBackend, "_task", task)
    s.set_speed_in_hz(20_000)
    s.set_acceleration(100_000)
    s.move(3000)
    run_until_idle(b, s)
    draining = [c for planning, queued, c in seen if not planning and queued]
    assert draining and all(c == t.fill_entry_ticks for c in draining)
    summing = [(queued, c) for planning, queued, c in seen if planning and queued > 1]
    assert summing and min(c - t.fill_entry_ticks - t.fill_stepper_ticks
                           - t.fill_queued_entry_ticks * (queued - 1)
                           for queued, c in summing) >= 0
