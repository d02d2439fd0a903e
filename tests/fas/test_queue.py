"""The raw command queue: add_queue_entry codes, depth, positions, synchronized start."""

from fas import Engine
from fas.codes import AqeResult
from fas.sim import SimBackend
from rigs.sim import make, periods, pin_position, rising, run_until_idle


def test_raw_commands_run_tick_exact():
    backend, _, s = make(auto_enable=False)
    s.enable_outputs()
    assert s.add_queue_entry(1000, 10, True, start=False) == AqeResult.OK
    assert s.add_queue_entry(2000, 0, True, start=False) == AqeResult.OK  # pause
    assert s.add_queue_entry(800, 5, True, start=False) == AqeResult.OK
    assert s.queue_entries() == 3
    assert s.ticks_in_queue() == 2000 + 800 * 5  # without the entry being executed
    assert not s.is_queue_running()
    assert s.add_queue_entry(None, start=True) == AqeResult.OK
    run_until_idle(backend, s)
    steps = rising(backend, 9)
    assert len(steps) == 15
    assert periods(steps) == [1000] * 9 + [1000 + 2000] + [800] * 4
    assert s.get_current_position() == 15


def test_add_queue_entry_error_codes():
    backend, engine, s = make(dir_pin=None, auto_enable=False)
    assert s.add_queue_entry(None, start=True) == AqeResult.ERROR_EMPTY_QUEUE_TO_START
    assert s.add_queue_entry(100, 1, True) == AqeResult.ERROR_TICKS_TOO_LOW  # < max speed
    assert s.add_queue_entry(400, 1, True) == AqeResult.ERROR_TICKS_TOO_LOW  # < MIN_CMD_TICKS
    assert s.add_queue_entry(400, 2, True, start=False) == AqeResult.OK  # 800 >= 640
    assert s.add_queue_entry(1000, 1, False) == AqeResult.ERROR_NO_DIR_PIN_TO_TOGGLE
    for _ in range(15):
        assert s.add_queue_entry(1000, 1, True, start=False) == AqeResult.OK
    assert s.is_queue_full()
    assert s.add_queue_entry(1000, 1, True, start=False) == AqeResult.QUEUE_FULL
    assert AqeResult.QUEUE_FULL.retry and not AqeResult.ERROR_TICKS_TOO_LOW.retry


def test_queue_never_exceeds_its_depth_while_ramping():
    backend, _, s = make()
    s.set_speed_in_us(40)
    s.set_acceleration(1_000_000)
    s.set_forward_planning_time_in_ms(100)  # asks for more than 16 entries can hold
    s.move(50000)
    run_until_idle(backend, s)
    assert s.queue.max_fill == 16
    assert s.get_current_position() == 50000


def test_esp32_queue_depth_is_32():
    backend, _, s = make("esp32", dir_pin=18, enable_pin=26)
    for _ in range(32):
        assert s.add_queue_entry(5000, 1, True, start=False) == AqeResult.OK
    assert s.add_queue_entry(5000, 1, True, start=False) == AqeResult.QUEUE_FULL


def test_synchronized_start_of_two_queues():
    backend = SimBackend("atmega328p", record=True)
    engine = Engine(backend)
    engine.init()
    a = engine.stepper_connect_to_pin(9)
    b = engine.stepper_connect_to_pin(10)
    for s, dpin in ((a, 5), (b, 7)):
        s.set_direction_pin(dpin)
        for _ in range(4):
            assert s.add_queue_entry(3000, 10, True, start=False) == AqeResult.OK
    backend.run_for(12345)  # nothing runs before the start
    assert rising(backend, 9) == [] and rising(backend, 10) == []
    assert a.add_queue_entry(None, start=True) == AqeResult.OK
    assert b.add_queue_entry(None, start=True) == AqeResult.OK
    backend.wait_until(lambda: not a.is_running() and not b.is_running())
    ra, rb = rising(backend, 9), rising(backend, 10)
    assert len(ra) == len(rb) == 40
    assert ra == rb  # started at the same tick, same commands: identical edges


def test_position_is_exact_in_the_middle_of_a_command():
    backend, _, s = make(auto_enable=False)
    s.add_queue_entry(1000, 200, True)
    samples = []
    for _ in range(7):
        backend.run_for(23_456)
        samples.append((backend.now(), s.get_current_position()))
    run_until_idle(backend, s)
    assert s.get_current_position() == 200
    times, levels = backend.recorder.pin_edges(9)
    falls = [t for t, lv in zip(times, levels, strict=True) if not lv]
    for t, pos in samples:
        # the position counts a step when its interrupt ends the pulse
        assert pos == sum(1 for f in falls if f <= t)
    assert [p for _, p in samples] == sorted(p for _, p in samples)
    assert 0 < samples[0][1] < samples[-1][1] < 200


def test_set_position_after_commands_completed_renumbers_everything():
    backend, _, s = make(auto_enable=False)
    s.add_queue_entry(1000, 100, True)
    backend.run_for(30_000)
    before = s.get_current_position()
    s.set_position_after_commands_completed(1000)
    assert s.get_position_after_commands_completed() == 1000
    assert s.get_current_position() == before + 900
    run_until_idle(backend, s)
    assert s.get_current_position() == 1000


def test_an_entry_after_the_queue_ran_dry_turns_round_before_its_first_step():
    # found by fuzzing the winder: the traverse wrote 50 steps up while the queue the
    # gear left behind had just run dry (the channel running out the last period of
    # one step down); the step interrupt restarts such a queue by its single-step path
    # only, so the 50 steps went out down, the direction turning before the last one
    backend, _, s = make(auto_enable=False)
    s.enable_outputs()
    assert s.add_queue_entry(20000, 1, False, start=True) == AqeResult.OK
    q = s.queue
    assert backend.wait_until(lambda: q.read_idx == q.next_write_idx, 100_000)
    assert s.is_queue_running()  # dry, the channel still runs out its last period
    assert s.add_queue_entry(16000, 10, True, start=False) == AqeResult.OK
    run_until_idle(backend, s)
    assert len(rising(backend, 9)) == 11
    assert pin_position(backend, 9, 5) == 9 == s.get_current_position()
