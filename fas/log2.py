"""Logarithmic fixed-point numbers, bit-exact with FastAccelStepper's ramp maths.

FastAccelStepper avoids floating point on 8-bit chips: every positive quantity the
ramp needs (steps, ticks, accelerations) is held as ``xi = round(512 * log2(x))`` in a
signed 16-bit integer.  Multiplication becomes addition, square root a halving.
The conversions to and from the log domain use two 256-entry correction tables and
a linear interpolation between neighbouring entries.  The exact integer sequence
matters: a status line prints ``v=11184us/178944ticks`` and those digits come from
this arithmetic, so it is reproduced here operation by operation, including C's
16-bit wrap-around and truncating division.
"""

from __future__ import annotations

import math
from collections.abc import Callable

INVALID = -0x8000
MAX = 0x7FFF
MIN = -0x7FFF
UINT16_MAX_LOG2 = 0x2000  # log2 of 65536
UINT32_MAX_LOG2 = 0x4000  # log2 of 2**32


def _table(func: Callable[[int], float]) -> tuple[int, ...]:
    return tuple(round(func(i) * 4) for i in range(256, 512))


# 4 * (256*log2(i/256) - (i-256)): how far log2(1+r) bulges above the straight line r.
_LOG_CORR = _table(lambda i: math.log2(i / 256) * 256 - (i - 256))
# 4 * (i - 256*2**(i/256-1)): the same bulge for the inverse function.
_POW_CORR = _table(lambda i: i - math.pow(2, i / 256 - 1) * 256)


def wrap16(v: int) -> int:
    """Interpret ``v`` as a C int16_t (two's complement wrap)."""
    v &= 0xFFFF
    return v - 0x10000 if v & 0x8000 else v


def cdiv(a: int, b: int) -> int:
    """C integer division: truncates toward zero."""
    q = abs(a) // abs(b)
    return q if (a >= 0) == (b >= 0) else -q


def leading_zeros8(x: int) -> int:
    x &= 0xFF
    if x == 0:
        return 8
    return 8 - x.bit_length()


def from_u8(x: int) -> int:
    lead = leading_zeros8(x)
    if lead == 8:
        return INVALID
    x = (x << (lead + 1)) & 0xFF
    exponent = 7 - lead
    offset = (_LOG_CORR[x] + 1) & 0xFF
    res = (((exponent << 8) | x) << 1) & 0xFFFF
    res += offset >> 1
    return wrap16(res)


def from_u16(x: int) -> int:
    x &= 0xFFFF
    lead = leading_zeros8(x >> 8)
    if lead == 8:
        return from_u8(x)
    x = (x << (lead + 1)) & 0xFFFF
    exponent = 15 - lead
    x >>= 5
    index = (x >> 3) & 0xFF
    offset = _LOG_CORR[index]
    if (x & 7) > 2:
        index = (index + 1) & 0xFF
        offset = (offset + _LOG_CORR[index] + 1) & 0xFF
    else:
        offset = (offset << 1) & 0xFF
    x = ((x + offset) & 0xFFFF) >> 2
    x = (x + (exponent << 9)) & 0xFFFF
    return wrap16(x)


def from_u32(x: int) -> int:
    x &= 0xFFFFFFFF
    if x & 0xFF000000 == 0:
        if x & 0x00FF0000 == 0:
            w, exp_offset = x, 0
        elif x & 0x00F00000 == 0:
            w, exp_offset = x >> 4, 0x0800
        else:
            w, exp_offset = x >> 8, 0x1000
    elif x & 0xF0000000 == 0:
        w, exp_offset = x >> 12, 0x1800
    else:
        w, exp_offset = x >> 16, 0x2000
    return wrap16(from_u16(w & 0xFFFF) + exp_offset)


def to_u16(x: int) -> int:
    if x < 0:
        return 0
    if x >= UINT16_MAX_LOG2:
        return 0xFFFF
    exponent = (x >> 9) & 0xFF
    x = (x & 0x01FF) + 0x200
    index = (x >> 1) & 0xFF
    x <<= 1
    offset = _POW_CORR[index]
    if x & 2:
        index = (index + 1) & 0xFF
        offset = ((offset + _POW_CORR[index]) & 0xFF) >> 1
    x -= offset
    if exponent > 10:
        x <<= exponent - 10
    elif exponent < 10:
        x += 1 if exponent == 9 else 2
        x >>= 10 - exponent
    return x & 0xFFFF


def to_u32(x: int) -> int:
    if x < 0:
        return 0
    if x >= UINT32_MAX_LOG2:
        return 0xFFFFFFFF
    exponent = x >> 9
    if exponent < 0x10:
        return to_u16(x)
    shift = exponent - 0x0F
    res = to_u16(wrap16(x - (shift << 9)))
    return (res << shift) & 0xFFFFFFFF


def square(x: int) -> int:
    if x > 0x4000:
        return MAX
    if x <= -0x4000:
        return MIN
    return wrap16(x + x)


def sqrt(x: int) -> int:
    return cdiv(x, 2)


def pow_div_3(x: int) -> int:
    """x/3 in the log domain (a cube root), with upstream's shift-and-add rounding."""
    xu = (-x if x < 0 else x) & 0xFFFF
    xu //= 2
    xu += xu // 4
    xu += xu // 16
    xu += xu // 256
    xu = ((xu + 1) & 0xFFFF) // 2
    return wrap16(-xu if x < 0 else xu)


def pow_2_div_3(x: int) -> int:
    return wrap16(x - pow_div_3(x))


def pow_3_div_2(x: int) -> int:
    return wrap16(x + cdiv(x, 2))


def shl(x: int, n: int) -> int:
    return wrap16(x + (n << 9))


def shr(x: int, n: int) -> int:
    return wrap16(x - (n << 9))


def const(value: float) -> int:
    """The log2 representation of a constant, rounded like upstream's generator."""
    return round(math.log2(value) * 512)
