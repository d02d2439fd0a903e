"""Issue 25's G-code words on the Grbl controller, on virtual time: arcs measured from the
step and direction pins, units, coordinate systems, G28/G30, G53, tool length offset,
spindle and coolant outputs, laser mode's power against the speed, bad programs."""

import bisect
import math
import random

import pytest

from fas.path.arc import Plane, arc_center_from_radius, arc_points
from fas.path.settings import GROUP_TOLERANCE_STEPS
from fas.pwm import duty_count
from rigs.gcode import path_from_pins
from stepperdemo.gcode.interp import Interpreter, Move
from stepperdemo.gcode.parser import parse_line
from stepperdemo.gcode.program import RawGrbl
from stepperdemo.gcode.settings import GcodeSettings

SPU = 80  # steps per mm in these tests
MM = (f"$100={SPU}\n$101={SPU}\n$102={SPU}\n$110=12000\n$111=12000\n$112=12000\n"
      "$120=500\n$121=500\n$122=500\n")


def grbl(arch: str = "atmega2560", setup: str = MM) -> RawGrbl:
    g = RawGrbl(arch, record=True)
    g.send(setup.encode())
    g.settle()
    g.take()
    return g


def lines(data: bytes) -> list[str]:
    return data.decode().split("\r\n")[:-1]


def send(g: RawGrbl, text: str) -> list[str]:
    """Lines as a sender waiting for each answer streams them; what came back."""
    for line in text.splitlines(keepends=True):
        g.send(line.encode())
        assert g.settle()
    return lines(g.take())


def status(g: RawGrbl) -> str:
    g.send(b"?")
    return lines(g.take())[-1]


# --------------------------------------------------------------------------- arcs
ARCS = [
    # (program, centre in mm) - from X0 Y0
    ("G2 X20 Y0 I10 J0 F3000", (10.0, 0.0)),  # half circle, clockwise (over the top)
    ("G3 X10 Y10 I10 J0 F3000", (10.0, 0.0)),  # quarter, counter-clockwise (below)
    ("G2 X0 Y0 I10 J5 F3000", (10.0, 5.0)),  # full circle
    ("G3 X7.5 Y-2.5 R-5 F3000", None),  # the long arc of R5
]


@pytest.mark.parametrize("motion", [0, 1])  # $171: look-ahead, exact stop
@pytest.mark.parametrize("program, centre", ARCS)
def test_arc_ends_exactly_and_stays_within_the_tolerance_plus_a_step_on_the_pins(program,
                                                                                   centre,
                                                                                   motion):
    """Both executors: the exact stop (``$171=1``) runs each chord from rest to rest,
    the axes standing on the chord ends rounded to steps, but its path between them is
    the chord itself (``Move.exact``), each axis on the step nearest to it and its last
    step on the end where the chord ends on whole steps (as the look-ahead's)."""
    g = grbl(setup=MM + f"$171={motion}\n")
    out = send(g, program + "\n")
    assert out == ["ok"]
    tol = 0.002  # $12's default, mm
    it = Interpreter(3, g.machine.settings)
    segments = [a for a in it.interpret(parse_line(program)) if isinstance(a, Move)]
    target = segments[-1].target
    assert g.machine.positions() == list(target)  # end point exact
    if centre is None:  # R form: the centre Grbl finds (both ends 5 mm away, long way)
        _err, off = arc_center_from_radius((0.0, 0.0), (7.5, -2.5), -5.0, Plane.XY, False)
        centre = off
    r = math.dist((0.0, 0.0), centre)
    # every segment end lies on the circle to the rounding of whole steps (as Grbl's
    # planner rounds them), its chord within $12 of the circle
    for m in segments:
        assert abs(math.dist((m.target[0] / SPU, m.target[1] / SPU), centre) - r) <= (
            math.sqrt(0.5) / SPU + 1e-9)
    # ... and the path goes through the points themselves, not rounded (but the last)
    for m in segments[:-1]:
        assert m.exact is not None
        assert abs(math.dist((m.exact[0] / SPU, m.exact[1] / SPU), centre) - r) <= 1e-5
    assert segments[-1].exact is None
    path = path_from_pins(g)
    worst = max(abs(math.dist((x / SPU, y / SPU), centre) - r) for _t, (x, y) in path)
    # the bound: $12 (the chords) + one step (every axis within a step of the
    # path; half a step inside the arc), at every step of either axis
    assert worst <= tol + 1 / SPU, worst
    assert len(path) > 100


def test_arc_radius_error_within_the_tolerance_plus_one_step():
    """Measured at every step of either axis: 0.0125 mm = $12 + 0.84 steps, in the last
    chord, where each axis makes its last step on the end tick (X, near (20, 0), up to
    a step behind over its last half step); elsewhere the axes stand on the step
    nearest to the path (before the chord ends went unrounded into the path: 0.0188 mm
    = $12 + 1.34 steps)."""
    g = grbl()
    send(g, "G2 X20 Y0 I10 J0 F3000\n")
    path = path_from_pins(g)
    worst = max(abs(math.dist((x / SPU, y / SPU), (10.0, 0.0)) - 10.0) for _t, (x, y) in path)
    assert worst <= 0.002 + 1 / SPU, worst * SPU
    # inside the arc (before the last chord, a step's angle before it): each axis within
    # half a step of the path, or up to GROUP_TOLERANCE_STEPS more where steps grouped
    # while the path speeds up come early - on the radius at most sqrt 2 times that
    it = Interpreter(3, g.machine.settings)
    moves = [a for a in it.interpret(parse_line("G2 X20 Y0 I10 J0 F3000")) if isinstance(a, Move)]
    last = moves[-2].exact
    assert last is not None
    turned = lambda x, y: math.atan2(y, x - 10.0 * SPU)  # noqa: E731 - from +pi down to 0
    inside = [(x, y) for _t, (x, y) in path
              if turned(x, y) > turned(last[0], last[1]) + 1 / (10.0 * SPU)]
    assert len(inside) > 0.9 * len(path)
    bound = 0.002 + (0.5 + GROUP_TOLERANCE_STEPS) * math.sqrt(2) / SPU
    inner = max(abs(math.dist((x / SPU, y / SPU), (10.0, 0.0)) - 10.0) for x, y in inside)
    assert inner <= bound, inner * SPU


