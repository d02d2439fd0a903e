"""FastAccelStepper's simulator-tested example sketches, run on the library API.

Upstream runs these sketches (examples/ExternalCall, Issue150 ... Issue280) on an
ATmega328P in an AVR simulator and compares the pin activity with its expect.txt:
pulse and transition counts and positions exactly; the "us" figures are ignored by
its judge for these tests.  Here each sketch is written again in Python on ``fas``
(same calls, same order, the same busy-waits and delays), run on the simulated
328P in upstream's build of these sketches (firmware build "upstream_time_measurement":
their ramp task costs what their expect.txt's FillISR lines say, fas.sim.timing), and
its pins are counted with upstream's rules
(:func:`stepperdemo.scenarios.evaluate.pin_activity`).  The expected figures are
upstream's.

The sketches signal success on pin 10 (stepper B's step pin, unused by them): two
pulses mean "pass", one "fail" - that is checked like every other pin.
"""

from __future__ import annotations

from dataclasses import replace

import pytest

from fas import Engine
from fas.codes import (
    PIN_EXTERNAL_FLAG,
    RAMP_DIRECTION_COUNT_DOWN,
    RAMP_DIRECTION_COUNT_UP,
    RAMP_STATE_MASK,
    RampState,
)
from fas.sim import SimBackend
from fas.sim.sketch_loops import sketch_loop_poll
from fas.sim.timing import UPSTREAM_TM_CMD_MASK_SECTIONS, sim_timing
from stepperdemo.demo.testseq.rand import AvrRand
from stepperdemo.scenarios.evaluate import pin_activity, position_from_pins

STEP_A, STEP_B, DIR_A, DIR_B, EN_A, EN_B = 9, 10, 5, 7, 6, 8


