"""Position and speed over time per stepper: in the terminal (braille) or as PNG.

The speed is derived from the step periods (steps/s = ticks_per_s / period, signed by
the direction).  The terminal plot needs nothing beyond the standard library; the
PNG needs matplotlib (the optional extra ``plot``).
"""

from __future__ import annotations

import importlib.util
import os
import re
import tempfile
import textwrap
from collections.abc import Sequence
from dataclasses import dataclass

from .. import messages as msg
from .observe import Observers

BRAILLE = 0x2800
# dot bit of braille cell column x (0/1) and row y (0..3)
_DOTS = ((0x01, 0x02, 0x04, 0x40), (0x08, 0x10, 0x20, 0x80))


@dataclass
class Series:
    number: int  # stepper 1, 2, ...
    t_s: list[float]
    position: list[int]
    speed: list[float]

    @property
    def label(self) -> str:
        return f"M{self.number}"


def series_of(obs: Observers) -> list[Series]:
    """The plot data of every stepper that made steps."""
    obs.flush()
    if obs.analysis is None:
        return []
    tps = obs.profile.ticks_per_s
    out = []
    for m in obs.analysis.steppers:
        if not m.samples:
            continue
        out.append(Series(m.wiring.number, [t / tps for t, _, _ in m.samples],
                          [p for _, p, _ in m.samples], [v for _, _, v in m.samples]))
    return out


@dataclass
class OutputSeries:
    """A user output over time: level 0/1 (Dout) or duty % per PWM period (Aout)."""

    name: str
    analog: bool
    t_s: list[float]
    value: list[float]


def outputs_of(obs: Observers) -> list[OutputSeries]:
    """The plot data of every user output that changed (issue 12)."""
    obs.flush()
    if obs.outputs is None:
        return []
    tps = obs.profile.ticks_per_s
    out = []
    for tr in obs.outputs.outputs:
        if tr.samples:
            out.append(OutputSeries(tr.out.name, tr.out.analog,
                                    [t / tps for t, _ in tr.samples],
                                    [v for _, v in tr.samples]))
    return out


@dataclass
class PathFeed:
    """The feed along a path of several axes (G-code): units/min over time."""

    t_s: list[float]
    feed: list[float]


def _speed_at(s: Series, t: float, k: int) -> float:
    """The stepper's speed at ``t`` (linear between its samples; 0 outside them);
    ``k`` is the index of the first sample at or after ``t``."""
    if k >= len(s.t_s) or (k == 0 and t < s.t_s[0]):
        return 0.0
    if s.t_s[k] == t or k == 0:
        return s.speed[k]
    t0, t1 = s.t_s[k - 1], s.t_s[k]
    return s.speed[k - 1] + (s.speed[k] - s.speed[k - 1]) * (t - t0) / (t1 - t0)


def path_feed(series: Sequence[Series], units: dict[int, float]) -> PathFeed | None:
    """The feed along the path, ``60 * sqrt(sum((v_i / steps_per_unit_i)^2))`` units/min,
    at every sample time of the axes in ``units`` (stepper number -> steps per unit);
    None when none of them moved."""
    axes = [s for s in series if s.number in units and s.t_s]
    if not axes:
        return None
    times = sorted({t for s in axes for t in s.t_s})
    idx = [0] * len(axes)
    feed = []
    for t in times:
        total = 0.0
        for j, s in enumerate(axes):
            while idx[j] < len(s.t_s) and s.t_s[idx[j]] < t:
                idx[j] += 1
            v = _speed_at(s, t, idx[j]) / units[s.number]
            total += v * v
        feed.append(60.0 * total ** 0.5)
    return PathFeed(times, feed)


MIN_SIDE, MAX_SIDE = 200, 10_000  # pixels a side of a PNG plot
MAX_PIXELS = 40_000_000  # (a 10000x4000 image: 160 MB while matplotlib draws it)
FORMATS = (".png", ".svg", ".pdf")  # what --plot and /plot write, by the file's suffix
TITLE_WIDTH = 100  # characters a title line; longer titles wrap
TITLE_LINES = 3  # at most; a longer title keeps its beginning and its end


def parse_size(text: str) -> tuple[int, int] | None:
    """``"1200x800"`` -> (1200, 800); None if it is not WxH within the bounds."""
    m = re.fullmatch(r"\s*(\d{1,9})\s*[xX]\s*(\d{1,9})\s*", text or "")
    if not m:
        return None
    w, h = int(m.group(1)), int(m.group(2))
    if not (MIN_SIDE <= w <= MAX_SIDE and MIN_SIDE <= h <= MAX_SIDE) or w * h > MAX_PIXELS:
        return None
    return w, h