@pytest.mark.parametrize("motion", [0, 1])  # $171: look-ahead, exact stop
def test_a_feed_hold_inside_an_arc_resumes_it_on_the_same_circle(motion):
    """The hold stops between chord ends; the blocks go back into the queue from where
    the axes stand, through the same points (``through``) - still within `$12` + one
    step, the end exact."""
    g = grbl(setup=MM + f"$171={motion}\n")
    g.send(b"G2 X20 Y0 I10 J0 F3000\n")
    g.advance(0.3)
    g.send(b"!")
    g.advance(1.0)
    assert status(g).startswith("<Hold:0")
    held = g.machine.positions()
    assert 0 < held[0] < 1600 and held[1] > 0  # on the way, above the centre
    g.send(b"~")
    assert g.settle()
    assert g.machine.positions() == [1600, 0, 0]
    worst = max(abs(math.dist((x / SPU, y / SPU), (10.0, 0.0)) - 10.0)
                for _t, (x, y) in path_from_pins(g))
    assert worst <= 0.002 + 1 / SPU, worst * SPU


def end_rule_point(events, last_move):
    """Where the axes stand just before the arc's end tick, checking the end rule: the end
    exact, and every axis that moves in the last chord makes its last step on that tick
    (an axis that does not - at its turning point there - made its last step in an
    earlier chord).  That point is the target less the last step of each axis stepping
    on the end tick: set by the target (in whole steps) and the directions the arc ends
    in, whatever the placement of the steps before it."""
    target = last_move.target[:2]
    end = events[-1][0]
    last = {}  # axis: (tick, direction) of its last step
    prev = (0,) * len(target)
    for t, p in events:
        for i, (a, b) in enumerate(zip(prev, p, strict=True)):
            if a != b:
                last[i] = (t, b - a)
        prev = p
    assert events[-1][1] == tuple(target)  # the end exact
    for i, x in enumerate(target):
        if x != last_move.start[i]:
            assert last[i][0] == end, i  # its last step on the end tick
    before = [p for t, p in events if t < end]
    forced = tuple(x - last[i][1] if i in last and last[i][0] == end else x
                   for i, x in enumerate(target))
    assert before[-1] == forced
    return forced


@pytest.mark.parametrize(("seed", "motion"), [(1, 0), (2, 0), (16, 0), (39, 0), (1, 1),
                                             (16, 1)])
def test_random_arcs_stay_within_the_tolerance_plus_a_step_and_end_exactly(seed, motion):
    """Arcs of random centre, sweep, direction, feed and `$12`, their targets in mm
    (whole micrometres, so not on whole steps nor quite on the circle): up to the last
    chord each axis within half a step of the path (+ GROUP_TOLERANCE_STEPS where
    grouped steps come early); the last block ends on the target rounded to steps,
    every axis moving in it making its last step on the end tick
    (:func:`end_rule_point`) - where that would force a point beyond `$12` + 1 step,
    the slower axis ends before it (:func:`fas.path.arc.arc_end_cut`).  ``motion`` 1:
    the exact stop (``$171=1``), each chord from rest to rest along the chord itself.
    The whole path
    within `$12` + 1 step, nothing added for the target's own distance from the circle
    (the last chord heads to it; where its steps would leave the band the last chord
    begins later on the circle: fas.path.arc.arc_end_approach - the arcs of
    test_where_the_last_chords_steps_would_leave_the_band_it_begins_later_on_the_circle)."""
    rnd = random.Random(seed)
    for _ in range(4):
        r = rnd.choice([1.0, 3.0, 10.0])
        a0 = rnd.uniform(0, 2 * math.pi)
        a1 = a0 + rnd.uniform(-2 * math.pi, 2 * math.pi)
        c = (-r * math.cos(a0), -r * math.sin(a0))  # from X0 Y0
        tx, ty = round(c[0] + r * math.cos(a1), 3), round(c[1] + r * math.sin(a1), 3)
        tol = rnd.choice([0.002, 0.01])
        line = (f"G{2 if a1 < a0 else 3} X{tx} Y{ty} I{c[0]:.4f} J{c[1]:.4f} "
                f"F{rnd.choice([600, 3000, 6000])}")
        g = grbl(setup=MM + f"$171={motion}\n")
        assert send(g, f"$12={tol}\n{line}\n") == ["ok", "ok"], line
        it = Interpreter(3, g.machine.settings)
        moves = [a for a in it.interpret(parse_line(line)) if isinstance(a, Move)]
        assert g.machine.positions() == list(moves[-1].target)  # end point exact
        centre = (round(c[0], 4) * SPU, round(c[1], 4) * SPU)
        radius = math.hypot(*centre)
        def off(p, centre=centre, radius=radius):  # steps off the circle
            return abs(math.dist(p, centre) - radius)

        events = path_from_pins(g)
        path = [p for _t, p in events]
        last = moves[-2].exact if len(moves) > 1 else None
        assert last is not None
        # the steps before the pins come within a step of the last chord's start
        k = next(i for i, p in enumerate(path) if math.dist(p, last[:2]) <= 1.5)
        inside = max(map(off, path[:k]), default=0.0)
        assert inside <= tol * SPU + (0.5 + GROUP_TOLERANCE_STEPS) * math.sqrt(2), line
        end_rule_point(events, moves[-1])
        assert max(map(off, path)) <= tol * SPU + 1, line


