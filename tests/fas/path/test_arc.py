"""Arc geometry (fas.path.arc): segments within the arc tolerance, exact end points,
full circles, the planes, the R form and Grbl's error codes."""

from __future__ import annotations

import math

import pytest

from fas.path.arc import (
    ArcError,
    Plane,
    arc_center_from_radius,
    arc_end_approach,
    arc_end_cut,
    arc_points,
    arc_segments,
    arc_travel,
    check_arc_offsets,
    last_block_pins,
)


def chord_sagitta(center, radius, a, b) -> float:
    """How far the chord ab comes inside the circle at most (its midpoint)."""
    mid = ((a[0] + b[0]) / 2, (a[1] + b[1]) / 2)
    return radius - math.hypot(mid[0] - center[0], mid[1] - center[1])


@pytest.mark.parametrize("radius,tol", [(1.0, 0.002), (10.0, 0.002), (50.0, 0.01),
                                        (3.0, 0.1)])
@pytest.mark.parametrize("clockwise", [True, False])
def test_segments_stay_within_the_tolerance_and_end_exactly(radius, tol, clockwise):
    start = (0.0, 0.0, 0.0)
    target = (radius, radius, 0.0)  # a quarter (or three quarters) about (radius, 0)
    offset = (radius, 0.0)
    pts = arc_points(start, target, offset, Plane.XY, clockwise, tol)
    assert pts[-1] == target  # exactly
    center = (radius, 0.0)
    prev = start
    for p in pts:
        assert chord_sagitta(center, radius, prev, p) <= tol + 1e-12
        assert math.hypot(p[0] - center[0], p[1] - center[1]) == pytest.approx(radius)
        prev = p
    travel = arc_travel(start, target, offset, Plane.XY, clockwise)
    assert travel == pytest.approx(-math.pi / 2 if clockwise else 3 * math.pi / 2)
    assert len(pts) == max(1, arc_segments(radius, travel, tol))


@pytest.mark.parametrize("radius,travel,tol", [(10.0, math.pi, 0.002), (1.0, 0.3, 0.002),
                                               (50.0, 2 * math.pi, 0.01), (3.0, 1.5, 0.1)])
def test_segment_count_is_grbls_or_one_more(radius, travel, tol):
    grbl = math.floor(abs(0.5 * travel * radius) / math.sqrt(tol * (2 * radius - tol)))
    n = arc_segments(radius, travel, tol)
    assert n in (grbl, grbl + 1)
    phi = travel / n
    assert radius * (1 - math.cos(phi / 2)) <= tol + 1e-12  # n chords are within tol
    if n > 1:
        phi = travel / (n - 1)
        assert radius * (1 - math.cos(phi / 2)) > tol  # n - 1 would not be


def test_an_arc_within_the_tolerance_is_a_line():
    assert arc_segments(0.0005, math.pi, 0.002) == 0
    assert arc_points((0.0, 0.0), (0.001, 0.0), (0.0005, 0.0), Plane.XY, True,
                      0.002) == [(0.001, 0.0)]


def test_full_circle_when_the_target_is_the_start():
    pts = arc_points((5.0, 0.0), (5.0, 0.0), (-5.0, 0.0), Plane.XY, False, 0.01)
    assert pts[-1] == (5.0, 0.0)
    assert len(pts) > 10
    angles = [math.atan2(p[1], p[0]) for p in pts[:-1]]
    assert angles[0] > 0  # counter-clockwise from +X
    assert max(abs(a) for a in angles) > 3.0  # all the way round


def test_helix_moves_the_linear_axis_in_proportion():
    pts = arc_points((0.0, 0.0, 0.0), (0.0, 0.0, 3.0), (1.0, 0.0), Plane.XY, True, 0.001)
    zs = [p[2] for p in pts]
    assert zs == sorted(zs) and zs[-1] == 3.0
    n = len(pts)
    for k, z in enumerate(zs, start=1):
        assert z == pytest.approx(3.0 * k / n)


@pytest.mark.parametrize("plane,axes", [(Plane.XY, (0, 1, 2)), (Plane.ZX, (2, 0, 1)),
                                        (Plane.YZ, (1, 2, 0))])
