"""Does the C firmware say what :mod:`fas.serial.protocol` says?

The wire format is defined once, in :mod:`fas.serial.protocol`: each message's type
byte, fields and size, the flag and feature bits, the frame's figures and the order
of DeviceStatus's counters.  The firmware (``firmware/``) spells the same things in C;
this module reads its sources and lists every place where they differ:

* ``proto.h`` - ``PROTOCOL_VERSION``, ``SEQ_UNSEQUENCED``, ``SEQ_MASK``; a type byte
  ``M_<name>`` for every message (:meth:`Message.c_name`), ``SIZE_<name>`` for every
  device message (``SIZE_IDENT_FIXED``: before the name, ``SIZE_PROGRESS_MAX``: with
  the pulse count); the bits ``E_*``, ``P_*``, ``D_*``, ``F_*``, ``W_*``, ``L_*``,
  ``S_*`` - each of them in both, with the same value;
* ``proto.c`` - the size of every host message (its table, and the Entry rule);
* ``frame.h`` - ``FRAME_OVERHEAD``, ``FRAME_MAX``, ``FRAME_MAX_PAYLOAD``, ``FRAME_SYNC``;
* ``outputs.c`` - the OutputSet flags ``O_*``, the OutputAt flags ``T_*`` and
  ``TIMED_SLOTS``;
* ``device.h`` - ``struct counters``: DeviceStatus's counters in order and width.

``python -m fas.device.proto_check [FIRMWARE_DIR]`` prints the differences (exit 1 if
there are any); the test suite runs the same check.
"""

from __future__ import annotations

import ast
import operator
import re
import sys
from collections.abc import Callable, Iterable
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

from ..serial import protocol
from ..serial.protocol import DEVICE_COUNTERS, Message

FILES = ("proto.h", "proto.c", "frame.h", "outputs.c", "device.h")
FLAG_GROUPS = ("E", "P", "D", "F", "W", "L", "S")  # proto.h's bit and mode groups
OUTPUT_FLAGS = ("O", "T")  # outputs.c's
# proto.h names whose Python constant is named otherwise
ALIASES = {"SEQ_UNSEQUENCED": "UNSEQUENCED"}
# macros of proto.h that are not part of the wire format
NOT_WIRE = {"FW_PROTO_H"}

_DEFINE = re.compile(r"^[ \t]*#[ \t]*define[ \t]+([A-Za-z_]\w*)(\()?[ \t]*([^\n]*?)[ \t]*"
                     r"(?:/\*.*?\*/[ \t]*)?$", re.M)
_SIZE_ENTRY = re.compile(r"\[\s*M_(\w+)\s*-\s*SIZES_FIRST\s*\]\s*=\s*(\w+)")
_ENTRY_RULE = re.compile(r"\(\s*type\s*&\s*(\w+)\s*\)\s*==\s*M_ENTRY\s*\)\s*return\s+(\w+)\s*;")
_COUNTERS = re.compile(r"struct\s+counters\s*\{(.*?)\}", re.S)
_FIELD = re.compile(r"\buint(8|16|32)_t\s+(\w+)\s*;")
_OPS: dict[type, Callable[..., int]] = {
    ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul,
    ast.LShift: operator.lshift, ast.RShift: operator.rshift, ast.BitOr: operator.or_,
    ast.BitAnd: operator.and_, ast.BitXor: operator.xor, ast.USub: operator.neg,
    ast.Invert: operator.invert,
}


@dataclass(frozen=True)
class Sources:
    """The texts of the firmware files the check reads (see :data:`FILES`)."""

    proto_h: str
    proto_c: str
    frame_h: str
    outputs_c: str
    device_h: str

    @classmethod
    def read(cls, firmware: str | Path) -> Sources:
        d = Path(firmware)
        return cls(*((d / name).read_text() for name in FILES))

    def replace(self, **changes: str) -> Sources:
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        values.update(changes)
        return Sources(**values)