#: two of bench/bench_arcs.py's random arcs (seed 8), ($12, centre in mm): before
#: arc_end_approach their last chord's steps came $12 + 1.0014 and + 1.0022 steps off
#: the circle, in its middle (the chord from the circle to a target rounded 0.57 and
#: 0.66 step inside it)
LATE_ARCS = [("G3 X-16.03 Y-4.493 I-9.5106 J3.0902 F6000", 0.002, (-9.5106, 3.0902)),
             ("G3 X3.281 Y0.043 I1.6738 J-2.4897 F3000", 0.01, (1.6738, -2.4897))]


@pytest.mark.parametrize("line, tol, centre", LATE_ARCS)
def test_where_the_last_chords_steps_would_leave_the_band_it_begins_later_on_the_circle(
        line, tol, centre):
    """The last chord from the circle to the target rounded inside it comes up to
    ``s + |delta| / 2`` inside (``s`` its sagitta, ``delta`` the target's offset), and
    its steps, on the steps nearest to the path, up to 0.71 step further: so the
    interpreter begins the last chord later on the circle
    (:func:`fas.path.arc.arc_end_approach`) - a point on the circle between the arc's
    last two chord ends - and the whole path keeps `$12` + 1 step, the end exact.  (The
    first arc's end rule then cuts the new last chord too: fas.path.arc.arc_end_cut.)"""
    g = grbl()
    assert send(g, f"$12={tol}\n{line}\n") == ["ok", "ok"]
    c = (centre[0] * SPU, centre[1] * SPU)
    radius = math.hypot(*c)
    it = Interpreter(3, g.machine.settings)
    moves = [a for a in it.interpret(parse_line(line)) if isinstance(a, Move)]
    assert g.machine.positions() == list(moves[-1].target)
    start = (0.0, 0.0, 0.0)
    target = tuple(float(v) for v in parse_values(line))
    chords = arc_points(start, target, centre, Plane.XY, False, tol)
    ends = [tuple(round(v * SPU * 1024) / 1024 for v in p) for p in chords[:-1]]
    extra = [m.exact for m in moves[:-1] if m.exact not in ends]
    # a chord end added on the circle in the last chord (and where the end rule asks,
    # arc_end_cut's on the new last chord)
    assert 1 <= len(extra) <= 2 and moves[-1 - len(extra)].exact == extra[0]
    assert abs(math.dist(extra[0][:2], c) - radius) < 1e-2
    assert moves[-2 - len(extra)].exact == ends[-1]
    if len(extra) == 2:
        p, q, t = extra[0][:2], extra[1][:2], moves[-1].target[:2]
        cross = (q[0] - p[0]) * (t[1] - p[1]) - (q[1] - p[1]) * (t[0] - p[0])
        assert abs(cross) / math.dist(p, t) < 1e-2
    worst = max(abs(math.dist(p, c) - radius) for _t, p in path_from_pins(g))
    assert worst <= tol * SPU + 1, worst - tol * SPU


def parse_values(line: str) -> tuple[float, float, float]:
    words = dict((w[0], float(w[1:])) for w in line.split()[1:])
    return (words["X"], words["Y"], 0.0)


OFF_CIRCLE = "G3 X-10.281 Y11.213 I-0.3557 J9.9937 F6000"  # target 0.49 step inside


def test_where_the_end_rule_would_force_a_point_off_the_band_the_slower_axis_ends_first():
    """The arc ends going -X and -Y on (-822, 897), 0.49 step inside the circle.  With
    both axes' last steps on the end tick the axes would stand on (-821, 898) just
    before it, 1.36 steps inside = `$12` + 1.20 (measured so before), whatever the
    placement of the steps before.  So the last chord is cut where X, the slower axis,
    has passed its last half step and Y has not (:func:`fas.path.arc.arc_end_cut`): X
    makes its last step there, as inside the arc, and the last block moves Y alone,
    its last step on the end tick - the axes stand on (-822, 898) before it."""
    g = grbl()
    assert send(g, OFF_CIRCLE + "\n") == ["ok"]
    centre = (-0.3557 * SPU, 9.9937 * SPU)
    radius = math.hypot(*centre)
    kept = (-821, 898)  # what keeping both last steps on the end tick would force
    assert radius - math.dist(kept, centre) == pytest.approx(0.002 * SPU + 1.20, abs=0.005)
    it = Interpreter(3, g.machine.settings)
    moves = [a for a in it.interpret(parse_line(OFF_CIRCLE)) if isinstance(a, Move)]
    before, cut, last = moves[-3], moves[-2], moves[-1]
    assert last.target[:2] == (-822, 897) and last.start == cut.target
    assert cut.target[0] == -822 and cut.target[1] > 897  # X there already, Y not
    # the cut lies on the chord from the last chord end on the circle to the target
    p, q = before.exact[:2], cut.exact[:2]
    cross = (q[0] - p[0]) * (897 - p[1]) - (q[1] - p[1]) * (-822 - p[0])
    assert abs(cross) / math.dist(p, (-822, 897)) < 1e-2
    assert abs(math.dist(p, centre) - radius) < 1e-2
    events = path_from_pins(g)
    assert end_rule_point(events, last) == (-822, 898)
    end = events[-1][0]
    assert [p for t, p in events if t == end] == [(-822, 897)]  # Y alone on the end tick
    x_last = max(t for (t, p), (_t0, p0) in zip(events[1:], events, strict=False)
                 if p[0] != p0[0])
    assert x_last < end


