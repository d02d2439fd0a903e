"""``stepperdemo gcode FILE --plot`` draws the feed along the path (issue 25): the numbers
it draws are the path's speed in units/min - the programmed F while a line cruises, the
vector sum of the axes' speeds measured from their steps."""

from __future__ import annotations

import math

import pytest

from stepperdemo.front.cli import EXIT_OK, main
from stepperdemo.watch import plots

PROGRAM = """$100=80
$101=40
$120=500
$121=500
G1 X30 Y40 F3000
G0 X0
M2
"""


@pytest.fixture(scope="module")
def drawn(tmp_path_factory):
    """The feed handed to the PNG writer, and the file."""
    got = []
    real = plots.write_png_or_problem

    def spy(series, path, *args, **kw):
        got.append((list(series), kw.get("feed")))
        return real(series, path, *args, **kw)

    tmp = tmp_path_factory.mktemp("feed")
    prog = tmp / "p.gcode"
    prog.write_text(PROGRAM)
    png = tmp / "p.png"
    mp = pytest.MonkeyPatch()
    mp.setattr(plots, "write_png_or_problem", spy)
    try:
        rc = main(["gcode", "--arch", "atmega2560", str(prog), "--plot", str(png)])
    finally:
        mp.undo()
    assert rc == EXIT_OK
    (series, feed), = got
    return series, feed, png


def test_the_feed_along_the_path_is_the_programmed_feed_while_the_line_cruises(drawn):
    series, feed, _png = drawn
    assert feed is not None
    # the G1 line: X 2400 steps at 80/mm, Y 1600 steps at 40/mm - 50 mm at F3000
    g1_end = max(t for s in series for t, v in zip(s.t_s, s.speed, strict=True)
                 if s.number == 2 and v > 0)
    cruise = [f for t, f in zip(feed.t_s, feed.feed, strict=True) if t <= g1_end and f > 2900]
    assert len(cruise) > 50
    assert max(cruise) == pytest.approx(3000, rel=0.01)  # steps on whole ticks: 1 %
    assert sum(cruise) / len(cruise) == pytest.approx(3000, rel=0.002)
    assert feed.feed[0] == 0.0  # from rest


def test_the_feed_is_the_vector_sum_of_the_axes_speeds_in_units(drawn):
    series, feed, _png = drawn
    x, y = (next(s for s in series if s.number == n) for n in (1, 2))
    for k in range(0, len(x.t_s), max(1, len(x.t_s) // 40)):
        t = x.t_s[k]
        if t not in y.t_s or t not in feed.t_s:
            continue
        vy = y.speed[y.t_s.index(t)]
        want = 60 * math.hypot(x.speed[k] / 80, vy / 40)
        assert feed.feed[feed.t_s.index(t)] == pytest.approx(want)
    # the G0 back: X alone at its top rate, the feed is X's speed in mm/min
    top = max(f for t, f in zip(feed.t_s, feed.feed, strict=True) if t > y.t_s[-1])
    assert top == pytest.approx(60 * max(abs(v) for v in x.speed) / 80, rel=1e-6)


def test_the_png_has_the_feed_panel(drawn):
    _series, _feed, png = drawn
    if not plots.png_available():
        pytest.skip("matplotlib is not installed")
    assert png.stat().st_size > 10_000
    fig = plots.figure(drawn[0], feed=drawn[1])
    labels = [ax.get_ylabel() for ax in fig.axes]
    assert "feed along the path [units/min]" in labels
    line = fig.axes[labels.index("feed along the path [units/min]")].lines[0]
    assert list(line.get_ydata()) == drawn[1].feed