def c_int(text: str, macros: dict[str, int]) -> int:
    """The value of a C integer expression of literals and known macros (ValueError:
    not one)."""
    text = re.sub(r"\b(0[xX][0-9a-fA-F]+|\d+)[uUlL]*\b", r"\1", text.strip())

    def value(node: ast.AST) -> int:
        if isinstance(node, ast.Constant) and isinstance(node.value, int):
            return node.value
        if isinstance(node, ast.Name) and node.id in macros:
            return macros[node.id]
        if isinstance(node, ast.BinOp) and type(node.op) in _OPS:
            return _OPS[type(node.op)](value(node.left), value(node.right))
        if isinstance(node, ast.UnaryOp) and type(node.op) in _OPS:
            return _OPS[type(node.op)](value(node.operand))
        raise ValueError(f"not an integer expression: {text!r}")

    try:
        tree = ast.parse(text, mode="eval")
    except SyntaxError as exc:
        raise ValueError(f"not an integer expression: {text!r}") from exc
    return value(tree.body)


def defines(text: str) -> dict[str, int | None]:
    """The object-like macros of a C file by name: their integer value, None for one
    without a value (an include guard) or with a value that is not an integer."""
    out: dict[str, int | None] = {}
    known: dict[str, int] = {}
    for m in _DEFINE.finditer(text):
        name, params, body = m.group(1), m.group(2), m.group(3)
        if params:
            continue  # a function-like macro
        try:
            v: int | None = c_int(body, known) if body else None
        except ValueError:
            v = None
        out[name] = v
        if v is not None:
            known[name] = v
    return out


def _sample(cls: type[Message], **values: Any) -> Message:
    """An instance of ``cls`` with every field zero (or ``values``)."""
    kwargs: dict[str, Any] = {}
    for f in fields(cls):
        kwargs[f.name] = values.get(f.name, "" if f.type in ("str", str) else 0)
    return cls(**kwargs)


def wire_size(cls: type[Message]) -> tuple[str, int]:
    """The size the firmware names for ``cls`` and its value: the whole message; the
    fixed part before Ident's name; Progress with its pulse count."""
    if cls is protocol.Ident:
        return "SIZE_IDENT_FIXED", len(_sample(cls).encode())
    if cls is protocol.Progress:
        return "SIZE_PROGRESS_MAX", len(_sample(cls, flags=protocol.P_HAS_PCNT).encode())
    return f"SIZE_{cls.c_name()}", len(_sample(cls).encode())


def _python_bits(prefixes: Iterable[str]) -> dict[str, int]:
    """The protocol's constants named ``<prefix>_*`` (flag, mode and feature bits)."""
    out = {}
    for name, value in vars(protocol).items():
        head, sep, _ = name.partition("_")
        if sep and head in prefixes and isinstance(value, int) and not isinstance(value, bool):
            out[name] = value
    return out


def _compare(where: str, c: dict[str, int | None], py: dict[str, int],
             problems: list[str]) -> None:
    for name, value in py.items():
        if name not in c:
            problems.append(f"{where}: {name} is missing (protocol.py: {value:#x})")
        elif c[name] != value:
            shown = "no value" if c[name] is None else f"{c[name]:#x}"
            problems.append(f"{where}: {name} is {shown}, protocol.py says {value:#x}")
    for name in c:
        if name not in py:
            problems.append(f"{where}: {name} is not in protocol.py")


