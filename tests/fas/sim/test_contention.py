"""Interrupt contention on the AVR: a step pulse lasts as long as its interrupt waits.

The compare hardware raises the step pin; the step interrupt lowers it ``lat`` ticks
after it is entered and writes the next compare ``ocr`` ticks later.  It is entered once
no routine holds the CPU with interrupts off; pending requests enter in priority order.
"""

from fas.arch import ATMEGA328P, get_profile
from fas.sim.machine import PRIO_STEP_ISR, PRIO_TASK, Machine
from fas.sim.timing import sim_timing
from rigs.sim import make

T = sim_timing(ATMEGA328P)
LAT_A, OCR, SEI = T.isr_latency(0), T.isr_ocr_ticks, T.sei_ticks
BLOCK = 4 * (4 * 100 - 5) + 2  # StepperDemo's `e`: cli, delayMicroseconds(100), sei


def test_requests_pending_at_the_end_of_a_block_enter_one_after_another_by_priority():
    m = Machine(ATMEGA328P)
    seen = []
    # requested during the block: channel B first, then the ramp task, then channel A
    m.schedule(50, lambda: seen.append(("B", m.now)), PRIO_STEP_ISR + 1, enter=146)
    m.schedule(70, lambda: seen.append(("task", m.now)), PRIO_TASK, enter=50)
    m.schedule(100, lambda: seen.append(("A", m.now)), PRIO_STEP_ISR, enter=120)
    m.block_interrupts(BLOCK)  # [0, 1582)
    m.run_until(5000)
    end = BLOCK + SEI  # the instruction after sei runs first
    assert seen == [("A", end), ("B", end + 120), ("task", end + 120 + 146)]


def test_a_request_before_the_block_is_entered_before_it_and_delays_the_cli():
    m = Machine(ATMEGA328P)
    seen = []
    m.schedule(100, lambda: seen.append(m.now), PRIO_STEP_ISR, enter=120)
    m.run_until(100)
    m.block_interrupts(BLOCK)  # the loop gets to its cli once the routine returned
    assert seen == [100]
    assert (m.irq_blocked_from, m.irq_blocked_until) == (220, 220 + BLOCK)


def test_a_compare_while_timer_0_interrupts_waits_for_it():
    backend, _, s = make()
    m = backend.machine
    backend.app_started()  # timer 0 runs: millis()
    # 41 us (656 ticks): its rises sweep timer 0's period in steps of 16 ticks (at 40 us,
    # 640 ticks, five periods make 128 steps: the rises keep 128 phases 128 ticks apart,
    # and whether one lies in the routine's 96 depended on the start's tick - none but
    # one with build d's figures of the fiftieth pass)
    s.set_speed_in_us(41)
    s.set_acceleration(1_000_000)
    s.move(30000)
    backend.run_for_ms(1000)
    times, levels = backend.recorder.pin_edges(9)
    first, ov, cost = m.tick_at_millis(0), T.millis_overflow_ticks, T.millis_isr_ticks
    waited = on_time = 0
    for rise, fall, level in zip(times, times[1:], levels, strict=False):
        if not level:
            continue
        into = (rise - first) % ov
        if rise > first + ov and into < cost:  # inside timer 0's routine
            # ... to its reti and the instruction after it (reti_next_ticks: 2 in build d
            # since the fiftieth pass, with the loop's sections; 0 before)
            assert fall - rise == LAT_A + cost - into + T.reti_next_ticks
            waited += 1
        elif fall - rise == LAT_A:
            on_time += 1
    assert waited > 100 and on_time > 20000


def _steady(period_us: int):
    """A stepper at constant speed; the machine stopped just after a rising edge."""
    backend, _, s = make()
    s.set_speed_in_us(period_us)
    s.set_acceleration(1_000_000)
    s.move(100_000)
    backend.run_for_ms(200)
    backend.channels[0].deliver_until(backend.now())  # a block of pulses reports at its end
    edge = backend.recorder.rising(9)[-1]
    backend.run_until(edge + 200)
    return backend, s, edge