class Sketch:
    """Arduino's view of the simulated chip: delay(), millis(), digitalWrite()."""

    def __init__(self, loop_sections: bool = False, task_sections: bool = False) -> None:
        self.backend = SimBackend("atmega328p", record=True, build="upstream_time_measurement")
        if task_sections:  # the ramp task's sections per command (off by default)
            m = self.backend.machine
            m.timing = replace(m.timing, fill_cmd_mask_sections=UPSTREAM_TM_CMD_MASK_SECTIONS)
        # the sketch's own waiting loops' interrupts-off sections (fas.sim.sketch_loops):
        # off by default, not landed
        self.loop_sections = loop_sections
        self.delay_starts: list[int] = []  # when each delay() began (ticks)
        self.backend.app_spend(sim_timing(self.backend.profile).boot_ticks)  # reset -> setup()
        self.backend.app_started()
        self.engine = Engine(self.backend)
        self.tps = self.backend.profile.ticks_per_s

    def poll(self, loop: str):
        """The waiting loop's sections where followed (None: not followed)."""
        if not self.loop_sections:
            return None
        return sketch_loop_poll("upstream_time_measurement", self.backend.profile.name, loop)

    def delay(self, ms: int) -> None:
        b = self.backend
        self.delay_starts.append(b.now())
        b.app_polls(self.poll("delay"))  # micros(), read over and over
        try:
            b.app_wait_until(b.now() + ms * self.tps // 1000)
        finally:
            b.app_polls(None)

    def millis(self) -> int:
        return self.backend.millis()

    def busy_wait(self, condition, loop: str = "") -> None:
        """``while (condition()) {}``: the loop polls; time passes event by event.
        ``loop``: the loop's kind where it has interrupts-off sections."""
        m = self.backend.machine
        poll = self.poll(loop) if loop else None
        if poll is not None:
            m.poll_begin(*poll)
        try:
            assert self.backend.wait_until(lambda: not condition(), 600 * self.tps)
        finally:
            if poll is not None:
                m.poll_end()
        m.resume()  # the loop polled; it goes on once the CPU is free

    def print(self, text: str) -> None:
        self.backend.console_write(text.encode())

    def signal(self, ok: bool) -> None:
        """The sketches' verdict: pin 10 pulses twice when ok, once otherwise."""
        b = self.backend
        b.write_pin(DIR_B, 0)  # pinMode(DIRPIN, OUTPUT): the level is known from here
        b.write_pin(DIR_B, 1)
        b.write_pin(STEP_B, 0)
        for _ in range(2 if ok else 1):
            b.write_pin(STEP_B, 1)
            b.write_pin(STEP_B, 0)

    def settle(self) -> None:
        """The chip halts here (``sleep_cpu()``): report the pulses made up to now."""
        for ch in self.backend.channels:
            ch.deliver_until(self.backend.now())

    def counts(self) -> dict[str, tuple[int, int]]:
        self.settle()
        out = {}
        for name, pin in (("DirA", DIR_A), ("DirB", DIR_B), ("EnableA", EN_A),
                          ("EnableB", EN_B), ("StepA", STEP_A), ("StepB", STEP_B)):
            act = pin_activity(self.backend, pin)
            out[name] = (act.rises, act.falls)
        return out

    def position(self, step: int, direction: int) -> int:
        self.settle()
        return position_from_pins(self.backend, step, direction)

    def stepper(self, step: int, direction: int, enable: int):
        s = self.engine.stepper_connect_to_pin(step)
        s.set_direction_pin(direction)
        s.set_enable_pin(enable, True)
        return s


def _i16(v: int) -> int:
    v &= 0xFFFF
    return v - 0x10000 if v & 0x8000 else v


# ----------------------------------------------------------------- ExternalCall
def test_external_call_sketch():
    sk = Sketch()
    b = sk.backend
    sk.engine.init()

    def set_external_pin(pin: int, value: int) -> bool:
        # returns the previous level: the library has to call twice to see it set
        pin &= ~PIN_EXTERNAL_FLAG
        if pin not in b.machine.pins.first_write:
            b.write_pin(pin, 0)  # pinMode(pin, OUTPUT): driven LOW before the first write
        old = b.read_pin(pin)
        b.write_pin(pin, value)
        return bool(old)

    sk.engine.set_external_call_for_pin(set_external_pin)
    s1 = sk.engine.stepper_connect_to_pin(STEP_A)
    s1.set_direction_pin(DIR_A | PIN_EXTERNAL_FLAG)
    s1.set_enable_pin(EN_A)
    s1.set_auto_enable(True)
    s1.set_speed_in_us(10000)
    s1.set_acceleration(1000)
    s2 = sk.stepper(STEP_B, DIR_B, EN_B)
    s2.set_auto_enable(True)
    s2.set_speed_in_us(10000)
    s2.set_acceleration(1000)
    for s in (s1, s2):
        for move in (1000, -900, 500, -450, 40):
            s.move(move, blocking=True)
    sk.delay(1000)
    assert sk.counts() == {"DirA": (3, 2), "DirB": (3, 2), "EnableA": (2, 1),
                           "EnableB": (2, 1), "StepA": (2890, 2890),
                           "StepB": (2890, 2890)}
    assert sk.position(STEP_A, DIR_A) == 190 and sk.position(STEP_B, DIR_B) == 190


# --------------------------------------------------------------------- Issue150
def test_issue150_sketch_speed_is_taken_over_on_run_forward():
    """getCurrentSpeedInUs() must not report the previous loop's target speed."""
    sk = Sketch()
    sk.engine.init()
    s = sk.stepper(STEP_A, DIR_A, EN_A)
    s.set_auto_enable(True)
    s.set_acceleration(1000000)
    rand = AvrRand(1)  # avr-libc's rand() without srand()
    fail = 0
    last_target = 0
    for loop_cnt in range(1, 51):
        target = _i16(rand.rand() % 40000 + 100)  # an int on the AVR: wraps above 32767
        s.set_speed_in_us(target & 0xFFFFFFFF)
        s.run_forward()
        sk.delay(500)
        actual = _i16(s.get_current_speed_in_us())
        sk.print(f"Loop{loop_cnt}\r\ntarget: {target}\r\nactual: {actual}\r\n")
        if actual == last_target and target != last_target:
            fail += 1
        last_target = target
    sk.signal(fail == 0)
    s.move_to(4000, blocking=True)
    sk.delay(1000)
    c = sk.counts()
    assert c["StepA"] == (4000, 4000) and sk.position(STEP_A, DIR_A) == 4000
    assert c["DirA"] == (0, 0) and c["EnableA"] == (2, 1)
    assert c["StepB"] == (2, 2) and c["DirB"] == (1, 0) and c["EnableB"] == (0, 0)


# ------------------------------------------------------------- Issue151 / 152
@pytest.mark.parametrize("accel,sketch", [(10000, "Issue151"), (1000000, "Issue152")])
def test_issue151_152_single_stepper_at_50khz_reaches_its_target(accel, sketch):
    sk = Sketch()
    sk.engine.init()
    s = sk.stepper(STEP_A, DIR_A, EN_A)
    s.set_auto_enable(True)
    s.set_acceleration(accel)
    s.set_speed_in_hz(50000)
    s.move_to(20000)
    sk.busy_wait(s.is_running)
    sk.signal(s.get_current_position() == 20000)
    sk.delay(1000)
    c = sk.counts()
    assert c["StepA"] == (20000, 20000) and sk.position(STEP_A, DIR_A) == 20000
    assert c["DirA"] == (0, 0) and c["EnableA"] == (2, 1)
    assert c["StepB"] == (2, 2) and c["DirB"] == (1, 0)


# --------------------------------------------------------------------- Issue172
def test_issue172_moves_relative_to_the_stop_target():
    sk = Sketch()
    sk.engine.init()
    s = sk.stepper(STEP_A, DIR_A, EN_A)
    s.set_auto_enable(True)
    s.set_acceleration(100000)
    s.set_speed_in_us(100)
    s.move(10000)

    def state() -> int:
        return s.ramp_state() & RAMP_STATE_MASK

    sk.busy_wait(lambda: state() != RampState.COAST)
    sk.print(f"coast at {s.get_current_position()}\r\n")
    s.stop_move()
    sk.busy_wait(lambda: state() == RampState.COAST)
    pos_end = s.get_position_after_commands_completed()
    target_pos = s.target_pos() & 0xFFFFFFFF  # a uint32_t in the sketch
    s.move(-1)
    s.move(1 - target_pos)
    sk.busy_wait(lambda: state() != RampState.ACCELERATE)
    max_pos = s.get_current_position()
    sk.busy_wait(s.is_running)
    sk.print(f"target position after stopMove() processed {target_pos}\r\n"
             f"stop at and move back {pos_end}\r\nmax position {max_pos}\r\n")
    pos = s.get_current_position()
    sk.print(f"stop at {pos}\r\n")
    sk.signal(pos == 0)
    sk.delay(1000)
    c = sk.counts()
    assert pos == 0 and sk.position(STEP_A, DIR_A) == 0
    assert c["StepA"] == (2060, 2060)
    assert c["DirA"] == (0, 1) and c["EnableA"] == (2, 1)
    assert c["StepB"] == (2, 2) and c["DirB"] == (1, 0)


# --------------------------------------------------------------------- Issue173
def test_issue173_force_stop_then_set_position_clears_the_target():
    sk = Sketch()
    sk.engine.init()
    s = sk.stepper(STEP_A, DIR_A, EN_A)
    s.set_auto_enable(True)
    s.set_acceleration(100000)
    s.set_speed_in_us(100)
    s.move(10000)
    sk.busy_wait(lambda: s.ramp_state() & RAMP_STATE_MASK != RampState.COAST)
    sk.print(f"coast at {s.get_current_position()}\r\n")
    s.force_stop()
    sk.busy_wait(s.is_running)
    pos = s.get_current_position()
    sk.print(f"position after force stop: {pos} with target pos: {s.target_pos()}\r\n")
    s.set_current_position(0)
    ok = s.target_pos() == 0
    sk.print(f"position after setCurrent position: {s.get_current_position()} "
             f"with target pos: {s.target_pos()}\r\n")
    s.move(-1)
    s.move(1 - pos)
    sk.busy_wait(s.is_running)
    sk.signal(ok)
    sk.delay(1000)
    c = sk.counts()
    assert ok and sk.position(STEP_A, DIR_A) == 0
    assert c["StepA"] == (1050, 1050)
    assert c["DirA"] == (0, 1) and c["EnableA"] == (3, 2)
    assert c["StepB"] == (2, 2)


# --------------------------------------------------------------------- Issue208
def _issue208(loop_sections: bool = False, task_sections: bool = False):
    sk = Sketch(loop_sections, task_sections)
    sk.print("Init\r\n")
    sk.engine.init()
    sk.print("AVR\r\n9\r\n")
    s = sk.engine.stepper_connect_to_pin(STEP_A)
    s.set_direction_pin(DIR_A)  # no enable pin in this sketch
    s.set_auto_enable(True)
    sk.print("OK\r\nDone\r\n")
    errors = []
    last = [0]

    def watch(expect_up: bool, done_state: int):
        def still_running() -> bool:
            if s.ramp_state() == done_state:
                return False
            v = s.get_current_speed_in_milli_hz(False)
            if v != last[0]:
                if (v < last[0]) if expect_up else (v > last[0]):
                    errors.append((last[0], v))
                last[0] = v
            return True
        return still_running

    sk.print("Start test: speed up\r\n")
    s.set_acceleration(10000)
    s.set_speed_in_hz(36800)
    s.run_forward()
    sk.busy_wait(watch(True, RampState.COAST | RAMP_DIRECTION_COUNT_UP), "speed_read")
    sk.delay(20)
    last[0] = s.get_current_speed_in_milli_hz(False)
    sk.print("Reverse\r\n")
    s.run_backward()
    sk.busy_wait(watch(False, RampState.COAST | RAMP_DIRECTION_COUNT_DOWN), "speed_read")
    s.stop_move()
    sk.signal(not errors)
    sk.print("PASS\r\n")
    sk.delay(1000)  # then the chip halts, in the middle of the deceleration
    return sk, errors


@pytest.fixture(scope="module")
def issue208():
    return _issue208()


def test_issue208_speed_is_monotone_while_speeding_up_and_reversing(issue208):
    """expect.txt: every count exactly, StepA's within its "~~120/120/5/700"."""
    sk, errors = issue208
    c = sk.counts()
    assert not errors
    assert abs(c["StepA"][0] - 234999) <= 120 and abs(c["StepA"][1] - 234999) <= 120
    assert c["DirA"] == (0, 1) and c["DirB"] == (1, 0)
    assert c["EnableA"] == (0, 0) and c["EnableB"] == (0, 0)
    assert c["StepB"] == (2, 2) and sk.position(STEP_B, DIR_B) == 2
    # Position[A]=37271~200: the chip halts 1 s into the final deceleration, so where
    # the reversal lies decides it (measured here: 37271)
    assert abs(sk.position(STEP_A, DIR_A) - 37271) <= 200


def test_issue208_longest_pulse_as_upstream(issue208):
    """expect.txt: StepA "Max High=9us" within its ~~.../5/...: a pulse lasts as long as
    the step interrupt waits behind the others (issue 23 item 2)."""
    sk, _ = issue208
    sk.settle()
    assert abs(int(pin_activity(sk.backend, STEP_A).high_max_us) - 9) <= 5


@pytest.mark.xfail(strict=True, reason="measured Total High 916550 us; upstream 923729 +- 700 "
                   "us (issue 23 item 2: the pulses waiting behind other interrupts are "
                   "fewer or shorter than on the chip)")
def test_issue208_pulse_high_time_as_upstream(issue208):
    """expect.txt: StepA "Max High=9us Total High=923729us~~120/120/5/700"."""
    sk, _ = issue208
    sk.settle()
    a = pin_activity(sk.backend, STEP_A)
    assert abs(int(a.high_total_us) - 923729) <= 700


# The sketch's own loops' interrupts-off sections (fas.sim.sketch_loops; off by default).
# Issue208 rebuilt and run cycle by cycle (bench/replica/sketch_replica.py, FastAccelStepper
# 1.2.7): its last delay(1000), the chip decelerating from 36.8 kHz, makes 31 969 pulses
# with 127 621 us high in all, 5 639 of them held by micros()'s section.
REPLICA_208_LAST_DELAY_HIGH_US = 127621
# upstream's own band for a total high time, relative: 700 of 923 729 us (expect.txt)
UPSTREAM_208_HIGH_BAND = 700 / 923729


@pytest.fixture(scope="module")
def issue208_sections():
    return _issue208(loop_sections=True)


def _high_us_from(sk: Sketch, start: int) -> float:
    sk.settle()
    times, levels = sk.backend.recorder.pin_edges(STEP_A)
    total, rise = 0, None
    for t, lv in zip(times, levels, strict=True):
        if lv:
            rise = t if t >= start else None
        elif rise is not None:
            total += t - rise
            rise = None
    return total / sk.backend.profile.ticks_per_us


def test_issue208_with_loop_sections_still_as_upstream(issue208_sections):
    """The same expect.txt figures as without the sections (counts, position, Max High)."""
    sk, errors = issue208_sections
    c = sk.counts()
    assert not errors
    assert abs(c["StepA"][0] - 234999) <= 120 and abs(c["StepA"][1] - 234999) <= 120
    assert c["DirA"] == (0, 1) and c["StepB"] == (2, 2)
    assert abs(sk.position(STEP_A, DIR_A) - 37271) <= 200
    assert abs(int(pin_activity(sk.backend, STEP_A).high_max_us) - 9) <= 5


def test_issue208_last_delay_sections_hold_pulses_as_the_rebuilt_sketch(issue208_sections,
                                                                        issue208):
    """micros()'s section in delay() holds step interrupts: the pulses of the last
    delay(1000) come closer to the rebuilt sketch's high time with the sections followed
    than without (without: 124 739 us)."""
    on = _high_us_from(issue208_sections[0], issue208_sections[0].delay_starts[-1])
    off = _high_us_from(issue208[0], issue208[0].delay_starts[-1])
    assert abs(on - REPLICA_208_LAST_DELAY_HIGH_US) < abs(off - REPLICA_208_LAST_DELAY_HIGH_US)


@pytest.mark.xfail(strict=True, reason="measured 128047 us; the rebuilt sketch 127621 "
                   "+- 97 us (upstream's relative band for a total high time; the model's "
                   "passes at a fixed pitch alias with the step period)")
def test_issue208_last_delay_high_time_as_the_rebuilt_sketch(issue208_sections):
    sk, _ = issue208_sections
    high = _high_us_from(sk, sk.delay_starts[-1])
    band = UPSTREAM_208_HIGH_BAND * REPLICA_208_LAST_DELAY_HIGH_US
    assert abs(high - REPLICA_208_LAST_DELAY_HIGH_US) <= band


@pytest.mark.xfail(strict=True, reason="measured Total High 922046 us with the sketch "
                   "loop's sections; upstream 923729 +- 700 us (the rebuilt sketch: "
                   "922944; short: the pulses held behind timer 0 and the ramp task's "
                   "entry, docs/timing-model.md, \"The upstream sketches' loop sections\")")
def test_issue208_pulse_high_time_with_loop_sections_as_upstream(issue208_sections):
    sk, _ = issue208_sections
    sk.settle()
    assert abs(int(pin_activity(sk.backend, STEP_A).high_total_us) - 923729) <= 700


@pytest.fixture(scope="module")
def issue208_all_sections():
    return _issue208(loop_sections=True, task_sections=True)


def test_issue208_with_all_sections_still_as_upstream(issue208_all_sections):
    """The sketch loop's sections and the ramp task's per command: the counts, position
    and Max High of expect.txt still."""
    sk, errors = issue208_all_sections
    c = sk.counts()
    assert not errors
    assert abs(c["StepA"][0] - 234999) <= 120 and abs(c["StepA"][1] - 234999) <= 120
    assert abs(sk.position(STEP_A, DIR_A) - 37271) <= 200
    assert abs(int(pin_activity(sk.backend, STEP_A).high_max_us) - 9) <= 5


def test_issue208_pulse_high_time_with_all_sections_as_upstream(issue208_all_sections):
    """With both switches (off by default) StepA's Total High meets expect.txt's band:
    923 263 us here.  Not landed as the default: the rebuilt sketch itself makes 922 944
    (785 short of upstream's figure), and the variant's delay() half holds more than
    the rebuilt sketch's (test_issue208_last_delay_high_time_as_the_rebuilt_sketch)."""
    sk, _ = issue208_all_sections
    sk.settle()
    assert abs(int(pin_activity(sk.backend, STEP_A).high_total_us) - 923729) <= 700


# --------------------------------------------------------------------- Issue250
def _issue250(block_us: int, loops: int, toggle: bool, use_move_to: bool) -> int:
    sk = Sketch()
    b = sk.backend
    sk.engine.init()
    s = sk.stepper(STEP_A, DIR_A, EN_A)
    s.set_auto_enable(True)
    s.set_delay_to_enable(50)
    s.set_delay_to_disable(50)
    s.set_speed_in_hz(40000)
    s.set_acceleration(100000)
    rand = AvrRand(1)
    previous = 0
    for loop_cnt in range(1, loops + 1):
        sk.print(f"Loop={loop_cnt}\r\n")
        runtime = rand.rand() % 50 + 50
        forward = (loop_cnt & 1) == 1 or not toggle
        if use_move_to:
            s.move_to(10000 if forward else -10000)
        elif forward:
            s.run_forward()
        else:
            s.run_backward()
        start = sk.millis()
        while sk.millis() < 2 * previous + runtime + start:
            b.block_interrupts(block_us * 16)  # noInterrupts(); _delay_us(); interrupts()
            b.app_spend(2 * 16)  # the loop around it
        previous = runtime
    s.stop_move()
    sk.busy_wait(s.is_running)
    s.move_to(0, blocking=True)
    sk.delay(100)
    return sk.position(STEP_A, DIR_A)


@pytest.mark.long
def test_issue250_20us_interrupt_blocks_lose_no_step():
    assert _issue250(20, 200, True, True) == 0  # judge_pos0: Position[A]=0


@pytest.mark.long
def test_issue250_30us_interrupt_blocks_lose_no_step():
    assert _issue250(30, 100, False, False) == 0


# --------------------------------------------------------------------- Issue280
@pytest.fixture(scope="module")
def issue280():
    sk = Sketch()
    sk.engine.init()
    s = sk.stepper(STEP_A, DIR_A, EN_A)
    s.set_auto_enable(True)
    s.set_speed_in_hz(40000)
    s.set_acceleration(100000)
    s.run_forward()
    sk.busy_wait(lambda: s.ramp_state() & RAMP_STATE_MASK != RampState.COAST)
    s.stop_move()
    sk.delay(20)
    err = not s.is_stopping()
    s.set_acceleration(90000)
    s.apply_speed_acceleration()
    sk.print(f"{s.get_current_speed_in_us()}\r\n")
    start = sk.millis()
    while sk.millis() - start < 2000 and s.is_running():
        sk.delay(10)
    sk.print(f"{s.get_current_speed_in_us()}\r\n")
    err = err or s.is_running()
    sk.print(f"Reached Position={s.get_current_position()}\r\n")
    s.move_to(0, blocking=True)
    sk.delay(100)
    return sk, err


def test_issue280_new_acceleration_while_stopping_still_stops(issue280):
    """expect.txt, every figure exact: the counts met here."""
    sk, err = issue280
    c = sk.counts()
    assert not err
    assert sk.position(STEP_A, DIR_A) == 0
    assert c["StepA"][0] == c["StepA"][1]
    assert c["DirA"] == (0, 1) and c["DirB"] == (0, 0)
    assert c["EnableB"] == (0, 0) and c["StepB"] == (0, 0)


@pytest.mark.xfail(strict=True, reason="measured 33992 pulses, upstream 33872 +- 0 "
                   "(FastAccelStepper 1.2.7 built here and run in Debian's simavr: 33983)")
def test_issue280_pulse_count_as_upstream(issue280):
    sk, _ = issue280
    assert sk.counts()["StepA"] == (33872, 33872)


def test_issue280_enable_transitions_as_upstream(issue280):
    """expect.txt: EnableA 3*L->H, 2*H->L - the driver was switched off between the stop
    and moveTo(0).  Whether a ramp task runs between the queue running dry and the
    sketch's poll that sees it depends on the poll's phase: each ``delay(10)`` that ends
    inside a ramp task goes on after it, and a task longer than ~480 us (with the default
    build's costs) locks every second poll to the 4.096 ms task grid."""
    sk, _ = issue280
    assert sk.counts()["EnableA"] == (3, 2)