def test_an_arc_whose_target_is_off_the_circle_in_whole_steps_within_the_tolerance_plus_one_step():
    """Measured: `$12` + 0.82 steps (+ 1.20 with both last steps on the end tick)."""
    g = grbl()
    assert send(g, OFF_CIRCLE + "\n") == ["ok"]
    centre = (-0.3557 * SPU, 9.9937 * SPU)
    radius = math.hypot(*centre)
    worst = max(abs(math.dist(p, centre) - radius) for _t, p in path_from_pins(g))
    assert worst <= 0.002 * SPU + 1, worst - 0.002 * SPU


def test_the_long_r_arc_goes_the_long_way():
    it = Interpreter(3, GcodeSettings(steps_per_unit=[SPU] * 6))
    short = [a for a in it.interpret(parse_line("G3 X7.5 Y-2.5 R5 F3000"))]
    it.sync_position([0, 0, 0])
    long = [a for a in it.interpret(parse_line("G3 X7.5 Y-2.5 R-5 F3000"))]
    assert short[-1].target == long[-1].target == (600, -200, 0)
    length = lambda ms: sum(math.dist(m.start, m.target) for m in ms)  # noqa: E731
    circle = 2 * math.pi * 5 * SPU  # the long arc is the circle minus the short one
    assert length(long) + length(short) == pytest.approx(circle, rel=0.01)
    assert length(long) > 2 * length(short)


def test_r_and_ijk_forms_of_one_arc_make_the_same_segments_and_the_same_pins():
    a, b = grbl(), grbl()
    send(a, "G17 G2 X20 Y0 R10 F3000\nG3 X30 Y10 R10\n")
    send(b, "G17 G2 X20 Y0 I10 J0 F3000\nG3 X30 Y10 I0 J10\n")
    assert path_from_pins(a) == path_from_pins(b)
    assert a.machine.positions() == b.machine.positions() == [2400, 800, 0]


@pytest.mark.parametrize("plane, program, moving", [
    ("G18", "G2 X20 Z0 I10 K0 F3000", (0, 2)),  # ZX: Y is the helical axis
    ("G19", "G3 Y20 Z0 J10 K0 F3000", (1, 2)),
])
def test_arcs_in_the_other_planes_move_their_axes(plane, program, moving):
    g = grbl()
    assert send(g, plane + "\n" + program + "\n") == ["ok", "ok"]
    pos = g.machine.positions()
    assert pos[moving[0]] == 1600 and pos[moving[1]] == 0
    rec = g.backend.recorder
    z_steps = len(rec.rising(g.machine.steppers[2].get_step_pin()))
    assert z_steps >= 2 * 800 - 2  # Z went out 10 mm and back
    assert f"[GC:G{int(program[1])} G54 {plane} " in send(g, "$G\n")[0]


def test_a_helix_moves_the_linear_axis_in_proportion():
    g = grbl()
    send(g, "G2 X0 Y0 Z4 I5 J0 F3000\n")  # a full turn, 4 mm down the Z axis
    assert g.machine.positions() == [0, 0, 320]
    path = path_from_pins(g, axes=3)
    # Z advances with the angle, at every step: within its own step of the path, and
    # the angle read from X and Y (each within a step of the path, 400 steps from the
    # centre) is off by at most 1/400 rad = 0.13 step of Z (320 / 2 pi per rad)
    worst = 0.0
    for _t, (x, y, z) in path:
        turned = (math.pi - math.atan2(y, x - 400)) % (2 * math.pi)  # clockwise
        if y == 0 and x < 400 and z > 160:
            turned = 2 * math.pi  # back at the start: the full turn
        worst = max(worst, abs(z - 320 * turned / (2 * math.pi)))
    assert worst <= 1 + 320 / (2 * math.pi) / 400, worst


def test_the_arc_tolerance_sets_the_segment_count_as_grbl():
    for tol in (0.002, 0.1):
        it = Interpreter(3, GcodeSettings(steps_per_unit=[SPU] * 6))
        it.settings.kept[12] = tol
        segs = [a for a in it.interpret(parse_line("G2 X0 Y0 I10 F100")) if isinstance(a, Move)]
        r = 10.0
        grbl_count = math.floor(abs(math.pi * r) / math.sqrt(tol * (2 * r - tol)))
        assert grbl_count <= len(segs) <= grbl_count + 1  # ours: the same or one more


