"""Plots of long recordings tell the truth (issue 26, item 2): the thinning of the plot
samples keeps every standstill at zero speed and its position flat, in bounded memory."""

from __future__ import annotations

import random

import pytest

from stepperdemo.front.cli import EXIT_OK, main
from stepperdemo.watch import motion, plots
from stepperdemo.watch.thinning import PlotSamples

MOVES = 18
# the issue's command: a long move, 9 s standing, then short moves 1 s apart - 18, not the
# issue's 20: the firmware reads its input into a 256-byte ring on every pass, also while
# a `W` holds it, and build d's default runs every pass of a held W since the fiftieth
# pass: with 20 the line (281 characters) overwrites its first held W (18: 257, the 237
# after that W fit)
ISSUE_LINE = "M1 A1000 V100 R3200 W w9000 A1000000 V40 " + " ".join(["R53 W w1000"] * MOVES)
STANDSTILL_S = 0.5  # the line's waits are >= 1 s, its moves 14 ms or 3.6 s of pulses


def standstills(series: plots.Series) -> list[tuple[int, int, float, float]]:
    """Consecutive samples further apart than any gap inside a move: what a plot draws
    across a standstill, as (position before, position after, speed before, after)."""
    return [(series.position[i - 1], series.position[i], series.speed[i - 1], series.speed[i])
            for i in range(1, len(series.t_s))
            if series.t_s[i] - series.t_s[i - 1] > STANDSTILL_S]


@pytest.fixture(scope="module")
def issue_plot(tmp_path_factory):
    """The issue's command line with --plot: the series the PNG was drawn from."""
    drawn, observed = [], []
    real_png, real_series = plots.write_png, plots.series_of

    def png_spy(series, path, *args, **kw):
        drawn.append(list(series))
        real_png(series, path, *args, **kw)

    def series_spy(obs, *args):
        observed.append(obs)
        return real_series(obs, *args)

    png = tmp_path_factory.mktemp("plot") / "p.png"
    mp = pytest.MonkeyPatch()
    mp.setattr(plots, "write_png", png_spy)
    mp.setattr(plots, "series_of", series_spy)
    try:
        rc = main(["-c", ISSUE_LINE, "--plot", str(png)])
    finally:
        mp.undo()
    assert rc == EXIT_OK and png.stat().st_size > 0
    (series,) = drawn[0]
    series.motion = observed[0].analysis.steppers[0]  # the unthinned figures, to compare
    return series


def test_every_standstill_is_drawn_at_zero_speed_and_a_flat_position(issue_plot):
    s = issue_plot
    assert s.position[-1] == 3200 + MOVES * 53
    gaps = standstills(s)
    # the 9 s wait after the long move and the 1 s after each short move but the last
    assert len(gaps) == 1 + MOVES - 1
    for before, after, v_before, v_after in gaps:
        assert (v_before, v_after) == (0.0, 0.0)
        assert before == after
    # the positions it stands at: 3200, then 53 steps more after each move
    assert [before for before, *_ in gaps] == [3200 + 53 * k for k in range(MOVES)]


def test_the_terminal_chart_is_flat_at_zero_through_the_long_standstill(issue_plot):
    s = issue_plot
    width, height = 64, 8
    lines = plots.terminal_plot([s], width=width, height=height)
    at = lines.index("M1 speed [steps/s]")
    rows = [line.split("|", 1)[1] for line in lines[at + 1:at + 1 + height]]
    t0, t1 = s.t_s[0], s.t_s[-1]
    stop = max(t for t, v in zip(s.t_s, s.speed, strict=True) if t < 5 and v)  # end of move 1
    start = min(t for t in s.t_s if t > stop + 1)  # first pulse of move 2
    # the columns strictly inside the 9 s standstill (a column spans 2 dots)
    cols = [c for c in range(width)
            if stop < t0 + (2 * c - 1) / (2 * width - 1) * (t1 - t0)
            and t0 + (2 * c + 2) / (2 * width - 1) * (t1 - t0) < start]
    assert len(cols) > 10
    for c in cols:
        assert all(ord(row[c]) == 0x2800 for row in rows[:-1]), c  # nothing above zero
        assert ord(rows[-1][c]) & ~(0x40 | 0x80) == 0x2800, c  # only the zero line


def test_peak_speed_survives_the_thinning(issue_plot):
    """The fastest interval of the run (the report's peak speed) is in the plot; so is
    the peak of the long move (A=1000 over 3200 steps: about sqrt(3200 * 1000))."""
    m = issue_plot.motion
    assert max(issue_plot.speed) == 16_000_000 / m.period_min
    first = max(v for t, v in zip(issue_plot.t_s, issue_plot.speed, strict=True) if t < 5)
    assert first == pytest.approx((3200 * 1000) ** 0.5, rel=0.02)


