"""Property tests: random command sequences on virtual time keep the invariants."""

import os
from bisect import bisect_left, bisect_right

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rigs.sim import make, pin_position, run_until_idle

op = st.one_of(
    st.tuples(st.just("move"), st.integers(-5000, 5000)),
    st.tuples(st.just("move_to"), st.integers(-5000, 5000)),
    st.tuples(st.just("speed_us"), st.integers(40, 3000)),
    st.tuples(st.just("accel"), st.integers(100, 2_000_000)),
    st.tuples(st.just("apply"), st.just(0)),
    st.tuples(st.just("stop"), st.just(0)),
    st.tuples(st.just("forward"), st.just(0)),
    st.tuples(st.just("backward"), st.just(0)),
    st.tuples(st.just("force_stop"), st.just(0)),
    st.tuples(st.just("wait_ms"), st.integers(0, 400)),
)

PROP = settings(max_examples=int(os.environ.get("FAS_PROP_EXAMPLES", "40")), deadline=None,
                suppress_health_check=[HealthCheck.too_slow])


def apply_ops(backend, s, ops):
    speeds = [1600]
    s.set_speed_in_us(100)
    s.set_acceleration(10_000)
    for name, value in ops:
        if name == "move":
            s.move(value)
        elif name == "move_to":
            s.move_to(value)
        elif name == "speed_us":
            if s.set_speed_in_us(value) == 0:
                speeds.append(value * 16)
        elif name == "accel":
            s.set_acceleration(value)
        elif name == "apply":
            s.apply_speed_acceleration()
        elif name == "stop":
            s.stop_move()
        elif name == "forward":
            s.run_forward()
        elif name == "backward":
            s.run_backward()
        elif name == "force_stop":
            s.force_stop()
        elif name == "wait_ms":
            backend.run_for_ms(value)
    return speeds


@PROP
@given(st.lists(op, min_size=1, max_size=12))
def test_random_sequences_keep_the_invariants(ops):
    backend, _, s = make()
    speeds = apply_ops(backend, s, ops)
    # bring everything to rest: a fast deceleration, then stop
    s.set_acceleration(1_000_000)
    s.apply_speed_acceleration()
    s.stop_move()
    run_until_idle(backend, s, limit_s=3600)

    # the motor ends idle where the queue said it would
    assert not s.is_running()
    assert s.get_current_position() == s.get_position_after_commands_completed()
    # edges counted on the pins agree with the library
    assert pin_position(backend, 9, 5) == s.get_current_position()
    # the queue never held more than its depth
    assert s.queue.max_fill <= 16

    times, levels = backend.recorder.pin_edges(9)
    rises = [t for t, lv in zip(times, levels, strict=True) if lv]
    falls = [t for t, lv in zip(times, levels, strict=True) if not lv]
    assert len(rises) == len(falls)
    # no period faster than the fastest speed that was ever set
    fastest = min(speeds)
    for a, b in zip(rises, rises[1:], strict=False):
        assert b - a >= fastest
    # the direction pin never changes during a pulse, nor just before one
    dir_times, _ = backend.recorder.pin_edges(5)
    for t in dir_times:
        i = bisect_right(rises, t) - 1
        if i >= 0:
            assert t >= falls[i]  # not while the pulse is high
        j = bisect_left(rises, t)
        if j < len(rises):
            assert rises[j] - t >= 640 - 60  # a whole command before the next step


@PROP
@given(st.integers(-3000, 3000), st.integers(0, 300), st.integers(40, 2000),
       st.integers(500, 500_000))
def test_stop_during_a_move_ends_at_the_queue_end(target, after_ms, speed_us, accel):
    backend, _, s = make()
    s.set_speed_in_us(speed_us)
    s.set_acceleration(accel)
    s.move_to(target)
    backend.run_for_ms(after_ms)
    s.stop_move()
    run_until_idle(backend, s, limit_s=3600)
    assert s.get_current_position() == s.get_position_after_commands_completed()
    assert pin_position(backend, 9, 5) == s.get_current_position()
    if after_ms == 0 or target == 0:
        return
    # a stop never runs past the target it was moving to
    if target > 0:
        assert s.get_current_position() <= target
    else:
        assert s.get_current_position() >= target