def path_problem(path: str) -> str | None:
    """Why a plot cannot be written to ``path`` (checked before a run), or None."""
    suffix = os.path.splitext(path)[1].lower()
    if suffix not in FORMATS:
        return msg.PLOT_BAD_FORMAT.format(path=path, formats=", ".join(FORMATS))
    folder = os.path.dirname(path) or "."
    if not os.path.isdir(folder):
        return msg.OBSERVE_FILE_ERROR.format(path=path, error=msg.PLOT_NO_FOLDER.format(
            folder=folder))
    if os.path.isdir(path):
        return msg.OBSERVE_FILE_ERROR.format(path=path, error=msg.PLOT_IS_FOLDER)
    try:  # can a file be made there? (root passes every permission check: try it)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        return msg.OBSERVE_FILE_ERROR.format(path=path, error=exc.strerror or exc)
    return None


def plot_title(text: str) -> str:
    """A title for the figure: wrapped at :data:`TITLE_WIDTH`; beyond
    :data:`TITLE_LINES` lines its beginning and its end with " ... " between."""
    flat = " ".join(text.split())
    lines = textwrap.wrap(flat, TITLE_WIDTH)
    if len(lines) <= TITLE_LINES:
        return "\n".join(lines)
    room = TITLE_WIDTH - 4  # for the " ..." / "... " marks
    words = flat.split(" ")
    tail: list[str] = []
    while words and len(" ".join([words[-1], *tail])) <= room:
        tail.insert(0, words.pop())
    end = " ".join(tail) if tail else flat[-room:]
    head = textwrap.wrap(flat, room)[:TITLE_LINES - 1]
    return "\n".join([*head[:-1], head[-1] + " ...", "... " + end])


