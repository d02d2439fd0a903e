"""What the library's ramp arithmetic costs the simulated chip, by value.

The ramp task computes an accelerating or decelerating command's period from the ramp
step: the step to log2 (``log2_from``), the log2 value back (``log2_to_u32``).  On the
AVR both take a number of cycles that follows the values: the conversion to log2 shifts
the step's leading bit out one place a loop turn (a 16-bit step takes another path than
an 8-bit one), the conversion back shifts by the exponent's distance from 10, and each
interpolates between two table entries for some values.  The cycles per value come from
the firmware's replica (bench/replica/replica.py --profile pitches; the figures are in
the build's table, :class:`fas.sim.timing.SimTiming`).
"""

from __future__ import annotations

from ..codes import PATH_CHECK, PATH_COAST, PATH_DEC, PATH_NEAR
from .timing import SimTiming


def log2_window(value: int) -> tuple[int, bool]:
    """The library's log2 of a 32-bit value: the bit length of the 16 bits it converts
    and whether it reads two table entries (interpolates)."""
    value &= 0xFFFFFFFF
    if value < 0x10000:
        w = value
    elif value < 0x100000:
        w = value >> 4
    elif value < 0x1000000:
        w = value >> 8
    elif value < 0x10000000:
        w = value >> 12
    else:
        w = value >> 16
    bits = w.bit_length()
    if bits <= 8:
        return bits, False  # the 8-bit conversion: one table entry
    x = ((w << (17 - bits)) & 0xFFFF) >> 5  # the leading bit shifted out
    return bits, (x & 7) > 2


def conversion_ticks(timing: SimTiming, ramp_step: int, log2_ticks: int) -> int:
    """CPU ticks of the ramp's conversions of ``ramp_step`` to log2 and of
    ``log2_ticks`` back (calculate_ticks's own code included)."""
    frm, back = timing.ramp_log2_from_ticks, timing.ramp_log2_to_ticks
    if not frm or not back:
        return 0
    bits, interp = log2_window(ramp_step)
    ticks = frm[min(max(bits, 1), len(frm)) - 1]
    if interp:
        ticks += timing.ramp_log2_interp_ticks
    exponent = log2_ticks >> 9 if log2_ticks > 0 else 0
    ticks += back[min(exponent, len(back) - 1)]
    if log2_ticks & 1:
        ticks += timing.ramp_log2_interp_ticks
    return ticks


def start_pitch_ticks(figures: tuple[int, ...], path: int) -> int:
    """A starting ramp's command of several steps beyond its one figure, by the
    branches its planning took (``figures``: plain, near, check, coast, dec;
    :attr:`fas.sim.timing.SimTiming.fill_start_pitch_ticks`)."""
    plain, near, check, coast, dec = figures
    return (plain + (near if path & PATH_NEAR else 0) + (check if path & PATH_CHECK else 0)
            + (coast if path & PATH_COAST else 0) + (dec if path & PATH_DEC else 0))
