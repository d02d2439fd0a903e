"""The firmware's ``proto.h``/``proto.c`` (and the frame figures, output flags and
counters it shares) say what :mod:`fas.serial.protocol` says - and the check that
holds them to it fails on any difference (mutated copies of the real sources)."""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass
from typing import ClassVar

import pytest

from fas.device.proto_check import Sources, c_int, check, defines, firmware_dir, main
from fas.serial import protocol
from fas.serial.protocol import Message


@pytest.fixture(scope="module")
def real() -> Sources:
    return Sources.read(firmware_dir())


def _sub(text: str, pattern: str, repl: str) -> str:
    new, n = re.subn(pattern, repl, text, count=1, flags=re.M)
    assert n == 1, f"{pattern!r} not found"
    return new


def test_the_firmware_agrees_with_the_protocol(real: Sources) -> None:
    assert check(real) == []
    assert main([str(firmware_dir())]) == 0


def test_every_message_is_checked(real: Sources) -> None:
    """Each message type of protocol.py has its M_ define; each device message its
    size; each host message (but Entry, by rule) its row in proto.c's table."""
    h = defines(real.proto_h)
    for cls in protocol.message_types():
        assert h[f"M_{cls.c_name()}"] == cls.CODE
    assert h["SIZE_STATUS"] == 17 and h["SIZE_DEVICE_STATUS"] == 48  # docs, section 5
    assert h["SIZE_IDENT_FIXED"] == 25 and h["SIZE_PROGRESS_MAX"] == 6
    assert "[M_HALT - SIZES_FIRST] = 5" in real.proto_c


@pytest.mark.parametrize(("field", "pattern", "repl", "says"), [
    # a type byte, a size, a flag, a feature bit, a mode, the version
    ("proto_h", r"^#define M_HALT 0x10", "#define M_HALT 0x11", "M_HALT is 0x11"),
    ("proto_h", r"^#define SIZE_LIMIT_HIT 12", "#define SIZE_LIMIT_HIT 11",
     "SIZE_LIMIT_HIT is 0xb"),
    ("proto_h", r"^#define E_CONT 0x80", "#define E_CONT 0x08", "E_CONT is 0x8"),
    ("proto_h", r"^#define F_SIM_INPUTS 0x0002", "#define F_SIM_INPUTS 0x0004",
     "F_SIM_INPUTS is 0x4"),
    ("proto_h", r"^#define W_ANALOG 3", "#define W_ANALOG 4", "W_ANALOG is 0x4"),
    ("proto_h", r"^#define PROTOCOL_VERSION 2", "#define PROTOCOL_VERSION 3",
     "PROTOCOL_VERSION is 0x3"),
    # a define gone, one protocol.py does not know
    ("proto_h", r"^#define P_HALTED 0x40.*\n", "", "P_HALTED is missing"),
    ("proto_h", r"^#define M_STARTED 0xA2", "#define M_STARTED 0xA2\n#define M_EXTRA 0xA3",
     "M_EXTRA is not in protocol.py"),
    ("proto_h", r"^#define D_SESSION 0x04", "#define D_SESSION 0x04\n#define D_LATE 0x08",
     "D_LATE is not in protocol.py"),
    # proto.c: a host message's size, its row gone, the Entry rule
    ("proto_c", r"\[M_OUTPUT_PWM - SIZES_FIRST\] = 15", "[M_OUTPUT_PWM - SIZES_FIRST] = 14",
     "M_OUTPUT_PWM has 14 bytes, protocol.py says 15"),
    ("proto_c", r"^\s*\[M_SET_INPUT - SIZES_FIRST\] = 5,\n", "", "M_SET_INPUT has no size"),
    ("proto_c", r"return 5;", "return 4;", "M_ENTRY is (type & 0xf8) with 4 bytes"),
    ("proto_c", r"\(type & 0xF8\)", "(type & 0xF0)", "M_ENTRY is (type & 0xf0)"),
    # frame.h, outputs.c, device.h
    ("frame_h", r"^#define FRAME_MAX 64", "#define FRAME_MAX 72", "FRAME_MAX is 0x48"),
    ("outputs_c", r"^#define O_SYNCHRONIZED 0x02", "#define O_SYNCHRONIZED 0x04",
     "O_SYNCHRONIZED is 0x4"),
    ("device_h", r"uint16_t cuts;\n(\s*)uint16_t cuts_refused;",
     r"uint16_t cuts_refused;\n\1uint16_t cuts;", "device.h: struct counters is"),
    ("device_h", r"uint16_t halts;", "uint32_t halts;", "halts u32"),
])
def test_a_difference_is_found(real: Sources, field: str, pattern: str, repl: str,
                               says: str) -> None:
    mutated = real.replace(**{field: _sub(getattr(real, field), pattern, repl)})
    problems = check(mutated)
    assert any(says in p for p in problems), problems


def test_a_new_python_message_needs_the_firmware(real: Sources) -> None:
    """A message type added to protocol.py but not to the firmware is reported."""

    @dataclass(frozen=True, slots=True)
    class Beep(Message):
        CODE: ClassVar[int] = 0x11
        FMT: ClassVar[struct.Struct] = struct.Struct("<BH")
        pin: int
        ms: int

    problems = check(real, [*protocol.message_types(), Beep])
    assert "proto.h: M_BEEP is missing (protocol.py: 0x11)" in problems
    assert "proto.c: M_BEEP has no size (protocol.py: 4)" in problems


def test_the_command_line_reports_differences(real: Sources, tmp_path, capsys) -> None:
    for name, text in (("proto.h", real.proto_h), ("proto.c", real.proto_c),
                       ("frame.h", real.frame_h), ("outputs.c", real.outputs_c),
                       ("device.h", real.device_h)):
        (tmp_path / name).write_text(text.replace("#define L_UP 0x01", "#define L_UP 0x02"))
    assert main([str(tmp_path)]) == 1
    assert "proto.h: L_UP is 0x2, protocol.py says 0x1" in capsys.readouterr().out


def test_c_expressions() -> None:
    assert c_int("(FRAME_MAX - FRAME_OVERHEAD)", {"FRAME_MAX": 64, "FRAME_OVERHEAD": 5}) == 59
    assert c_int("0x7FUL", {}) == 0x7F and c_int("1u << 3", {}) == 8
    with pytest.raises(ValueError):
        c_int("sizeof(int)", {})
    assert defines("#define A 3  /* three */\n#define B (A | 0x10)\n#define F(x) x\n"
                   "#define GUARD\n") == {"A": 3, "B": 0x13, "GUARD": None}