# --------------------------------------------------------------- terminal
def _braille_chart(ts: Sequence[float], ys: Sequence[float], width: int,
                   height: int, t_range: tuple[float, float]) -> tuple[list[str], float, float]:
    w, h = width * 2, height * 4
    t0, t1 = t_range
    lo, hi = min(ys), max(ys)
    if hi == lo:
        hi, lo = hi + 1, lo - 1
    cells = [[0] * width for _ in range(height)]

    def dot(x: int, y: int) -> None:
        cells[y // 4][x // 2] |= _DOTS[x % 2][y % 4]

    def xy(t: float, v: float) -> tuple[int, int]:
        x = round((t - t0) / (t1 - t0) * (w - 1)) if t1 > t0 else 0
        y = round((hi - v) / (hi - lo) * (h - 1))
        return min(max(x, 0), w - 1), min(max(y, 0), h - 1)

    px, py = xy(ts[0], ys[0])
    dot(px, py)
    for t, v in zip(ts[1:], ys[1:], strict=True):
        x, y = xy(t, v)
        n = max(abs(x - px), abs(y - py))
        for i in range(1, n + 1):
            dot(px + (x - px) * i // n, py + (y - py) * i // n)
        px, py = x, y
    rows = ["".join(chr(BRAILLE + c) for c in row) for row in cells]
    return rows, lo, hi


def _num(v: float) -> str:
    return f"{v:.0f}" if abs(v) >= 100 or v == int(v) else f"{v:.3g}"


def terminal_plot(series: Sequence[Series], width: int = 64, height: int = 8,
                  outputs: Sequence[OutputSeries] = ()) -> list[str]:
    """Text lines: per stepper a position chart and a speed chart (braille dots);
    per user output its level or duty (issue 12)."""
    if not series and not outputs:
        return [msg.PLOT_NO_DATA]
    t0 = min([s.t_s[0] for s in series] + [o.t_s[0] for o in outputs])
    t1 = max([s.t_s[-1] for s in series] + [o.t_s[-1] for o in outputs])
    charts: list[tuple[str, Sequence[float], Sequence[float], int]] = []
    for s in series:
        for what, ys in ((msg.PLOT_TITLE_POSITION, s.position), (msg.PLOT_TITLE_SPEED, s.speed)):
            charts.append((msg.PLOT_TERMINAL_HEADER.format(n=s.number, what=what), s.t_s, ys,
                           height))
    for o in outputs:
        what = msg.PLOT_OUTPUT_DUTY if o.analog else msg.PLOT_OUTPUT_LEVEL
        ts, ys = _steps(o.t_s, o.value) if not o.analog else (o.t_s, o.value)
        charts.append((msg.PLOT_TERMINAL_OUTPUT.format(name=o.name, what=what), ts, ys,
                       max(2, height // 2)))
    lines: list[str] = []
    for header, ts, ys, h in charts:
        rows, lo, hi = _braille_chart(ts, ys, width, h, (t0, t1))
        lines.append(header)
        label_w = max(len(_num(hi)), len(_num(lo)))
        for i, row in enumerate(rows):
            label = _num(hi) if i == 0 else _num(lo) if i == len(rows) - 1 else ""
            lines.append(f"{label:>{label_w}} |{row}")
        left, right = f"{t0:.3f} s", f"{t1:.3f} s"
        lines.append(" " * label_w + " +" + "-" * width)
        lines.append(" " * (label_w + 2) + left + right.rjust(width - len(left)))
    return lines


def _steps(ts: Sequence[float], ys: Sequence[float]) -> tuple[list[float], list[float]]:
    """A level held until the next change: a staircase of points."""
    out_t, out_y = [ts[0]], [ys[0]]
    for t, y in zip(ts[1:], ys[1:], strict=True):
        out_t += [t, t]
        out_y += [out_y[-1], y]
    return out_t, out_y


# -------------------------------------------------------------------- PNG
def png_available() -> bool:
    return importlib.util.find_spec("matplotlib") is not None


class PlotExtraMissing(RuntimeError):
    pass


DPI = 100


def write_png(series: Sequence[Series], path: str, size: tuple[int, int] = (1200, 800),
              title: str = "", outputs: Sequence[OutputSeries] = (),
              feed: PathFeed | None = None) -> None:
    """Position and speed over time, one line per stepper, as a PNG of ``size`` pixels;
    with ``outputs`` a panel of Dout levels (offset per output) and Aout duty; with
    ``feed`` (G-code) a panel of the feed along the path."""
    figure(series, size, title, outputs, feed).savefig(path, dpi=DPI)


def figure(series: Sequence[Series], size: tuple[int, int] = (1200, 800), title: str = "",
           outputs: Sequence[OutputSeries] = (), feed: PathFeed | None = None):
    """The matplotlib figure of :func:`write_png`."""
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError as exc:  # pragma: no cover - depends on the installation
        raise PlotExtraMissing(msg.PLOT_EXTRA_MISSING) from exc
    dpi = DPI
    fig = Figure(figsize=(size[0] / dpi, size[1] / dpi), dpi=dpi, layout="constrained")
    FigureCanvasAgg(fig)
    panels = 2 + bool(outputs) + (feed is not None)
    axes = fig.subplots(panels, 1, sharex=True)
    ax_pos, ax_speed = axes[0], axes[1]
    if feed is not None:
        ax_feed = axes[2]
        ax_feed.plot(feed.t_s, feed.feed, linewidth=1.2, color="black")
        ax_feed.set_ylabel(msg.PLOT_TITLE_FEED)
        ax_feed.grid(True, alpha=0.3)
    for s in series:
        ax_pos.plot(s.t_s, s.position, label=s.label, linewidth=1.2)
        ax_speed.plot(s.t_s, s.speed, label=s.label, linewidth=1.2)
    ax_pos.set_ylabel(msg.PLOT_TITLE_POSITION)
    ax_speed.set_ylabel(msg.PLOT_TITLE_SPEED)
    axes[-1].set_xlabel(msg.PLOT_AXIS_TIME)
    if outputs:
        ax_out = axes[-1]
        digital = [o for o in outputs if not o.analog]
        for i, o in enumerate(digital):  # 0/1 levels stacked above the duty range
            ax_out.step(o.t_s, [110 + 15 * i + 10 * v for v in o.value], where="post",
                        label=o.name, linewidth=1.2)
        for o in outputs:
            if o.analog:
                ax_out.step(o.t_s, o.value, where="post", label=o.name, linewidth=1.2)
        ax_out.set_ylabel(msg.PLOT_TITLE_OUTPUTS)
        ax_out.grid(True, alpha=0.3)
        ax_out.legend(loc="best")
    for ax in (ax_pos, ax_speed):
        ax.grid(True, alpha=0.3)
    if series:  # one legend for both panels: the steppers are the same in each
        ax_pos.legend(loc="best")
    if not series:
        ax_pos.text(0.5, 0.5, msg.PLOT_NO_DATA, ha="center", va="center",
                    transform=ax_pos.transAxes)
    if title:
        fig.suptitle(title)
    return fig


def write_png_or_problem(series: Sequence[Series], path: str,
                         size: tuple[int, int] | None = (1200, 800), title: str = "",
                         outputs: Sequence[OutputSeries] = (),
                         feed: PathFeed | None = None) -> str | None:
    """:func:`write_png`; a file that cannot be written is a one-line problem (None:
    written)."""
    problem = path_problem(path)
    if problem is not None:
        return problem
    try:
        write_png(series, path, size or (1200, 800), title=title, outputs=outputs,
                  feed=feed)
    except (OSError, ValueError, MemoryError) as exc:
        return msg.OBSERVE_FILE_ERROR.format(path=path, error=exc)
    return None