def test_many_moves_keep_the_bound_and_the_standstills(monkeypatch):
    """300 short moves: the samples stay within the bound, the buckets (not the moves)
    decide how many there are, and every 1 s standstill is still flat at zero."""
    from fas.sim import SimBackend
    from stepperdemo.program import make_program
    from stepperdemo.watch import observe

    monkeypatch.setattr(motion, "PLOT_POINTS", 1000)
    line = "M1 A1000000 V40 " + " ".join(["R53 W w1000"] * 300)
    # build e: build d's default runs every pass of a held W since the fiftieth pass
    # and, as the firmware, reads the line into its 256-byte ring meanwhile, so a line of
    # 3 616 characters overwrites its held W's (27 moves arrive); build e's W skips its
    # idle passes (the line waits)
    backend = SimBackend("atmega328p", build="e")
    app = make_program("demo", backend, scripted=True, output=lambda _b: None)
    obs = observe.attach(backend)
    app.watch(obs)
    app.run_script(line, firmware_end=False, max_ticks=3600 * backend.profile.ticks_per_s)
    obs.finish()
    m = obs.analysis.steppers[0]
    (s,) = plots.series_of(obs)
    # (the firmware drops input while it prints the usage after a stop, as a board
    # would: some R53 never arrive)
    moves = m.pulses // 53
    assert moves > 250 and m.pulses == moves * 53 == s.position[-1]
    assert len(s.t_s) <= 1000
    gaps = standstills(s)
    assert len(gaps) == moves - 1
    assert all(v0 == v1 == 0.0 and p0 == p1 for p0, p1, v0, v1 in gaps)


# ------------------------------------------------------------- the thinning
def test_plot_samples_stay_bounded_and_keep_extremes_and_standstill_ends():
    rng = random.Random(26)
    kept = PlotSamples(400, key=2)
    t, pos, peak = 0, 0, 0.0
    ends = []  # (last tick of a motion, first tick of the next)
    for n in range(2000):
        kept.add((t, pos, 0.0))
        for _ in range(rng.randint(2, 30)):
            t += rng.randint(50, 500)
            pos += 1
            v = 16e6 / rng.randint(50, 500)
            peak = max(peak, v)
            kept.add((t, pos, v))
        kept.add((t, pos, 0.0))
        gap = 100_000_000 if n % 100 == 99 else rng.choice((100, 10_000))
        ends.append((t, t + gap))
        t += gap
        assert len(kept) <= 400
    samples = kept.samples()
    assert [s[0] for s in samples] == sorted(s[0] for s in samples)
    assert max(s[2] for s in samples) == peak  # the fastest interval is still there
    # a standstill wider than two buckets: its ends are kept, both at zero speed
    by_tick = {}
    for s in samples:
        by_tick.setdefault(s[0], []).append(s)
    wide = [(a, b) for a, b in ends[:-1] if b - a > 2 * kept.width]
    assert wide
    for a, b in wide:
        assert by_tick[a][-1][2] == 0.0 and by_tick[b][0][2] == 0.0
        assert by_tick[a][-1][1] == by_tick[b][0][1]


def test_plot_samples_keep_everything_below_the_bound():
    kept = PlotSamples(100, key=1)
    data = [(t, (t * 7919) % 13) for t in range(90)]
    for s in data:
        kept.add(s)
    assert kept.samples() == data


# ------------------------------------------------------- the figure (item 10)
def _figure_of(argv, monkeypatch):
    """The matplotlib figure the command line draws (and writes)."""
    made = []
    real = plots.figure

    def spy(*args, **kw):
        made.append(real(*args, **kw))
        return made[-1]

    monkeypatch.setattr(plots, "figure", spy)
    assert main(argv) == EXIT_OK
    (fig,) = made
    return fig


def test_traverse_plot_has_one_legend(tmp_path, monkeypatch):
    """The README's winder plot: two panels, the same stepper in each, one legend."""
    fig = _figure_of(["winder", "-c", "period 2 100 accel 2 20000 traverse 0 2000 w4000 "
                      "move 2 0 w500", "--plot", str(tmp_path / "traverse.png")], monkeypatch)
    legends = [ax.get_legend() for ax in fig.axes if ax.get_legend() is not None]
    assert len(legends) == 1
    assert [t.get_text() for t in legends[0].get_texts()] == ["S2"]  # the winder's name
    assert (tmp_path / "traverse.png").stat().st_size > 0


def test_winder_plots_name_its_steppers_s1_and_s2(tmp_path, monkeypatch):
    fig = _figure_of(["winder", "-c", "period 1 100 accel 1 20000 move 1 500 period 2 100 "
                      "accel 2 20000 move 2 300 w500", "--plot", str(tmp_path / "w.png")],
                     monkeypatch)
    lines = [line for ax in fig.axes for line in ax.get_lines()]
    assert sorted({line.get_label() for line in lines}) == ["S1", "S2"]
    ends = {line.get_label(): line.get_ydata()[-1] for line in fig.axes[0].get_lines()}
    assert ends == {"S1": 500, "S2": 300}  # the position panel: S1 at 500, S2 at 300


def test_a_long_command_is_the_whole_title_wrapped(issue_plot, tmp_path, monkeypatch):
    fig = _figure_of(["-c", ISSUE_LINE, "--plot", str(tmp_path / "p.png")], monkeypatch)
    (title,) = [t.get_text() for t in fig.texts]  # the suptitle
    assert title.split() == ISSUE_LINE.split()  # nothing cut: its end is there
    assert max(len(line) for line in title.splitlines()) <= plots.TITLE_WIDTH
    longer = ISSUE_LINE + " M2 R5 W" + " R53 W w1000" * 30 + " M1 R-7 W"
    short = plots.plot_title(longer).splitlines()
    assert len(short) == plots.TITLE_LINES
    assert short[0].startswith("M1 A1000 V100 R3200") and short[1].endswith(" ...")
    assert short[-1].startswith("... ") and short[-1].endswith("R53 W w1000 M1 R-7 W")