def check(src: Sources, messages: Iterable[type[Message]] | None = None) -> list[str]:
    """Every difference between the firmware's sources and the protocol (empty: none);
    ``messages``: the message types to hold it to (default: every registered one)."""
    msgs = list(protocol.message_types() if messages is None else messages)
    problems: list[str] = []
    h = defines(src.proto_h)

    # proto.h: version and sequence bits
    scalars = {c_name: getattr(protocol, ALIASES.get(c_name, c_name))
               for c_name in ("PROTOCOL_VERSION", "SEQ_UNSEQUENCED", "SEQ_MASK")}
    _compare("proto.h", {k: h.get(k) for k in scalars if k in h}, scalars, problems)

    # proto.h: type bytes and device message sizes
    codes = {f"M_{cls.c_name()}": cls.CODE for cls in msgs}
    _compare("proto.h", {k: v for k, v in h.items() if k.startswith("M_")}, codes, problems)
    sizes = dict(wire_size(cls) for cls in msgs if cls.from_device())
    _compare("proto.h", {k: v for k, v in h.items() if k.startswith("SIZE_")}, sizes, problems)

    # proto.h: flag, mode and feature bits
    groups = tuple(g + "_" for g in FLAG_GROUPS)
    _compare("proto.h", {k: v for k, v in h.items() if k.startswith(groups)},
             _python_bits(FLAG_GROUPS), problems)
    known = set(scalars) | set(codes) | set(sizes) | NOT_WIRE
    for name in h:
        if not name.startswith(("M_", "SIZE_", *groups)) and name not in known:
            problems.append(f"proto.h: {name} is not in protocol.py")

    # proto.c: the sizes of the host's messages
    _check_host_sizes(src.proto_c, h, msgs, problems)

    # frame.h, outputs.c
    frame = {"FRAME_OVERHEAD": protocol.FRAME_OVERHEAD, "FRAME_MAX": protocol.MAX_FRAME,
             "FRAME_MAX_PAYLOAD": protocol.MAX_PAYLOAD, "FRAME_SYNC": protocol.SYNC}
    f = defines(src.frame_h)
    _compare("frame.h", {k: v for k, v in f.items() if k in frame or k.startswith("FRAME_")},
             frame, problems)
    o = defines(src.outputs_c)
    _compare("outputs.c", {k: v for k, v in o.items()
                           if k.startswith(("O_", "T_")) or k == "TIMED_SLOTS"},
             {**_python_bits(OUTPUT_FLAGS), "TIMED_SLOTS": protocol.TIMED_SLOTS}, problems)

    # device.h: DeviceStatus's counters
    _check_counters(src.device_h, problems)
    return problems


def _check_host_sizes(proto_c: str, h: dict[str, int | None], msgs: list[type[Message]],
                      problems: list[str]) -> None:
    host = [cls for cls in msgs if not cls.from_device()]
    table = {}
    for name, size in _SIZE_ENTRY.findall(proto_c):
        try:
            table[name] = c_int(size, {})
        except ValueError:
            problems.append(f"proto.c: the size of M_{name} is {size!r}")
    for cls in host:
        size = len(_sample(cls).encode())
        if cls.CODE_HAS_INDEX:
            rule = _ENTRY_RULE.search(proto_c)
            stepper_mask = 0xFF & ~(len(cls.CODES) - 1)
            if cls is not protocol.Entry or rule is None:
                problems.append(f"proto.c: no size rule for M_{cls.c_name()}")
                continue
            mask, n = (c_int(x, {k: v for k, v in h.items() if v is not None})
                       for x in rule.groups())
            if mask != stepper_mask or n != size:
                problems.append(f"proto.c: M_ENTRY is (type & {mask:#x}) with {n} bytes, "
                                f"protocol.py says (type & {stepper_mask:#x}) with {size}")
            continue
        name = cls.c_name()
        if name not in table:
            problems.append(f"proto.c: M_{name} has no size (protocol.py: {size})")
        elif table[name] != size:
            problems.append(f"proto.c: M_{name} has {table[name]} bytes, protocol.py says "
                            f"{size}")
    names = {cls.c_name() for cls in host}
    for name in table:
        if name not in names:
            problems.append(f"proto.c: M_{name} is not a host message of protocol.py")


def _check_counters(device_h: str, problems: list[str]) -> None:
    m = _COUNTERS.search(device_h)
    if m is None:
        problems.append("device.h: no struct counters")
        return
    found = [(name, int(bits)) for bits, name in _FIELD.findall(m.group(1))]
    # DeviceStatus packs the first two counters in 32 bits, the others in 16
    fmt = protocol.DeviceStatus.FMT.format.lstrip("<")[2:]
    widths = {"I": 32, "H": 16}
    wanted = [(name, widths[code]) for name, code in zip(DEVICE_COUNTERS, fmt, strict=True)]
    if found != wanted:
        problems.append("device.h: struct counters is "
                        + ", ".join(f"{n} u{b}" for n, b in found)
                        + "; protocol.py says " + ", ".join(f"{n} u{b}" for n, b in wanted))


def firmware_dir() -> Path:
    """The firmware sources the simavr runner builds (the checkout's or the installed
    package's copy, :func:`fas.device.simavr.firmware_dir`)."""
    from .simavr import firmware_dir as sources

    return sources()


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    problems = check(Sources.read(args[0] if args else firmware_dir()))
    for p in problems:
        print(p)
    if not problems:
        print("firmware and protocol.py agree")
    return 1 if problems else 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