def test_planes_turn_their_own_axes(plane, axes):
    a0, a1, lin = axes
    assert plane.axes == axes
    start = [0.0, 0.0, 0.0]
    target = [0.0, 0.0, 0.0]
    target[a0] = 2.0  # half a turn about (1, 0) in the plane
    offset = (1.0, 0.0)
    pts = arc_points(tuple(start), tuple(target), offset, plane, False, 0.001)
    assert pts[-1] == tuple(target)
    for p in pts:
        assert p[lin] == 0.0
        assert math.hypot(p[a0] - 1.0, p[a1]) == pytest.approx(1.0)
    # counter-clockwise from the first axis towards the second: through a1 < 0 first
    assert pts[len(pts) // 2][a1] < 0


@pytest.mark.parametrize("clockwise", [True, False])
@pytest.mark.parametrize("radius", [5.0, -5.0, 7.5])
def test_radius_form_agrees_with_the_center_form(clockwise, radius):
    start, target = (0.0, 0.0), (6.0, 2.0)
    err, offset = arc_center_from_radius(start, target, radius, Plane.XY, clockwise)
    assert err == ArcError.OK
    r = math.hypot(*offset)
    assert r == pytest.approx(abs(radius))  # the centre is |R| from start and target
    assert math.hypot(target[0] - start[0] - offset[0],
                      target[1] - start[1] - offset[1]) == pytest.approx(abs(radius))
    travel = arc_travel(start, target, offset, Plane.XY, clockwise)
    assert (abs(travel) > math.pi) == (radius < 0)  # negative R: the long way round
    assert (travel < 0) == clockwise
    assert check_arc_offsets(start, target, offset, Plane.XY) == ArcError.OK
    r_pts = arc_points(start, target, offset, Plane.XY, clockwise, 0.002)
    # the same arc given by its centre as I/J (rounded as a program would write it)
    ij = (round(offset[0], 4), round(offset[1], 4))
    ij_pts = arc_points(start, target, ij, Plane.XY, clockwise, 0.002)
    assert len(r_pts) == len(ij_pts)
    for a, b in zip(r_pts, ij_pts, strict=True):
        assert math.dist(a, b) < 1e-3


def test_grbl_errors():
    # R: target equal to the start (Grbl 33), radius too small (34)
    assert arc_center_from_radius((1.0, 1.0), (1.0, 1.0), 5.0, Plane.XY, True)[0] == 33
    assert arc_center_from_radius((0.0, 0.0), (10.0, 0.0), 4.9, Plane.XY, True)[0] == 34
    assert arc_center_from_radius((0.0, 0.0), (10.0, 0.0), 5.0, Plane.XY, True)[0] == 0
    # I/J/K: none in the plane (35); radii differing by more than 0.005 mm and 0.1 % (33)
    assert check_arc_offsets((0, 0), (10, 0), (5, 0), Plane.XY,
                             offset_in_plane=False) == ArcError.NO_OFFSETS_IN_PLANE
    assert check_arc_offsets((0, 0), (10.004, 0), (5, 0), Plane.XY) == ArcError.OK
    assert check_arc_offsets((0, 0), (10.02, 0), (5, 0), Plane.XY) == ArcError.INVALID_TARGET
    # a large radius: 0.1 % of 1000 mm = 1 mm, but never more than 0.5 mm
    assert check_arc_offsets((0, 0), (2000.4, 0), (1000, 0), Plane.XY) == ArcError.OK
    assert check_arc_offsets((0, 0), (2000.6, 0), (1000, 0),
                             Plane.XY) == ArcError.INVALID_TARGET
    assert int(ArcError.ARC_RADIUS_ERROR) == 34  # the numbers Grbl prints as error:N


# the arc of tests/stepperdemo/gcode/test_gcode_words.py's OFF_CIRCLE in steps (80/mm):
# its last chord from a point on the circle to the target rounded to steps, 0.49 step
# inside the circle; ending -X and -Y
OFF_CENTRE = (-0.3557 * 80, 9.9937 * 80)
OFF_RADIUS = math.hypot(*OFF_CENTRE)
OFF_LAST = (-817.958984375, 928.6787109375)  # the last chord's start (on the circle)
OFF_TARGET = (-822, 897)


def _off(p):
    return abs(math.dist(p[:2], OFF_CENTRE) - OFF_RADIUS)


def test_arc_end_cut_where_both_last_steps_on_the_end_tick_would_leave_the_band():
    band = 0.16 + 1.0  # $12 = 0.002 mm and one step
    assert _off((-821, 898)) > band  # the target less both last steps
    cut = arc_end_cut(OFF_LAST + (0.0,), OFF_TARGET + (0,), OFF_CENTRE, OFF_RADIUS, band,
                      Plane.XY)
    assert cut is not None and len(cut) == 3
    # on the chord, where X (the slower axis) has passed its last half step and Y has not
    u = (cut[1] - OFF_LAST[1]) / (OFF_TARGET[1] - OFF_LAST[1])
    assert cut[0] == pytest.approx(OFF_LAST[0] + u * (OFF_TARGET[0] - OFF_LAST[0]))
    assert cut[0] < OFF_TARGET[0] + 0.5  # X past -821.5: on -822, its target, from here
    assert cut[1] > OFF_TARGET[1] + 0.5  # Y short of 897.5: its last step still ahead
    assert _off((-822, 898)) <= band  # the target less Y's last step alone


def test_arc_end_cut_only_where_it_is_needed_and_helps():
    band = 0.16 + 1.0
    args = (OFF_CENTRE, OFF_RADIUS)
    # a wider band: the end rule's points lie within it - no cut
    assert arc_end_cut(OFF_LAST, OFF_TARGET, *args, 2.0, Plane.XY) is None
    # X without a step in the last chord: nothing to release
    assert arc_end_cut((-821.8, 928.7), OFF_TARGET, *args, band, Plane.XY) is None
    # an arc on the circle ending on whole steps (the half circle's end at (1600, 0)):
    # its end rule's points lie within the band
    assert arc_end_cut((1599.36, 32.0), (1600, 0), (800.0, 0.0), 800.0, band,
                       Plane.XY) is None
    # the other planes: the plane's own two axes (ZX: Z first, then X)
    cut = arc_end_cut((928.6787109375, 0.0, -817.958984375), (897, 0, -822),
                      OFF_CENTRE, OFF_RADIUS, band, Plane.ZX)
    assert cut is not None and round(cut[2]) == -822 and cut[0] > 897.5


def test_last_block_pins_stand_on_the_steps_nearest_to_the_path_but_the_last():
    """From (0.3, 0.2) to (4, 1): X from 0 (the step nearest to 0.3) steps where the
    path is half a step before 1, 2, 3 - its last step (to 4) on the end tick, so it
    stands on 3 until then; Y (one step) only on the end tick.  The end rule's points
    (within a step of the target on both axes: (3, 0)) are left to arc_end_cut."""
    assert last_block_pins((0.3, 0.2), (4, 1)) == [(0, 0), (1, 0), (2, 0)]
    # both axes: a step of each whose windows overlap (a grouped step may come up to
    # 1/8 step early) - both orders
    pins = last_block_pins((0.0, 0.0), (8, 8))
    assert (1, 0) in pins and (0, 1) in pins and (1, 1) in pins
    # (0, 0) to (8, 2): X steps where the path's X is 0.5, 1.5 .. 6.5 (u = 1/16, 3/16,
    # 5/16 ..), Y once where its Y is 0.5 (u = 1/4, up to 1/8 step early: from u =
    # 3/16, X's step to 2 - so before it too, (1, 1)); X's step to 3 (from u = 5/16 -
    # 1/64) cannot come before Y's
    assert last_block_pins((0.0, 0.0), (8, 2)) == [
        (0, 0), (1, 0), (1, 1), (2, 0), (2, 1), (3, 1), (4, 1), (5, 1), (6, 1)]


def test_arc_end_approach_begins_the_last_chord_later_only_where_its_steps_leave_the_band():
    """The second arc of test_gcode_words' LATE_ARCS in steps ($12 = 0.01 mm = 0.8
    step): its last chord from (293.17, -19.64) on the circle to (262, 3), 0.66 step
    inside it, comes 1.13 steps inside in its middle and its steps up to 0.71 further
    (`$12` + 1.002 measured): a point on the circle later in the chord, from which
    they keep `$12` + 1; a wider band, or the target on the circle: none."""
    centre = (1.6738 * 80, -2.4897 * 80)
    radius = math.hypot(*centre)
    last = (293.173828125, -19.6357421875, 0.0)
    band = 0.8 + 1.0

    def off(p):
        return abs(math.dist(p[:2], centre) - radius)

    assert max(off(p) for p in last_block_pins(last[:2], (262, 3))) > band
    p = arc_end_approach(last, (262, 3, 0), centre, radius, band, Plane.XY, False)
    assert p is not None and off(p) < 1e-9
    # between the two (the arc turns counter-clockwise from the last chord end)
    a = [math.atan2(q[1] - centre[1], q[0] - centre[0]) for q in (last, p, (262, 3))]
    assert a[0] < a[1] < a[2]
    assert max(off(q) for q in last_block_pins(p[:2], (262, 3))) <= band
    assert arc_end_approach(last, (262, 3, 0), centre, radius, band + 0.1, Plane.XY,
                            False) is None
    on = (centre[0] + radius * math.cos(a[2]), centre[1] + radius * math.sin(a[2]))
    assert arc_end_approach(last, (round(on[0]), round(on[1]), 0), centre, radius, 3.0,
                            Plane.XY, False) is None


def test_arc_end_approach_leaves_an_end_the_cut_keeps_within_the_band():
    """OFF_CIRCLE's last chord: its steps straight to the target would stand on
    (-821, 899), $12 + 1.08 steps inside - but arc_end_cut releases X before, and
    through the cut they keep the band: no later chord."""
    band = 0.16 + 1.0
    straight = last_block_pins(OFF_LAST, OFF_TARGET)
    assert max(_off(p) for p in straight) > band
    assert arc_end_approach(OFF_LAST + (0.0,), OFF_TARGET + (0,), OFF_CENTRE, OFF_RADIUS,
                            band, Plane.XY, False) is None