BAD_ARCS = [
    ("G2 X10 F100", 35, "needs I or J"),
    ("G2 I5 F100", 26, "an arc needs axis words"),
    ("G2 Z5 I5 F100", 32, "an arc in G17 needs X or Y"),
    ("G2 X10 Y0 R2 F100", 34, "arc radius R2 is less than half the distance"),
    ("G2 X0 Y0 R5 F100", 33, "target other than the start"),
    ("G2 X10 Y0 I4 F100", 33, "arc radius to the start 4.0000 and to the target 6.0000"),
    ("G2 X10 R5 I5 F100", 36, "unused word(s): I"),
    ("G2 X10 I5", 22, "undefined feed rate: G2 needs F"),
    ("G18 G2 X10 J5 F100", 35, "needs K or I"),
    ("G53 G2 X10 I5 F100", 30, "G53 needs G0 or G1"),
]


def test_bad_arcs_answer_grbls_error_nothing_moves_and_the_program_goes_on():
    g = grbl()
    program = "".join(line + "\n" + "G0 X1 Y1\nG0 X0 Y0\n" for line, _c, _r in BAD_ARCS)
    out = send(g, program)
    errors = [ln for ln in out if ln.startswith("error:")]
    msgs = [ln for ln in out if ln.startswith("[MSG:")]
    assert errors == [f"error:{c}" for _l, c, _r in BAD_ARCS]
    for m, (_l, _c, reason) in zip(msgs, BAD_ARCS, strict=True):
        assert reason in m, m
    assert out.count("ok") == 2 * len(BAD_ARCS)
    rec = g.backend.recorder
    x_steps = len(rec.rising(g.machine.steppers[0].get_step_pin()))
    assert x_steps == 2 * SPU * len(BAD_ARCS)  # only the G0 moves moved
    assert g.machine.interp.plane == 17 and g.machine.interp.motion == 0


def test_arcs_that_no_plane_of_the_machine_holds_are_refused():
    g = RawGrbl("atmega2560", axes=2)
    g.take()
    assert send(g, "G18 G2 X2 I1 F100\n")[-1] == "error:20"


# ------------------------------------------------------- units and coordinates
def test_g20_takes_inches_for_words_and_feed_and_g21_goes_back():
    g = grbl()
    assert send(g, "G20 G0 X1 Y0.5\nG1 X2 F10\n") == ["ok", "ok"]
    assert g.machine.positions()[:2] == [round(2 * 25.4 * SPU), round(0.5 * 25.4 * SPU)]
    assert send(g, "$G\n")[0] == "[GC:G1 G54 G17 G20 G90 G94 M5 M9 T0 F10 S0]"
    assert g.machine.interp.feed == pytest.approx(254.0)
    send(g, "G21 G0 X0 Y0\n")
    assert g.machine.positions()[:2] == [0, 0]


def test_g93_inverse_time_finishes_each_move_in_1_over_f_minutes():
    g = grbl()
    assert send(g, "G93 G1 X40 F60\n$G\nX0\nG94 X10\n") == [
        "ok", "[GC:G1 G54 G17 G21 G90 G93 M5 M9 T0 F60 S0]", "ok",
        "[MSG:undefined feed rate: G1 needs F]", "error:22",  # F is per block in G93
        "[MSG:undefined feed rate: G1 needs F]", "error:22"]  # ... and undefined after
    xs = g.backend.recorder.rising(g.machine.steppers[0].get_step_pin())
    gaps = [b - a for a, b in zip(xs, xs[1:], strict=False)]
    # 40 mm in 1/60 min: cruise at 2400 mm/min = 3200 steps/s, 5000 ticks a step
    assert min(gaps) == 5000 and gaps.count(5000) > 1000
    t0 = g.backend.now()
    assert send(g, "G93 G2 X40 Y0 I20 F30\n") == ["ok"]  # a full circle, 125.7 mm in 2 s
    assert g.machine.positions()[:2] == [3200, 0]
    # each of its segments at 125.7 mm * 30/min (not reached: they are short and stop)
    assert all(b.feed == pytest.approx(2 * math.pi * 20 * 30, rel=1e-4)
               for b in Interpreter(3, g.machine.settings).interpret(
                   parse_line("G93 G2 X0 Y0 I20 F30")) if isinstance(b, Move))
    assert g.backend.now() > t0


def test_g10_sets_work_coordinate_systems_that_g54_to_g59_select_and_dollar_hash_shows():
    g = grbl()
    send(g, "G10 L2 P2 X10 Y20\nG55\nG0 X0 Y0\n")
    assert g.machine.positions()[:2] == [800, 1600]
    assert "WCO:10.000,20.000,0.000" in status(g)
    send(g, "G0 X5\nG10 L20 P0 X0\n")  # the present position becomes X0 of G55
    assert send(g, "$#\n")[:2] == ["[G54:0.000,0.000,0.000]", "[G55:15.000,20.000,0.000]"]
    send(g, "G54 G0 X0 Y0\n")
    assert g.machine.positions()[:2] == [0, 0]
    out = send(g, "G10 L2 P7 X1\nG10 L3 P1 X1\nG10 L2 X1\nG10 L2 P1\nG10 L2 P1 R5 X1\n")
    assert [ln for ln in out if ln.startswith("error")] == [
        "error:29", "error:20", "error:28", "error:26", "error:20"]
    g.send(b"\x18")  # a reset keeps the systems (Grbl's EEPROM), $RST=# zeroes them
    g.settle()
    g.take()
    assert send(g, "$#\n")[1] == "[G55:15.000,20.000,0.000]"
    send(g, "$RST=#\n")
    assert send(g, "$#\n")[1] == "[G55:0.000,0.000,0.000]"


