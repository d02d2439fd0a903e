"""Grbl 1.1's receive path, byte by byte (no clock, no I/O).

Three stages, as Grbl has them (its ``serial.c`` receive interrupt, its 128-byte ring
and the line assembly of ``protocol.c``):

1. :meth:`GrblReceiver.receive` classifies every byte the moment it arrives: the real-time
   commands (``?`` ``!`` ``~`` Ctrl-X and 0x84 0x85 0x90-0x9D 0x9E 0xA0 0xA1) are returned to the
   caller in arrival order and never stored - wherever they sit, mid-line or in a comment;
   any other byte >= 0x80 is dropped; the rest goes into the receive ring (128 bytes), and a
   byte that does not fit is dropped and counted (Grbl drops it silently).
2. The ring: :attr:`free` is what ``Bf:`` reports as free bytes.
3. :meth:`GrblReceiver.take_line` is called whenever the parser is free to read: it moves
   characters out of the ring into the line being assembled - dropping whitespace and control
   characters, ``/``, ``(...)`` and ``;`` comments (an unclosed ``(`` just ends at the line
   end), upper-casing letters, flagging an overflow past ``line_max`` characters - and returns
   the line once a line end is read.  The characters of a line leave the ring as they are read,
   so a line that then waits (queue full, a synchronized output, a dwell) no longer counts
   against the ring: Grbl's capacity is the ring plus the line being executed.  CR, LF and
   CR LF each end one line (FluidNC; Grbl AVR would answer an extra ``ok`` for the LF).
"""

from __future__ import annotations

from dataclasses import dataclass

RX_SIZE = 128  # Grbl's RX_BUFFER_SIZE (what character-counting senders count against)
LINE_MAX = 255  # characters kept per line after filtering (Grbl_ESP32/FluidNC; Grbl AVR: 79)

RESET = 0x18
STATUS = 0x3F  # ?
HOLD = 0x21  # !
RESUME = 0x7E  # ~
DOOR = 0x84
JOG_CANCEL = 0x85
FEED_100, FEED_PLUS_10, FEED_MINUS_10, FEED_PLUS_1, FEED_MINUS_1 = 0x90, 0x91, 0x92, 0x93, 0x94
RAPID_100, RAPID_50, RAPID_25 = 0x95, 0x96, 0x97
SPINDLE_100, SPINDLE_PLUS_10, SPINDLE_MINUS_10, SPINDLE_PLUS_1, SPINDLE_MINUS_1 = (
    0x99, 0x9A, 0x9B, 0x9C, 0x9D)
SPINDLE_STOP = 0x9E
FLOOD_TOGGLE = 0xA0
MIST_TOGGLE = 0xA1
REALTIME = frozenset({RESET, STATUS, HOLD, RESUME, DOOR, JOG_CANCEL,
                      *range(FEED_100, RAPID_25 + 1), *range(SPINDLE_100, SPINDLE_STOP + 1),
                      FLOOD_TOGGLE, MIST_TOGGLE})

_CR, _LF = 0x0D, 0x0A
#: bytes that ``receive`` does not simply store: the real-time commands and >= 0x80
_NOT_STORED = bytes(sorted(REALTIME | set(range(0x80, 0x100))))
#: what line assembly drops (up to the space, '/') and its upper-casing of a-z
_DROP = bytes(range(0x21)) + b"/"
_UPPER = bytes(c - 0x20 if 0x61 <= c <= 0x7A else c for c in range(256))


@dataclass(frozen=True)
class RxLine:
    """A complete input line as the parser sees it."""

    text: str  # filtered: no spaces, comments or '/', letters upper case
    overflow: bool  # longer than line_max after filtering: answered error:11, not executed


