"""Issue 25: the G-code machine's blocks planned with look-ahead (``fas.path``), on
virtual time, measured on the simulated chip's pins: blocks join without a pause, the
feed holds across collinear joints, a corner is taken at the junction-deviation speed,
every axis stays within a step of the path, a dwell and a synchronized output wait for
the motion before them, overrides re-plan, and the exact-stop executor (``$171=1``)
takes at least twice as long on short segments."""

from __future__ import annotations

import math

import pytest

from stepperdemo.gcode.program import RawGrbl

TPS = 16_000_000
X_STEP, X_DIR, Y_STEP, Y_DIR = 6, 21, 7, 20  # atmega2560: StepperDemo's steppers 1, 2
SPU = 80
ACCEL = 500.0  # mm/s^2 per axis
MM = (f"$100={SPU}\n$101={SPU}\n$102={SPU}\n$110=12000\n$111=12000\n$112=12000\n"
      f"$120={ACCEL:g}\n$121={ACCEL:g}\n$122={ACCEL:g}\n")


def grbl(setup: str = "") -> RawGrbl:
    g = RawGrbl("atmega2560", record=True)
    g.send((MM + setup).encode())
    assert g.settle()
    g.take()
    return g


def stream(g: RawGrbl, program: str) -> None:
    """Send the program a line at a time as a sender does (the next line once the
    machine has read the one before: Grbl's receive buffer holds 128 bytes)."""
    for line in program.splitlines():
        g.send(line.encode() + b"\n")
        while g.machine.rx.pending or g.machine.pending is not None:
            g.advance_ticks(TPS // 1000)


def run(program: str, setup: str = "") -> RawGrbl:
    g = grbl(setup)
    stream(g, program)
    assert g.settle()
    out = g.take().decode()
    assert "error" not in out and "ALARM" not in out, out
    return g


def signed(g: RawGrbl, step: int, direction: int, stepper) -> list[tuple[int, int]]:
    """(tick, +1/-1) of every step on ``step``, the direction read from its pin."""
    rec = g.backend.recorder
    times, levels = rec.pin_edges(direction)
    up = stepper.direction_pin_high_counts_up()
    out, k, level = [], -1, 0
    for t in rec.rising(step):
        while k + 1 < len(times) and times[k + 1] <= t:
            k += 1
            level = levels[k]
        out.append((t, 1 if bool(level) == up else -1))
    return out


def chebyshev(px: float, py: float, a, b) -> float:
    """Chebyshev distance from (px, py) to the segment a-b (steps)."""
    ax, ay, dx, dy = a[0] - px, a[1] - py, b[0] - a[0], b[1] - a[1]
    ts = [0.0, 1.0] + [-n / d for n, d in ((ax, dx), (ay, dy), (ax - ay, dx - dy),
                                           (ax + ay, dx + dy)) if d and 0 < -n / d < 1]
    return min(max(abs(ax + t * dx), abs(ay + t * dy)) for t in ts)


def circle(n: int, r: float, feed: int) -> tuple[str, list[tuple[int, int]]]:
    """G-code of an n-gon of radius ``r`` mm from (r, 0) round and back, and its vertices
    in steps."""
    pts = [(r * math.cos(2 * math.pi * k / n), r * math.sin(2 * math.pi * k / n))
           for k in range(n + 1)]
    text = f"G0 X{r:g} Y0\n" + "".join(f"G1 X{x:.4f} Y{y:.4f} F{feed}\n" for x, y in pts[1:])
    return text, [(round(x * SPU), round(y * SPU)) for x, y in pts]


def right_angle_corner(deviation: float) -> tuple[float, float]:
    """A right angle's bisector acceleration (each axis at ACCEL) and its junction
    speed by Grbl's formula v^2 = a_j d sin(45) / (1 - sin(45)), mm/s^2 and mm/s."""
    a_j = ACCEL / math.cos(math.pi / 4)
    s = math.sin(math.pi / 4)
    return a_j, math.sqrt(a_j * deviation * s / (1 - s))


def test_lookahead_is_the_default_and_171_selects_exact_stop():
    g = grbl()
    assert g.machine.executor.kind == "lookahead"
    g.send(b"$$\n")
    out = g.take().decode().split("\r\n")
    assert "$11=0.010" in out and "$12=0.002" in out and "$171=0" in out
    g.send(b"$171=1\nG1 X1 F600\n")
    assert g.settle()
    assert g.machine.executor.kind == "exact_stop"
    g.send(b"$171=2\n")
    assert g.take().decode().split("\r\n")[-3:] == ["[MSG:$171 must be 0 or 1]", "error:3", ""]


def test_esp32_wiring_shares_a_direction_pin_so_every_block_stops():
    """StepperDemo's ESP32 wiring has X and Y on one direction pin (18): a path group
    cannot drive them, the machine keeps the exact-stop executor."""
    g = RawGrbl("esp32")
    assert g.machine.executor.kind == "exact_stop"


def test_collinear_segments_join_without_a_pause_and_keep_the_feed():
    """20 segments of 2 mm along X at F3000: one run; across every joint after the
    acceleration the X pin runs at the feed (50 mm/s = 4000 steps/s)."""
    program = "".join(f"G1 X{2 * k} F3000\n" for k in range(1, 21))
    g = run(program)
    assert len(g.machine.motion_log) == 1  # one run: no stop between the blocks
    xs = g.backend.recorder.rising(X_STEP)
    assert len(xs) == 40 * SPU
    d_acc = (50.0 ** 2) / (2 * ACCEL)  # mm to the feed: 2.5
    for k in range(2, 19):
        joint = 2 * k * SPU  # steps at the joint
        if 2 * k < d_acc + 1 or 2 * k > 40 - d_acc - 1:
            continue
        speed = 16 / ((xs[joint + 7] - xs[joint - 9]) / TPS)  # 16 steps across it
        assert abs(speed / (50 * SPU) - 1) < 0.005, (k, speed)
    gaps = [b - a for a, b in zip(xs, xs[1:], strict=False)]
    assert max(gaps[len(gaps) // 4: 3 * len(gaps) // 4]) <= TPS // (50 * SPU) + 2


def test_a_right_angle_corner_is_taken_at_the_junction_deviation_speed():
    """X 20 mm then Y 20 mm at F6000, $11=0.05: the corner's speed by Grbl's formula,
    the acceleration along the bisector 500 / cos 45 deg:
    v^2 = a_j d sin(45) / (1 - sin(45)).  Measured from the pins: X's last step is the
    corner's tick; from there Y leaves at v and accelerates at 500 mm/s^2, so its step
    k comes where k / 80 = v t + 250 t^2."""
    g = run("G1 X20 F6000\nG1 Y20\n", setup="$11=0.05\n")
    a_j, v = right_angle_corner(0.05)  # v 9.24 mm/s
    xs, ys = g.backend.recorder.rising(X_STEP), g.backend.recorder.rising(Y_STEP)
    assert len(g.machine.motion_log) == 1
    corner = xs[-1]
    assert ys[0] > corner
    k = 80  # 1 mm after the corner (acceleration to F6000 takes 10 mm)
    t = (ys[k - 1] - corner) / TPS
    measured = (k / SPU - ACCEL * t * t / 2) / t
    assert abs(measured / v - 1) < 0.01, (measured, v)


def test_every_axis_stays_within_a_step_of_the_path_round_a_polygon():
    text, verts = circle(72, 5.0, 3000)  # chords of 0.44 mm
    g = run(text)
    assert len(g.machine.motion_log) == 1  # the G0 to the start joins the polygon
    st = g.machine.steppers
    events = sorted([(t, 0, d) for t, d in signed(g, X_STEP, X_DIR, st[0])]
                    + [(t, 1, d) for t, d in signed(g, Y_STEP, Y_DIR, st[1])])
    x = y = 0
    worst = 0.0
    i = 0
    k = 0
    path = [(0, 0)] + verts
    while i < len(events):
        t = events[i][0]
        while i < len(events) and events[i][0] == t:
            _, axis, d = events[i]
            x, y = (x + d, y) if axis == 0 else (x, y + d)
            i += 1
        dists = [chebyshev(x, y, path[j], path[j + 1])
                 for j in range(max(0, k - 1), min(k + 3, len(path) - 1))]
        best = min(dists)
        k = max(0, k - 1) + dists.index(best)
        worst = max(worst, best)
    assert (x, y) == verts[-1] and g.machine.positions()[:2] == list(verts[-1])
    assert worst <= 1.0


def test_short_segments_take_at_most_half_the_exact_stop_time():
    text, _ = circle(72, 5.0, 3000)
    times = {}
    for motion in (0, 1):
        g = run(text, setup=f"$171={motion}\n")
        xs = g.backend.recorder.rising(X_STEP)
        times[motion] = xs[-1] - xs[0]
    assert times[0] <= times[1] / 2, times


def test_a_dwell_waits_for_the_motion_before_it_then_the_next_block_starts_after_it():
    g = run("G1 X5 F3000\nG4 P0.1\nG1 X10\n")
    xs = g.backend.recorder.rising(X_STEP)
    first_end, second_start = xs[5 * SPU - 1], xs[5 * SPU]
    assert second_start - first_end >= TPS // 10  # the dwell after the first block
    assert second_start - first_end < TPS // 10 + TPS // 20  # ... and not much more


def test_synchronized_output_changes_between_the_blocks_of_a_planned_path():
    g = run("G1 X5 F3000\nG1 X10\nM62 P0\nG1 X15\n")
    xs = g.backend.recorder.rising(X_STEP)
    times, levels = g.backend.recorder.pin_edges(22)  # Dout0 on the atmega2560
    (rise,) = [t for t, lv in zip(times, levels, strict=True) if lv]
    assert xs[10 * SPU - 1] < rise < xs[10 * SPU]  # after X10 (both blocks), before X15
    assert len(g.machine.motion_log) == 2  # the first two blocks were one run


def test_feed_override_replans_the_queued_blocks():
    """Ten 10 mm blocks at F1200 (20 mm/s); 0x91 (+10 %) twice -> 120 %, then 0x92
    (-10 %) five times -> 70 %: X runs at 24 mm/s, then 14 mm/s, across the blocks."""
    g = grbl()
    stream(g, "".join(f"G1 X{10 * k} F1200\n" for k in range(1, 11)))
    g.advance(0.8)
    g.send(b"\x91\x91")
    g.advance(1.0)
    t_fast = g.backend.now()
    g.send(b"\x92\x92\x92\x92\x92")
    g.advance(1.0)
    t_slow = g.backend.now()
    assert g.settle()
    xs = g.backend.recorder.rising(X_STEP)

    def speed(at: int) -> float:
        window = [t for t in xs if at - TPS // 5 <= t < at]
        return (len(window) - 1) / ((window[-1] - window[0]) / TPS) / SPU

    assert abs(speed(t_fast) / 24 - 1) < 0.01
    assert abs(speed(t_slow) / 14 - 1) < 0.01
    assert len(xs) == 100 * SPU and len(g.machine.motion_log) == 1


def test_speed_listener_reports_the_path_speed_at_every_queue_command():
    """The laser hook through the executor seam: (tick, units/min, the block) at every
    command of the dominant axis, ahead of time; F3000 while cruising, 0 at the end."""
    g = grbl()
    seen: list[tuple[int, float, object]] = []
    assert g.machine.executor.kind == "lookahead"
    assert g.machine.executor.set_speed_listener(lambda t, v, mv: seen.append((t, v, mv)))
    g.send(b"G1 X20 Y10 F3000\nG1 X40 Y10\n")
    assert g.settle()
    assert seen and seen[-1][1] == 0.0
    ticks = [t for t, _, _ in seen]
    assert ticks == sorted(ticks)
    cruise = [v for _, v, mv in seen if mv is not None and v > 0]
    assert max(cruise) == pytest.approx(3000, rel=1e-6)
    lines = {mv.line for _, _, mv in seen if mv is not None}
    assert lines == {"G1X20Y10F3000", "G1X40Y10"}


def cam_on_the_python_device(extra_setup: list[str] | None = None):
    """rigs.gcode's CAM program through ``--port``'s path on the Python device (the
    loopback's virtual clock, 115200 baud), the setup lines plus ``extra_setup``: the
    machine, the program's vertices, the instants from the device's pins and the corner
    blends made (empty with Grbl's junctions).  Asserts what every such run must: no
    error, one look-ahead motion, no underrun, late start or rejected command."""
    from fas.device.loopback import Loopback
    from rigs.gcode import SETUP, cam_program
    from rigs.path import instants
    from rigs.pins import steps_by_pins
    from stepperdemo.program import make_program

    text, verts = cam_program()
    with Loopback(device="python", record=True) as lb:
        app = make_program("gcode", lb.backend, scripted=True, axes=2,
                           setup_lines=list(SETUP) + list(extra_setup or []))
        app.run_script("G21\n", max_ticks=TPS)  # the machine is made: record its blends
        app.machine.executor.group.blend_log = blends = []
        app.run_script(text, max_ticks=120 * TPS)
        assert lb.backend.settle()
        m = app.machine
        counters = lb.backend.device_counters()
        edges = lb.device.recorder.pin_edges
        ups = [s.direction_pin_high_counts_up() for s in m.steppers]
        steps = [steps_by_pins(edges, 9, 5, ups[0]), steps_by_pins(edges, 10, 7, ups[1])]
    assert "error" not in app.transcript.decode()
    assert m.executor.kind == "lookahead" and len(m.motion_log) == 1
    assert counters["underruns"] == counters["late_starts"] == counters["rejected"] == 0
    return m, verts, instants(steps, (0, 0)), blends


def test_the_same_program_through_port_on_the_python_device():
    """Item 5 on the Python device (the loopback's virtual clock, 115200 baud): one run,
    no underrun on the device, every axis within one step of the path, the position
    where the program ends (the firmware in simavr: tests/firmware/)."""
    from rigs.path import tracked_deviation

    m, verts, points, _blends = cam_on_the_python_device()
    assert points[-1][1] == verts[-1] == tuple(m.positions())
    assert tracked_deviation(points, verts) <= 1.0


@pytest.mark.parametrize("after", [b"\x18", b"~"])
def test_a_door_during_a_jog_rests_in_door_until_input(after: bytes) -> None:
    """A safety door (0x84) during a jog cancels it; once the axes stand the machine
    sleeps in Door:0 until the host sends something (no wake-up at every tick: a run
    that never ended on virtual time, and a Ctrl-X that found no banner on the pty),
    then a reset answers with the banner / a resume goes back to Idle and a new jog runs."""
    g = grbl()
    g.send(b"$J=G91 X50 F3000\n")
    g.advance(0.1)
    assert g.machine.state_name() == "Jog"
    g.send(b"\x84")
    assert g.settle(1.0)
    assert g.machine.state_name() == "Door:0"
    # at rest: nothing due now (the drivers' idle delay, $1, is the one wake-up left)
    wake = g.program.next_wake_tick()
    assert wake is None or wake > g.backend.now()
    passes = 0
    loop_pass = g.program.loop_pass

    def counted() -> None:
        nonlocal passes
        passes += 1
        loop_pass()

    g.program.loop_pass = counted  # type: ignore[method-assign]
    g.advance(0.5)
    assert passes <= 3
    assert g.program.next_wake_tick() is None  # only input wakes it now
    stopped = g.machine.positions()
    assert g.machine.state_name() == "Door:0"
    assert b"[MSG:Check Door]" in g.take()
    g.send(after)
    assert g.settle(1.0)
    out = g.take()
    if after == b"\x18":
        assert b"Grbl 1.1h ['$' for help]" in out
        assert b"ALARM" not in out  # nothing was moving
    else:
        assert out == b""
    assert g.machine.state_name() == "Idle"
    assert not g.machine.executor.group.attached
    g.send(b"$J=G91 X-10 F3000\n")
    assert g.settle(2.0)
    assert g.take() == b"ok\r\n"
    assert g.machine.positions()[0] == stopped[0] - 10 * SPU  # steps


# ------------------------------------------------- $172: corner blends (opt-in)
def test_172_switches_corner_blends_lists_persists_and_refuses_bad_values():
    """``$172``: 0 Grbl's junctions (the default), 1 corner blends; ``$$`` lists it,
    it is kept over a reset as the other settings, ``$RST=$`` restores 0, a value
    other than 0 or 1 is Grbl's error:3 (a negative one error:4) and changes
    nothing."""
    g = grbl()
    g.send(b"$$\n")
    assert "$172=0" in g.take().decode().split("\r\n")
    assert g.machine.settings.corner_blends is False
    for bad, answer in ((b"2", "0 or 1]"), (b"0.5", "0 or 1]"), (b"-1", ">= 0]")):
        g.send(b"$172=" + bad + b"\n")
        assert g.settle()
        err = "error:4" if bad == b"-1" else "error:3"  # Grbl's negative value: 4
        assert g.take().decode().split("\r\n")[-3:] == [
            "[MSG:$172 must be " + answer, err, ""]
    g.send(b"$172=1\n")
    assert g.settle()
    assert g.take().decode().split("\r\n")[-2:] == ["ok", ""]
    g.send(b"\x18")  # a reset keeps the settings
    assert g.settle()
    g.take()
    g.send(b"$$\n")
    assert "$172=1" in g.take().decode().split("\r\n")
    g.send(b"G1 X20 F6000\nG1 Y20\n")
    assert g.settle()
    group = g.machine.executor.group
    assert group.settings.corner_blends and group.lookahead.blend_share > 0.0
    g.send(b"$RST=$\n")
    assert g.settle()
    g.take()
    assert g.machine.settings.corner_blends is False


def test_a_right_angle_corner_blended_with_172():
    """``$172=1``: X 20 mm then Y 20 mm at F6000, $11=0.05, the corner's speed by
    Grbl's formula, the acceleration along the bisector 500 / cos 45 deg:
    v^2 = a_j d sin(45) / (1 - sin(45)).  The corner is a blend (docs/path-planner.md):
    the velocity turns from v X to v Y at a_j along the bisector in T = v sqrt(2) / a_j,
    each axis at 500 mm/s^2 in it.  Measured from the pins: X comes to rest at the
    blend's end on its last step; Y leaves rest at the blend's start, its first step
    (a command's first: exact) sqrt(2 / (500 * 80)) s later; so T and v = 500 T."""
    g = run("G1 X20 F6000\nG1 Y20\n", setup="$11=0.05\n$172=1\n")
    a_j, v = right_angle_corner(0.05)  # v 9.24 mm/s
    xs, ys = g.backend.recorder.rising(X_STEP), g.backend.recorder.rising(Y_STEP)
    assert len(g.machine.motion_log) == 1
    t_end = xs[-1] / TPS
    t_start = ys[0] / TPS - math.sqrt(2 / (ACCEL * SPU))
    assert t_start < t_end  # Y leaves before X stands: the corner is blended
    measured = ACCEL * (t_end - t_start)
    assert abs(measured / v - 1) < 0.01, (measured, v)


def test_the_same_program_through_port_on_the_python_device_with_blends():
    """As above with ``$172=1``: one run, no underrun, every axis within one step of
    the path as run (the commanded path, its corners blended) and within $11 + 1 step
    of the commanded path (tests/fas/path/test_path_blends.py says why) - at this $11
    (0.01 mm, 0.8 step) within 1 step of it, the issue's line (the blends' steps led
    towards the commanded corner, fas.path.blend.lead_to_polyline; 1.029 without)."""
    from rigs.path import commanded_deviation, path_as_run, timed_deviation

    m, verts, points, blends = cam_on_the_python_device(["$172=1"])
    assert blends  # the corners were blended
    assert points[-1][1] == verts[-1] == tuple(m.positions())
    path = path_as_run(verts, blends, points, (SPU, SPU))
    assert timed_deviation(points, path, int(0.02 * TPS)) <= 1.0
    jd = m.settings.junction_deviation
    dev = commanded_deviation(points, verts, blends, int(0.02 * TPS))
    assert dev <= jd * SPU + 1.0
    assert jd * SPU < 1.0 and dev <= 1.0, dev


def test_a_feed_hold_with_172_stops_where_the_deceleration_takes_it_through_a_corner():
    """``$172=1`` and ``!`` on a zigzag of 12.5 x 3.125 mm legs (turns of 28 degrees)
    at F3000, sent where the deceleration cannot stop before the corner: the hold
    takes the corner as a blend that slows down (fas.path.blend.hold_blend), here at
    the block's acceleration along the polyline (X keeps its share of it through the
    corner), so the axes stop ``v^2 / (2 a)`` along the polyline from where the
    deceleration began (``a`` 500 mm/s^2 of X along the leg) - within a step per axis;
    ``~`` runs the rest to the end."""
    legs = [(12.5 * j, 3.125 if j % 2 else 0.0) for j in range(1, 9)]
    g = grbl("$172=1\n")
    program = "G1 F3000\n" + "".join(f"X{x:g} Y{y:g}\n" for x, y in legs)
    assert len(program) <= 128  # (Grbl's receive buffer: sent at once)
    g.send(program.encode())
    group = g.machine.executor.group
    for _ in range(4000):  # until a stop from here would pass the next corner
        g.advance_ticks(TPS // 1000)
        ex = group.executor  # (made when the group attaches)
        seg = ex.cur
        if (seg is not None and not seg.blend and len(group.lookahead.blocks) > 1
                and (ex.v * TPS) ** 2 / (2 * seg.block.acceleration)
                > seg.length - seg.s_done):
            break
    g.send(b"!")
    g.advance(1.0)
    assert status(g).startswith("<Hold:0|")
    hs = group.hold_start
    assert hs is not None and hs.block is not None
    # the point v^2 / (2 a) along the polyline from the hold's start
    verts = [(0.0, 0.0)] + legs
    i0 = i = [(round(x * SPU), round(y * SPU)) for x, y in verts].index(
        tuple(hs.block.start[:2]))
    left = hs.distance + hs.speed ** 2 / (2 * hs.block.acceleration)
    while True:
        (x0, y0), (x1, y1) = verts[i], verts[i + 1]
        n = math.hypot(x1 - x0, y1 - y0)
        if left <= n:
            exp = ((x0 + (x1 - x0) * left / n) * SPU, (y0 + (y1 - y0) * left / n) * SPU)
            break
        left -= n
        i += 1
    assert i > i0  # past a corner
    stop = g.machine.positions()[:2]
    assert all(abs(s - e) <= 1.0 for s, e in zip(stop, exp, strict=True)), (stop, exp)
    g.send(b"~")
    assert g.settle()
    assert g.machine.positions()[:2] == [round(100 * SPU), 0]


def status(g: RawGrbl) -> str:
    g.send(b"?")
    return g.take().decode().split("\r\n")[-2]


# ------------------------------------------- $173: plain corners with blends (opt-in)
def test_173_sets_plain_corners_lists_and_refuses_bad_values():
    """``$173``: with ``$172=1``, corners whose blend no step tells from Grbl's corner
    by more than this many steps are taken as Grbl's corner (0, the default: none);
    ``$$`` lists it, 0 .. 0.125 (the grouping's tolerance) or Grbl's error:3 (a
    negative value error:4), nothing changed; the group gets it."""
    g = grbl()
    g.send(b"$$\n")
    assert "$173=0" in g.take().decode().split("\r\n")
    for bad, answer in ((b"0.2", "0 .. 0.125]"), (b"1", "0 .. 0.125]"), (b"-1", ">= 0]")):
        g.send(b"$173=" + bad + b"\n")
        assert g.settle()
        err = "error:4" if bad == b"-1" else "error:3"
        assert g.take().decode().split("\r\n")[-3:] == [
            "[MSG:$173 must be " + answer, err, ""]
    assert g.machine.settings.plain_corner_steps == 0.0
    g.send(b"$172=1\n$173=0.125\n")
    assert g.settle()
    assert g.take().decode().split("\r\n")[-3:] == ["ok", "ok", ""]
    g.send(b"$$\n")
    assert "$173=0.125" in g.take().decode().split("\r\n")
    g.send(b"G1 X20 F6000\nG1 Y20\n")
    assert g.settle()
    assert g.machine.executor.group.settings.plain_corner_steps == 0.125


def test_the_same_program_through_port_with_blends_and_plain_corners():
    """The CAM program on the Python device with ``$172=1 $173=0.125``: one run, no
    underrun, fewer blends than with blends alone, within one step of the commanded
    path (docs/path-planner.md, "Corners no step can tell apart")."""
    from rigs.path import commanded_deviation

    m, verts, points, blends = cam_on_the_python_device(["$172=1"])
    m2, verts2, points2, blends2 = cam_on_the_python_device(["$172=1", "$173=0.125"])
    assert 0 < len(blends2) < len(blends)
    assert points2[-1][1] == verts2[-1] == tuple(m2.positions())
    # (the plain corners are not logged here: a vertex is matched at its visit)
    assert commanded_deviation(points2, verts2, blends2, int(0.02 * TPS)) <= 1.0