def test_g92_adds_to_the_coordinate_system_and_program_end_returns_to_g54():
    g = grbl()
    send(g, "G10 L2 P1 X2\nG0 X10\nG92 X0\n")  # work 0 = machine 12
    assert send(g, "$#\n")[6:9] == ["[G28:0.000,0.000,0.000]", "[G30:0.000,0.000,0.000]",
                                    "[G92:10.000,0.000,0.000]"]
    send(g, "G0 X1\n")
    assert g.machine.positions()[0] == 13 * SPU
    send(g, "G55\nM2\n")
    assert g.machine.interp.coord_select == 0


def test_g28_and_g30_return_to_stored_positions_through_the_given_point():
    g = grbl()
    send(g, "G0 X30 Y40\nG28.1\nG0 X5 Y6 Z7\nG30.1\nG0 X0 Y0 Z0\n")
    assert send(g, "$#\n")[6:8] == ["[G28:30.000,40.000,0.000]", "[G30:5.000,6.000,7.000]"]
    send(g, "G28\n")
    assert g.machine.positions() == [2400, 3200, 0]
    send(g, "G91 G30 Z1\n")  # up 1 mm first, then only Z to G30's Z
    assert g.machine.positions() == [2400, 3200, 560]
    z = path_from_pins(g, axes=3)
    assert max(p[2] for _t, p in z) == 560  # (the intermediate point Z1 is below it)
    send(g, "G90 G0 X0 Y0 Z0\nG28 X10\n")  # via X10, then X to 30; Y Z stay
    assert g.machine.positions() == [2400, 0, 0]


def test_g53_moves_in_machine_coordinates_for_one_block():
    g = grbl()
    send(g, "G10 L2 P1 X100\nG0 X0\n")
    assert g.machine.positions()[0] == 8000
    send(g, "G53 G0 X1\n")
    assert g.machine.positions()[0] == 80
    assert send(g, "G53 X3\n") == ["ok"] and g.machine.positions()[0] == 240  # G0 modal
    assert send(g, "G53\n")[-1] == "error:30"  # nothing to move


def test_tool_length_offset_moves_z_and_shows_in_wco_and_tlo():
    g = grbl()
    send(g, "G43.1 Z2\nG0 Z0\n")
    assert g.machine.positions()[2] == 160 and "WCO:0.000,0.000,2.000" in status(g)
    assert send(g, "$#\n")[9] == "[TLO:2.000]"
    assert send(g, "G43.1 X1\nG43.1 Z1 G0 X1\n")[1::2] == ["error:37", "error:24"]
    send(g, "G49\nG0 Z0\n")
    assert g.machine.positions()[2] == 0


def test_probing_without_a_probe_input_is_refused_after_grbls_checks():
    g = grbl("esp32")
    out = send(g, "G38.2 Z-10 F100\nG38.2 F100\nG38.3 Z0 F100\nG38.2 Z-1\n")
    assert out == ["[MSG:G38.2: esp32 has no probe input]", "error:20",
                   "[MSG:G38.2 needs axis words]", "error:26",
                   "[MSG:probe target is the present position]", "error:33",
                   "[MSG:undefined feed rate: G38.2 needs F]", "error:22"]
    assert g.machine.positions() == [0, 0, 0]


PROBE_PIN = 69  # atmega2560: Grbl's A15


def test_g38_2_stops_every_axis_at_the_contact_and_reports_the_position():
    g = grbl()
    g.send(b"G0 Z2\nG38.2 Z-10 X1 F120\n")  # (X too: both axes stop at the contact)
    while g.machine.positions()[2] > -80:  # Z passes -1 mm: the probe touches
        g.advance_ticks(1000)
    touched = g.backend.now()
    g.backend.drive_input(PROBE_PIN, 0)
    assert g.settle()
    out = lines(g.take())
    z = g.machine.positions()[2]
    assert -82 <= z <= -80 and out[-2:] == [f"[PRB:{g.machine.positions()[0] / SPU:.3f},"
                                            f"0.000,{z / SPU:.3f}:1]", "ok"]
    rec = g.backend.recorder
    for s in g.machine.steppers[::2]:  # X and Z: not one pulse after the contact
        assert all(t <= touched for t in rec.rising(s.get_step_pin()))
    assert g.machine.interp.position_steps == g.machine.positions()  # parser there
    assert send(g, "$#\n")[10] == out[-2]
    g.backend.drive_input(PROBE_PIN, 1)
    assert send(g, "G0 Z0\n") == ["ok"] and g.machine.positions()[2] == 0


def test_probe_failures_are_grbls_alarms_and_g38_3_reports_no_contact():
    g = grbl()
    out = send(g, "G38.3 Z-1 F600\n")  # no contact, no error: the end is the position
    assert out == ["[PRB:0.000,0.000,-1.000:0]", "ok"] and g.machine.alarm is None
    out = send(g, "G38.2 Z-2 F600\n")
    assert out[-2:] == ["ALARM:5", "ok"] and g.machine.positions()[2] == -160
    assert send(g, "G0 Z0\n")[-1] == "error:9"
    send(g, "$X\n")
    g.backend.drive_input(PROBE_PIN, 0)  # touching already
    out = send(g, "G38.2 Z-3 F600\n")
    assert out[-2:] == ["ALARM:4", "ok"] and g.machine.positions()[2] == -160
    send(g, "$X\n")
    out = send(g, "G38.4 Z0 F600\n")  # away from the contact: it never leaves it
    assert out[-2:] == ["ALARM:5", "ok"]