class GrblReceiver:
    """The receive ring and line assembly of one host connection (see the module text)."""

    def __init__(self, ring_size: int = RX_SIZE, line_max: int = LINE_MAX) -> None:
        self.ring_size = ring_size
        self.line_max = line_max
        self.dropped = 0  # bytes lost because the ring was full
        self.dropped_high = 0  # bytes >= 0x80 that are no real-time command
        self.reset()

    def reset(self) -> None:
        """A soft reset: what was received and not yet parsed is gone."""
        self._ring = bytearray()  # (a bytearray: a line is found and cut at once)
        #: the same ring, to read (hot paths take its length without a call)
        self.ring = self._ring
        self._line = bytearray()
        self._overflow = False
        self._comment: int | None = None  # "(" or ";" while inside a comment
        self._last_cr = False

    @property
    def free(self) -> int:
        """Free bytes of the ring (the second number of ``Bf:``)."""
        return self.ring_size - len(self._ring)

    @property
    def pending(self) -> int:
        """Bytes in the ring not yet read by the parser."""
        return len(self._ring)

    @property
    def partial(self) -> str:
        """The line begun and not ended yet (what the host sent after its last line end)."""
        ring = bytes(self._ring)
        cut = max(ring.rfind(b"\n"), ring.rfind(b"\r"))
        if cut >= 0:
            return ring[cut + 1:].decode("ascii", "replace").strip()
        return (self._line.decode("ascii") + ring.decode("ascii", "replace")).strip()

    def receive(self, data: bytes) -> list[int]:
        """Take bytes from the host; return the real-time commands among them, in order."""
        ring = self._ring
        if (isinstance(data, (bytes, bytearray))  # the common case: bytes to store
                and len(data.translate(None, _NOT_STORED)) == len(data)):
            room = self.ring_size - len(ring)
            if len(data) <= room:
                ring.extend(data)
            else:
                ring.extend(data[:max(room, 0)])
                self.dropped += len(data) - max(room, 0)
            return []
        commands = []
        for b in data:
            if b in REALTIME:
                commands.append(b)
            elif b >= 0x80:
                self.dropped_high += 1
            elif len(ring) < self.ring_size:
                ring.append(b)
            else:
                self.dropped += 1
        return commands

    def take_line(self) -> RxLine | None:
        """Read from the ring up to the next line end; None while no line is complete
        (the characters read so far stay in the line being assembled)."""
        ring = self._ring
        if ring and self._comment is None:
            line = self._whole_line(ring)
            if line is not None:
                return line
        while ring:
            c = ring.pop(0)
            if c in (_CR, _LF):
                if c == _LF and self._last_cr:
                    self._last_cr = False
                    continue  # CR LF is one line end
                self._last_cr = c == _CR
                line = RxLine(self._line.decode("ascii"), self._overflow)
                self._line.clear()
                self._overflow = False
                self._comment = None
                return line
            self._last_cr = False
            if self._comment is not None:
                if self._comment == 0x28 and c == 0x29:  # ( ... )
                    self._comment = None
                continue
            if c <= 0x20 or c == 0x2F:  # spaces, control characters, '/' (block delete)
                continue
            if c in (0x28, 0x3B):  # '(' or ';'
                self._comment = c
            elif len(self._line) >= self.line_max:
                self._overflow = True
            else:
                self._line.append(c - 0x20 if 0x61 <= c <= 0x7A else c)
        return None

    def _whole_line(self, ring: bytearray) -> RxLine | None:
        """:meth:`take_line` at once for a line whose end is in the ring and which has
        no comment (what the byte loop makes of it); None: the byte loop's case."""
        cr, lf = ring.find(b"\r"), ring.find(b"\n")
        end = cr if lf < 0 or 0 <= cr < lf else lf
        if end < 0 or (self._last_cr and ring[0] == _LF):
            return None
        chunk = ring[:end]  # (a copy)
        if b"(" in chunk or b";" in chunk:
            return None
        kept = chunk.translate(_UPPER, _DROP)
        room = self.line_max - len(self._line)
        if len(kept) > room:
            self._overflow = True
            kept = kept[:max(room, 0)]
        self._last_cr = ring[end] == _CR
        del ring[:end + 1]
        if self._line:
            self._line += kept
            kept = self._line
        line = RxLine(kept.decode("ascii"), self._overflow)
        self._line.clear()
        self._overflow = False
        self._comment = None
        return line
