"""The log2 fixed-point arithmetic the ramp maths runs on."""

import math

from hypothesis import given
from hypothesis import strategies as st

from fas import log2


def test_constants_match_firmware_figures():
    assert log2.const(16_000_000) == 0x2FDD
    assert log2.const(16_000_000 / math.sqrt(2)) == 0x2EDD
    assert log2.const(16_000_000 ** 2 / 2) == 0x5DBA
    assert log2.const(21_000_000) == 0x30A6
    assert log2.const(1.5) == 0x012C


def test_from_u16_example_from_the_representation():
    # 15373 = 0b0011_1100_0000_1101 -> 512*log2(15373) = 7121 (0x1bd1)
    assert log2.from_u16(15373) == 0x1BD1


def test_zero_is_invalid_and_saturation():
    assert log2.from_u32(0) == log2.INVALID
    assert log2.to_u16(-5) == 0
    assert log2.to_u16(log2.UINT16_MAX_LOG2) == 0xFFFF
    assert log2.to_u32(log2.UINT32_MAX_LOG2) == 0xFFFFFFFF
    assert log2.square(0x4001) == log2.MAX
    assert log2.square(-0x4000) == log2.MIN


@given(st.integers(min_value=1, max_value=0xFFFFFFFF))
def test_round_trip_is_within_half_a_percent(x):
    back = log2.to_u32(log2.from_u32(x))
    assert abs(back - x) <= max(2, x * 0.005)


@given(st.integers(min_value=1, max_value=0xFFFFFFFF))
def test_log_value_is_close_to_real_logarithm(x):
    assert abs(log2.from_u32(x) - 512 * math.log2(x)) <= 1.5


def test_cube_root_and_its_square_over_the_whole_range():
    for x in range(-32767, 32768):
        third = log2.pow_div_3(x)
        assert abs(third - x / 3) < 1.7  # shift-and-add approximation of 1/3
        assert log2.pow_2_div_3(x) == log2.wrap16(x - third)


def test_c_semantics_helpers():
    assert log2.cdiv(-5, 2) == -2
    assert log2.sqrt(-5) == -2
    assert log2.wrap16(0x8000) == -0x8000
    assert log2.wrap16(0x18001) == -0x7FFF