# ------------------------------------------------------------ spindle, coolant
def spindle_duty(g: RawGrbl) -> float:
    return g.machine.engine.outputs.analog_applied(1)[0]


def test_m3_sets_the_spindle_pwm_after_the_motion_before_it_and_m5_stops_it():
    g = grbl(setup=MM + "$30=24000\n$31=0\n")
    g.send(b"G0 X100\nM3 S12000\n")
    g.advance(0.05)
    assert spindle_duty(g) == 0.0  # waits for the motion before it (Grbl's spindle_sync)
    assert g.settle()
    assert spindle_duty(g) == 50.0
    g.send(b"\x9a")  # spindle override +10 %
    assert spindle_duty(g) == pytest.approx(55.0)
    g.send(b"\x99M4\n")
    g.settle()
    g.take()
    assert spindle_duty(g) == 50.0
    assert send(g, "$G\n")[0] == "[GC:G0 G54 G17 G21 G90 G94 M4 M9 T0 F0 S12000]"
    send(g, "S30000\n")
    assert spindle_duty(g) == 100.0  # at or above $30
    send(g, "M5\n")
    assert spindle_duty(g) == 0.0


def test_spindle_speed_to_duty_follows_grbls_min_max_rule():
    g = grbl(setup=MM + "$30=1000\n$31=200\n")
    send(g, "M3 S600\n")
    assert spindle_duty(g) == pytest.approx(50.0)
    send(g, "S100\n")  # below $31 but not 0: the least duty the timer makes
    setting = g.machine.engine.outputs.frequency_setting(1)
    assert spindle_duty(g) == pytest.approx(100.0 / setting.counts, rel=1e-3)
    send(g, "S0\n")
    assert spindle_duty(g) == 0.0


def test_coolant_outputs_program_end_and_the_toggles():
    g = grbl()
    outputs = g.machine.engine.outputs
    send(g, "M7\nM8\n")
    assert (outputs.digital_applied(2), outputs.digital_applied(3)) == (1, 1)
    assert send(g, "$G\n")[0] == "[GC:G0 G54 G17 G21 G90 G94 M5 M7 M8 T0 F0 S0]"
    send(g, "M9\n")
    assert (outputs.digital_applied(2), outputs.digital_applied(3)) == (0, 0)
    g.send(b"\xa0")  # flood toggle
    assert outputs.digital_applied(3) == 1 and g.machine.interp.flood
    send(g, "M3 S500 M7\nT3 M6\nG0 X10\nM30\n")
    assert (outputs.digital_applied(2), outputs.digital_applied(3)) == (0, 0)
    assert spindle_duty(g) == 0.0
    assert send(g, "$G\n")[0] == "[GC:G1 G54 G17 G21 G90 G94 M5 M9 T3 F0 S500]"


def test_profiles_without_spindle_outputs_keep_the_words_and_refuse_laser_mode():
    g = RawGrbl("rp2040")
    g.take()
    assert send(g, "M3 S100\nM8\n$G\n") == [
        "ok", "ok", "[GC:G0 G54 G17 G21 G90 G94 M3 M8 T0 F0 S100]", "ok"]
    out = send(g, "$32=1\n")
    assert out == ["[MSG:laser mode needs a spindle PWM output: rp2040 has none "
                   "(docs/gcode.md)]", "error:17"]


# -------------------------------------------------------------------- laser
def pwm_periods(g: RawGrbl, pin: int) -> list[tuple[int, int, int]]:
    """(start tick, period, high ticks) of every full period of a PWM pin."""
    ticks, levels = g.backend.recorder.pin_edges(pin)
    rises = [t for t, v in zip(ticks, levels, strict=True) if v]
    falls = [t for t, v in zip(ticks, levels, strict=True) if not v]
    out = []
    for a, b in zip(rises, rises[1:], strict=False):
        k = bisect.bisect_right(falls, a)
        fall = falls[k] if k < len(falls) else b
        out.append((a, b - a, min(fall, b) - a))
    return out


LOOKAHEAD_LATE = ("look-ahead executor: one change came 1.14 ms after its queue command "
                  "(measured, 1 kHz PWM, atmega2560): the simulated CPU is busy writing "
                  "the path's queue commands and the main loop gets back 1.1 ms late")


@pytest.mark.parametrize("executor", [
    "exact_stop", "lookahead"])