def _block_before_compare(d: int, period_us: int = 100):
    """A blocked section that begins ``d`` ticks before the next step's compare; the
    high time of that step and the interval to the one after."""
    backend, _, edge = _steady(period_us)
    m = backend.machine
    period = period_us * 16
    c = edge + period
    backend.run_until(c - d)
    m.block_interrupts(BLOCK)
    backend.run_for_ms(20)
    times, levels = backend.recorder.pin_edges(9)
    i = list(times).index(c)
    return times[i + 1] - c, backend.recorder.rising(9)[i // 2 + 1] - c


def test_the_pulse_lasts_to_the_end_of_the_block_and_the_next_compare_follows_its_write():
    period = 1600  # 10 kHz
    # the pin falls lat after the entry (block end + sei); the next compare is written
    # ocr later: a value passed by then matches only after the 16-bit timer wrapped
    # the block's start ``d`` ticks before the compare: missed while c + period is at or
    # before the write, c - d + BLOCK + SEI + LAT_A + OCR
    threshold = BLOCK + SEI + LAT_A + OCR - period
    high, interval = _block_before_compare(threshold)
    assert high == BLOCK - threshold + SEI + LAT_A
    assert interval == period + 65536
    high, interval = _block_before_compare(threshold + 1)
    assert high == BLOCK - threshold - 1 + SEI + LAT_A
    assert interval == period


def test_a_compare_just_before_a_block_is_not_delayed():
    high, interval = _block_before_compare(-1)  # the block begins the tick after the compare
    assert high == LAT_A and interval == 1600


def _behind_a_step_interrupt_and_timer_0(profile_name: str) -> list[tuple[str, int]]:
    """Channel A's step interrupt runs [OV - 50, OV + 77); timer 0 overflows at OV, channel
    B's compare comes at OV + 10: when is B entered?"""
    m = Machine(get_profile(profile_name))
    m.start_millis()  # at tick 0: timer 0 overflows every millis_overflow_ticks
    ov = m.timing.millis_overflow_ticks
    seen: list[tuple[str, int]] = []
    m.schedule(ov - 50, lambda: seen.append(("A", m.now - ov)), PRIO_STEP_ISR, enter=127)
    m.schedule(ov + 10, lambda: seen.append(("B", m.now - ov)), PRIO_STEP_ISR + 1, enter=142)
    m.run_until(ov + 2000)
    return seen


def test_on_the_megas_timer_4_timer_0_enters_before_a_pending_step_interrupt():
    """Vectors of the ATmega2560: timer 0's overflow (24) comes before timer 4's compares
    (42-44), so its interrupt, requested while A's runs, enters when A's returns, and B's
    after it.  On timer 1 (compares 18-20) timer 0 has the lower priority; the model
    keeps its routine where it was requested (overlapping A's), B waits to its end."""
    ms = sim_timing(get_profile("atmega2560")).millis_isr_ticks
    a_end = -50 + 127
    assert _behind_a_step_interrupt_and_timer_0("atmega2560") == [("A", -50), ("B", a_end + ms)]
    assert _behind_a_step_interrupt_and_timer_0("atmega2560_timer1") == [("A", -50), ("B", ms)]


def test_a_step_interrupt_waits_for_the_uarts_routine_to_its_reti_the_loop_for_its_cpu_time():
    # build e (the replica's): the UART's transmit interrupt requested at 1000 holds a step
    # interrupt to its reti's end and one instruction (124 ticks on the 328P, 133 on the
    # 2560); the loop and the ramp task (asker None) go on after its CPU time (114)
    for profile, hold in ((ATMEGA328P, 124), (get_profile("atmega2560_timer1"), 133)):
        m = Machine(profile, "e")
        m.uart.loads.append(1000)
        step = object()  # a step channel asks
        cpu = sim_timing(profile, "e").uart_isr_ticks
        assert m.cpu_free_at(1010, step) == 1000 + hold
        assert m.cpu_free_at(1010) == 1000 + cpu
        assert m.cpu_free_at(1000 + hold, step) == 1000 + hold
    # the default build (build d): since the fiftieth pass with the loop's sections and
    # the figures read with them, the replica's hold (118 to the reti, 4 for it; before,
    # the window was the CPU time, 114); the loop still goes on after the CPU time
    m = Machine(ATMEGA328P)
    m.uart.loads.append(1000)
    assert m.cpu_free_at(1010, object()) == 1000 + T.uart_hold_ticks == 1000 + 118 + 4
    assert m.cpu_free_at(1010) == 1000 + T.uart_isr_ticks
