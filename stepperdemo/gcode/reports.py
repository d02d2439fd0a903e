"""What the machine reports, in Grbl 1.1's formats: the ``?`` status report, ``$G``,
``$#``, ``$I`` and ``$$``.

Positions are printed for at least three axes (X Y Z: every sender expects three;
a machine with two steppers prints Z as 0.000) and at most six, in units with three
decimals.  The status report's fields come in Grbl's order
``<State|MPos|Bf|FS|WCO|Ov>``; ``WCO`` and ``Ov`` appear on Grbl's schedule
(:class:`ReportSchedule`); the project's ``Dout:``/``Aout:`` fields follow only
with ``$170=1``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .interp import MM_PER_INCH
from .parser import code_name
from .settings import FIXED, KEPT, SWITCHES

if TYPE_CHECKING:  # pragma: no cover
    from .machine import GcodeMachine

REPORT_AXES = 3  # at least X Y Z in every report (Grbl's N_AXIS)
# Grbl's refresh counts (config.h): reports between two WCO / Ov fields
WCO_BUSY, WCO_IDLE = 30, 10
OV_BUSY, OV_IDLE = 20, 10
BUSY_STATES = ("Run", "Hold", "Jog", "Door", "Home")
GRBL_VERSION = "1.1h.20190830"


def axis_values(values: list[float], decimals: int = 3) -> str:
    shown = list(values) + [0.0] * max(0, REPORT_AXES - len(values))
    return ",".join(f"{v:.{decimals}f}" for v in shown)


class ReportSchedule:
    """When ``WCO:`` and ``Ov:`` go into a status report (Grbl's counters): ``WCO`` in
    the first report after a reset or an offset change, then every 10th (30th while
    busy); ``Ov`` in the report after that, after an override change, then every 10th
    (20th while busy)."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self.wco = 0
        self.ov = 0

    def offsets_changed(self) -> None:
        self.wco = 0

    def overrides_changed(self) -> None:
        self.ov = 0

    def fields(self, busy: bool) -> tuple[bool, bool]:
        """(print WCO, print Ov) in the report made now."""
        show_wco = False
        if self.wco > 0:
            self.wco -= 1
        else:
            self.wco = (WCO_BUSY if busy else WCO_IDLE) - 1
            if self.ov == 0:
                self.ov = 1
            show_wco = True
        show_ov = False
        if self.ov > 0:
            self.ov -= 1
        else:
            self.ov = (OV_BUSY if busy else OV_IDLE) - 1
            show_ov = True
        return show_wco, show_ov


def status_report(m: GcodeMachine) -> str:
    """Grbl's answer to ``?``."""
    st = m.settings
    state = m.state_name()
    mpos = m.machine_position()
    wco = list(m.wco)
    fields = [state]
    if st.status_mask & 1:
        fields.append("MPos:" + axis_values(mpos))
    else:
        fields.append("WPos:" + axis_values([p - o for p, o in zip(mpos, wco, strict=True)]))
    if st.status_mask & 2:
        fields.append(f"Bf:{m.blocks.room},{m.rx.free}")
    fields.append(f"FS:{m.executor.path_rate():.0f},{m.tooling.reported_speed():.0f}")
    show_wco, show_ov = m.schedule.fields(state.split(":")[0] in BUSY_STATES)
    if show_wco:
        fields.append("WCO:" + axis_values(wco))
    if show_ov:
        fields.append(f"Ov:{m.feed_override},{m.rapid_override},{m.spindle_override}")
    if st.report_outputs:
        outputs = m.engine.outputs
        fields.append("Dout:" + "".join(str(outputs.digital_applied(n)) for n in range(4)))
        fields.append("Aout:" + ",".join(f"{outputs.analog_applied(n)[0]:.2f}"
                                         for n in range(4)))
    return "<" + "|".join(fields) + ">"


def parser_state(m: GcodeMachine) -> str:
    """``$G``: the modal state in Grbl's order - motion, coordinate system, plane,
    units, distance, feed mode, [M0/M2/M30], spindle, coolant, T, F, S."""
    it = m.interp
    words = [code_name("G", it.motion), f"G{54 + it.coord_select}", f"G{it.plane}",
             "G20" if it.inches else "G21", "G90" if it.absolute else "G91",
             "G93" if it.inverse_time else "G94"]
    if m.paused:
        words.append("M0")
    words.append(f"M{it.spindle}")
    coolant = (["M7"] if it.mist else []) + (["M8"] if it.flood else [])
    words += coolant or ["M9"]
    feed = it.feed / MM_PER_INCH if it.inches and not it.inverse_time else it.feed
    words += [f"T{it.tool}", f"F{feed:.0f}", f"S{it.spindle_speed:.0f}"]
    return "[GC:" + " ".join(words) + "]"


def parameters(m: GcodeMachine) -> list[str]:
    """``$#``: G54-G59, G28, G30 (machine units), the G92 offset, the tool length
    offset and the last probe (machine units, 1: it touched)."""
    it = m.interp
    c = it.coords
    lines = [f"[G{54 + n}:{axis_values(c.systems[n])}]" for n in range(len(c.systems))]
    lines += [f"[G28:{axis_values(c.g28)}]", f"[G30:{axis_values(c.g30)}]",
              "[G92:" + axis_values(list(it.offset)) + "]", f"[TLO:{it.tlo:.3f}]",
              m.probe.report()]
    return lines


def build_info(m: GcodeMachine) -> list[str]:
    """``$I``: Grbl's version with our identity in the user string, and the options."""
    # Grbl's option letters: V a variable (PWM) spindle, M mist coolant (M7)
    mist = m.tooling.map.mist
    options = ("V" if m.tooling.spindle_output() is not None else "") + (
        "M" if mist is not None and m.tooling.role(False, mist) is not None else "")
    return [f"[VER:{GRBL_VERSION}:{m.settings.build_info or m.identity}]",
            f"[OPT:{options},{m.blocks.size},{m.rx.ring_size}]"]


def settings_lines(m: GcodeMachine) -> list[str]:
    """``$$``: ``$n=value`` in Grbl's order, then the project's own numbers."""
    st = m.settings
    shown = max(REPORT_AXES, m.axes)
    values: dict[int, str] = {n: str(v) for n, v in FIXED.items()}
    values[1] = str(st.idle_delay_ms)
    values[10] = str(st.status_mask)
    for n, (_default, decimals) in KEPT.items():
        values[n] = f"{st.kept[n]:.{decimals}f}"
    for n in SWITCHES:
        values[n] = "0"
    lines = [f"${n}={values[n]}" for n in sorted(values)]
    for base in (100, 110, 120, 130):
        axis = st.axis_values(base)
        lines += [f"${base + i}={axis[i]:.3f}" for i in range(shown)]
    outputs = m.engine.outputs
    lines += [f"${140 + n}={_plain(outputs.frequency_hz(n))}" for n in range(4)]
    lines += [f"${150 + n}={outputs.digital_pin(n)}" for n in range(4)]
    lines += [f"${160 + n}={outputs.analog_pin(n)}" for n in range(4)]
    lines.append(f"$170={int(st.report_outputs)}")
    lines.append(f"$171={st.motion}")
    lines.append(f"$172={int(st.corner_blends)}")
    lines.append(f"$173={_plain(st.plain_corner_steps)}")
    return lines


def _plain(value: float) -> str:
    """A number as ``$$`` prints it: plain decimals, never an exponent (``1e+06``
    breaks senders' ``$N=value`` parsers)."""
    return f"{value:.3f}".rstrip("0").rstrip(".")