def test_laser_m4_duty_follows_the_speed_at_every_queue_command(executor):
    setup = MM + "$30=2000\n$32=1\n$141=1000\n"  # full speed: 50 %, 1 kHz PWM
    if not hasattr(GcodeSettings(), "motion"):  # ($171 selects the executor)
        if executor != "exact_stop":
            pytest.skip("only the exact-stop executor here")
    else:
        setup += f"$171={int(executor == 'exact_stop')}\n"
    g = grbl(setup=setup)
    g.machine.poll()
    told: list[tuple[int, float]] = []
    original = g.machine.tooling.on_speed

    def spy(tick, rate, block):
        if block.laser is not None and not block.rapid:
            told.append((tick, rate))
        original(tick, rate, block)

    assert g.machine.executor.set_speed_listener(spy)
    made: list[tuple[int, float]] = []  # (tick, duty) of every change of the output
    g.backend.output_listeners.append(lambda ch, t: made.append((t, ch.percent)))
    feed = 3000.0
    send(g, f"M4 S1000\nG1 X40 F{feed:g}\nG0 X0\n")
    assert len(told) > 30
    pin = g.machine.engine.outputs.analog_pin(1)
    periods = pwm_periods(g, pin)
    period = periods[0][1]
    xs = g.backend.recorder.rising(g.machine.steppers[0].get_step_pin())
    made_ticks = [t for t, _d in made]
    counts = g.machine.engine.outputs.frequency_setting(1).counts
    for tick, rate in told:
        # the speed told is the speed on the pins: X's step interval there
        k = bisect.bisect_left(xs, tick)
        if 0 < k < len(xs) - 1 and rate > 300:
            pin_rate = 2 * g.ticks_per_s / (xs[k + 1] - xs[k - 1]) / SPU * 60
            assert rate == pytest.approx(pin_rate, rel=0.05), (tick, rate, pin_rate)
        # within one PWM period of the command the output has S * v / F (proportional):
        # a change made then, or the duty it has already
        # (Grbl's rule: a speed above 0 makes at least the timer's smallest duty - the
        # look-ahead path's last step before a stop comes a rounded tick before the
        # path's exact end, at a speed of ~1e-10 units/min)
        want = 1000 * rate / feed / 2000 * 100
        if rate > 0:
            want = max(want, 100 / counts)
        lo, hi = bisect.bisect_left(made_ticks, tick), bisect.bisect_left(made_ticks,
                                                                           tick + period)
        held = made[max(0, lo - 1):hi] if lo and made[lo - 1][0] <= tick else made[lo:hi]
        assert any(d == pytest.approx(want) for _t, d in held), (tick, rate)
    # the pin: every PWM period shows the duty of the last change made before it began
    # (to the timer's count), so the power follows the speed one period behind at most
    for start, per, high in periods:
        j = bisect.bisect_right(made_ticks, start) - 1
        assert high * counts == per * duty_count(counts, made[j][1]), start
    assert len(periods) > 100
    # at rest and in the G0: off, no pulse after the path stopped
    assert told[-1][1] == 0.0 and spindle_duty(g) == 0.0
    assert not [p for p in periods if p[0] > told[-1][0] + period]


def test_laser_is_off_during_a_feed_hold_and_powered_again_when_the_move_goes_on():
    g = grbl(setup=MM + "$30=1000\n$32=1\n")
    g.send(b"G1 F3000 M3 S400\nG1 X40\n")
    g.advance(0.3)
    assert spindle_duty(g) == 40.0
    g.send(b"!")
    g.advance(0.5)
    assert g.machine.state_name() == "Hold:0" and spindle_duty(g) == 0.0
    g.send(b"~")
    g.advance(0.2)
    assert g.machine.state_name() == "Run" and spindle_duty(g) == 40.0
    assert g.settle() and g.machine.positions()[0] == 3200


def test_laser_m3_is_constant_in_g1_and_off_in_g0():
    g = grbl(setup=MM + "$30=1000\n$32=1\n")
    send(g, "G1 F3000\nM3 S250\n")
    assert spindle_duty(g) == 25.0  # M3 in a G1 mode: on, constant power (focusing)
    g.send(b"G0 X20\n")
    g.advance(0.1)
    assert spindle_duty(g) == 0.0  # G0: unpowered
    assert g.settle()
    g.send(b"G1 X40\n")
    g.advance(0.1)
    assert spindle_duty(g) == 25.0
    assert g.settle()
    send(g, "M5\n")
    assert spindle_duty(g) == 0.0


# ---------------------------------------------------------------- bad programs
@pytest.mark.parametrize("arch, seed", [("atmega2560", 25), ("esp32", 26), ("rp2040", 27),
                                        ("atmega328p", 28)])
def test_random_words_never_raise_and_every_line_is_answered(arch, seed):
    rng = random.Random(seed)
    g = grbl(arch)
    letters = "GMXYZIJKRSTFPLNQE"
    codes = ["G0", "G1", "G2", "G3", "G17", "G18", "G19", "G20", "G21", "G28", "G28.1",
             "G30", "G38.2", "G43.1", "G49", "G53", "G54", "G59", "G80", "G90", "G91",
             "G92", "G10", "M3", "M4", "M5", "M7", "M8", "M9", "M6", "M2", "G61", "G40",
             "G92.1", "G30.1", "G55", "M62", "M67", "G4", "G93"]
    sent = 0
    send(g, "$110=60000\n$111=60000\n$112=60000\n$120=20000\n$121=20000\n$122=20000\n")
    for _ in range(120):
        words = [rng.choice(codes) for _ in range(rng.randint(0, 2))]
        words += [f"{rng.choice(letters[2:])}{rng.uniform(-3, 3):.3f}"
                  for _ in range(rng.randint(0, 4))]
        words += [f"F{rng.choice((0, 6000, 30000))}"]
        g.send((" ".join(words) + "\n").encode())
        sent += 1
        assert g.settle(max_seconds=600)
        if g.machine.alarm is not None:  # a probe without contact: ALARM:5
            g.machine.unlock()
    out = lines(g.take())
    answers = [ln for ln in out if ln == "ok" or ln.startswith("error:")]
    assert len(answers) == sent
    assert answers.count("ok") >= sent // 10  # (not only refusals)
    assert not any("Traceback" in ln or ln in ("ALARM:1", "ALARM:2", "ALARM:3")
                   for ln in out)
