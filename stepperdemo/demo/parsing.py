"""StepperDemo's numbers: the firmware parses them with C ``strtol`` (base 10).

A command's argument is one number (``parse_number``: the whole rest of the command,
empty means 0) or up to three separated by commas (``parse_values``, the firmware's
``get_val1_val2_val3``).  Values saturate at a 32-bit ``long``, as ``strtol`` does.
"""

from __future__ import annotations

LONG_MAX = 2**31 - 1
LONG_MIN = -(2**31)
_WS = b" \t\n\v\f\r"


def strtol(data: bytes) -> tuple[int, int]:
    """C ``strtol(s, &end, 10)`` on a 32-bit long: (value, characters consumed)."""
    i = 0
    n = len(data)
    while i < n and data[i] in _WS:
        i += 1
    neg = False
    if i < n and data[i] in b"+-":
        neg = data[i] == 0x2D
        i += 1
    start = i
    value = 0
    while i < n and 0x30 <= data[i] <= 0x39:
        value = value * 10 + data[i] - 0x30
        i += 1
    if i == start:
        return 0, 0
    if neg:
        value = -value
    value = max(LONG_MIN, min(LONG_MAX, value))
    return value, i


def parse_number(arg: bytes) -> int | None:
    """The whole of ``arg`` as a number (empty means 0, as in the firmware), else None."""
    value, used = strtol(arg)
    if used != len(arg):
        return None
    return value


def parse_values(arg: bytes) -> list[int] | None:
    """``get_val1_val2_val3``: one to three comma-separated numbers, else None."""
    values: list[int] = []
    rest = arg
    for i in range(3):
        value, used = strtol(rest)
        if used == 0:
            return None
        values.append(value)
        rest = rest[used:]
        if not rest:
            return values
        if i < 2:
            if rest[:1] != b",":
                return None
            rest = rest[1:]
    return None
