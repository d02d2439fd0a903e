"""Read a VCD file back to check the traces we write: pyvcd's tokenizer, or a quick reader of the
scalar-only files the trace writes (the same result, ten times faster)."""

from __future__ import annotations

from dataclasses import dataclass, field

from vcd.reader import TokenKind, tokenize


@dataclass
class Vcd:
    timescale: str = ""
    ids: dict[str, str] = field(default_factory=dict)  # name -> identifier code
    initial: dict[str, int] = field(default_factory=dict)  # identifier -> $dumpvars value
    changes: dict[str, list[tuple[int, int]]] = field(default_factory=dict)  # id -> (t, v)
    times: list[int] = field(default_factory=list)  # every timestamp, in file order
    end: int = 0

    def edges(self, name: str) -> list[tuple[int, int]]:
        return self.changes.get(self.ids[name], [])

    def rising(self, name: str) -> list[int]:
        return [t for t, v in self.edges(name) if v == 1]

    def falling(self, name: str) -> list[int]:
        return [t for t, v in self.edges(name) if v == 0]

    def level_at(self, name: str, t: int) -> int:
        """Level of ``name`` just before time ``t`` (changes at t not yet applied)."""
        level = self.initial.get(self.ids[name], 0)
        for ct, v in self.edges(name):
            if ct >= t:
                break
            level = v
        return level


def read_vcd(path: str) -> Vcd:
    """Quick reader: header keywords, timestamps and scalar changes only."""
    vcd = Vcd()
    now = 0
    with open(path, encoding="ascii") as f:
        words = iter(f.read().split())
    for w in words:
        if w == "$timescale":
            vcd.timescale = " ".join(iter(lambda: next(words), "$end"))
        elif w == "$var":
            _type, _size, ident, name = (next(words) for _ in range(4))
            vcd.ids[name] = ident
            for rest in words:
                if rest == "$end":
                    break
        elif w in ("$comment", "$date", "$version", "$scope"):
            for rest in words:
                if rest == "$end":
                    break
        elif w == "$dumpvars":
            for rest in words:
                if rest == "$end":
                    break
                vcd.initial[rest[1:]] = int(rest[0])
        elif w[0] == "#":
            now = int(w[1:])
            vcd.times.append(now)
            vcd.end = max(vcd.end, now)
        elif w[0] in "01":
            vcd.changes.setdefault(w[1:], []).append((now, int(w[0])))
    return vcd


def read_vcd_pyvcd(path: str) -> Vcd:
    """The same with pyvcd's reader (any VCD)."""
    vcd = Vcd()
    now = 0
    in_dumpvars = False
    with open(path, "rb") as f:
        for tok in tokenize(f):
            kind = tok.kind
            if kind is TokenKind.TIMESCALE:
                vcd.timescale = str(tok.data)
            elif kind is TokenKind.VAR:
                vcd.ids[tok.data.reference] = tok.data.id_code
            elif kind is TokenKind.CHANGE_TIME:
                now = tok.data
                vcd.times.append(now)
                vcd.end = max(vcd.end, now)
            elif kind is TokenKind.DUMPVARS:
                in_dumpvars = True
            elif kind is TokenKind.END:
                in_dumpvars = False
            elif kind is TokenKind.CHANGE_SCALAR:
                value = int(tok.data.value)
                if in_dumpvars:
                    vcd.initial[tok.data.id_code] = value
                else:
                    vcd.changes.setdefault(tok.data.id_code, []).append((now, value))
    return vcd
