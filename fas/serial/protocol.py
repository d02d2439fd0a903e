"""The wire format of the serial backend: frames, CRC-16 and messages.

A frame is ``LEN SEQ PAYLOAD... CRC_HI CRC_LO SYNC``:

* ``LEN`` - the whole frame's length in bytes (5 .. :data:`MAX_FRAME`);
* ``SEQ`` - host to device: bit 7 marks an *unsequenced* frame (handled on arrival,
  never acknowledged), bits 0-6 the sequence number; device to host: the
  acknowledgement, i.e. the next sequence number the device expects;
* ``PAYLOAD`` - zero or more messages, each starting with its type byte;
* ``CRC`` - CRC-16/CCITT-FALSE over ``LEN SEQ PAYLOAD``, high byte first;
* ``SYNC`` - 0x7E.  After any error the receiver drops bytes up to and including
  the next 0x7E and expects a frame to begin right after it.

Multi-byte fields are little-endian.  docs/serial-protocol.md is the specification;
this module is its one implementation on the host side and in the simulated device.
"""

from __future__ import annotations

import re
import struct
from dataclasses import Field, astuple, dataclass
from typing import Any, ClassVar, cast

PROTOCOL_VERSION = 2
SYNC = 0x7E
FRAME_OVERHEAD = 5  # LEN, SEQ, CRC (2), SYNC
MAX_FRAME = 64
MAX_PAYLOAD = MAX_FRAME - FRAME_OVERHEAD
SEQ_MOD = 128
SEQ_MASK = 0x7F
UNSEQUENCED = 0x80
MAX_STEPPERS = 8
MAX_RX_SLOTS = 16  # the Nak's bitmap of held frames has 16 bits
DEVICE_CODES_FIRST = 0x50  # type bytes from here on: device -> host (section 5)


class ProtocolError(ValueError):
    """A payload that passed its CRC but does not parse as messages."""


# ------------------------------------------------------------------------ CRC-16
def _crc_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x1021) if crc & 0x8000 else (crc << 1)
        table.append(crc & 0xFFFF)
    return tuple(table)


_CRC_TABLE = _crc_table()


def crc16(data: bytes | bytearray | memoryview, crc: int = 0xFFFF) -> int:
    """CRC-16/CCITT-FALSE: polynomial 0x1021, initial value 0xFFFF, no reflection."""
    table = _CRC_TABLE
    for b in data:
        crc = ((crc << 8) & 0xFFFF) ^ table[(crc >> 8) ^ b]
    return crc


# ------------------------------------------------------------------------ frames
def encode_frame(seq: int, payload: bytes) -> bytes:
    """One frame around ``payload`` (``seq`` already carries the unsequenced bit)."""
    n = len(payload) + FRAME_OVERHEAD
    if n > MAX_FRAME:
        raise ValueError(f"payload of {len(payload)} bytes exceeds {MAX_PAYLOAD}")
    body = bytes((n, seq & 0xFF)) + payload
    crc = crc16(body)
    return body + bytes((crc >> 8, crc & 0xFF, SYNC))


class FrameDecoder:
    """Cuts a byte stream into checked frames; counts and skips everything else."""

    __slots__ = ("_buf", "crc_errors", "discarded_bytes", "frames", "framing_errors")

    def __init__(self) -> None:
        self._buf = bytearray()
        self.frames = 0
        self.crc_errors = 0  # frames whose CRC did not match
        self.framing_errors = 0  # impossible length byte or no SYNC where the frame ends
        self.discarded_bytes = 0

    def reset(self) -> None:
        self._buf.clear()

    def feed(self, data: bytes) -> list[tuple[int, bytes]]:
        """Take received bytes; return the complete valid frames as ``(seq, payload)``."""
        buf = self._buf
        buf += data
        out: list[tuple[int, bytes]] = []
        pos = 0
        end = len(buf)
        while pos < end:
            n = buf[pos]
            if n < FRAME_OVERHEAD or n > MAX_FRAME:
                self.framing_errors += 1
                pos = self._resync(pos)
                continue
            if end - pos < n:
                break
            if buf[pos + n - 1] != SYNC:
                self.framing_errors += 1
                pos = self._resync(pos)
                continue
            crc = (buf[pos + n - 3] << 8) | buf[pos + n - 2]
            if crc16(memoryview(buf)[pos:pos + n - 3]) != crc:
                self.crc_errors += 1
                pos = self._resync(pos)
                continue
            out.append((buf[pos + 1], bytes(buf[pos + 2:pos + n - 3])))
            self.frames += 1
            pos += n
        del buf[:pos]
        return out

    def _resync(self, pos: int) -> int:
        """Drop bytes up to and including the next SYNC after ``pos``."""
        buf = self._buf
        nxt = buf.find(SYNC, pos)
        new = len(buf) if nxt < 0 else nxt + 1
        self.discarded_bytes += new - pos
        return new


def seq_diff(a: int, b: int) -> int:
    """``a - b`` in sequence space, in -64 .. 63."""
    return ((a - b + SEQ_MOD // 2) % SEQ_MOD) - SEQ_MOD // 2


def tick_diff32(a: int, b: int) -> int:
    """``a - b`` of two 32-bit tick counter values, as a signed number."""
    return ((a - b + 0x80000000) & 0xFFFFFFFF) - 0x80000000


# ---------------------------------------------------------------------- messages
class Message:
    """A message with fixed fields packed by ``FMT`` (little-endian) after its code.

    A new message type is one subclass with ``CODE`` (see the type table in
    docs/serial-protocol.md, section 5) and ``FMT``, decorated with :func:`register`;
    ``UNSEQUENCED`` marks host messages that travel outside the sequence (section 4).
    This is the one definition of the wire format: the Python device and the host use
    it, and :mod:`fas.device.proto_check` holds the firmware's ``proto.h`` to it - there
    the type is ``M_<C_NAME>`` and its size ``SIZE_<C_NAME>`` (device messages).
    """

    CODE: ClassVar[int]
    FMT: ClassVar[struct.Struct]
    __dataclass_fields__: ClassVar[dict[str, Field[Any]]]  # each type is a dataclass
    UNSEQUENCED: ClassVar[bool] = False
    CODES: ClassVar[tuple[int, ...]] = ()  # every type byte it owns (default: CODE)
    CODE_HAS_INDEX: ClassVar[bool] = False  # the type byte carries the stepper (0x40|s)
    C_NAME: ClassVar[str] = ""  # the firmware's name (default: the class name, UPPER_SNAKE)

    @classmethod
    def from_device(cls) -> bool:
        """A device -> host message (else host -> device)."""
        return cls.CODE >= DEVICE_CODES_FIRST

    @classmethod
    def c_name(cls) -> str:
        """The type's name in the firmware: ``M_<c_name>`` (``EmergencyStop``: ESTOP)."""
        return cls.C_NAME or re.sub(r"(?<!^)(?=[A-Z])", "_", cls.__name__).upper()

    def encode(self) -> bytes:
        return bytes((self.CODE,)) + self.FMT.pack(*astuple(self))

    @classmethod
    def decode(cls, data: bytes, pos: int) -> tuple[Message, int]:
        """Decode the fields at ``pos`` (after the type byte, or at it when
        ``CODE_HAS_INDEX``); returns the message and the position after it."""
        size = cls.FMT.size
        if pos + size > len(data):
            raise ProtocolError(f"{cls.__name__}: truncated")
        return cls(*cls.FMT.unpack_from(data, pos)), pos + size


_BY_CODE: dict[int, type[Message]] = {}


def register(cls: type[Message]) -> type[Message]:
    """Class decorator: make ``cls`` known to :func:`decode_messages` under its codes."""
    for code in cls.CODES or (cls.CODE,):
        other = _BY_CODE.get(code)
        if other is not None and other is not cls:
            raise ValueError(f"message type 0x{code:02x} is taken by {other.__name__}")
        _BY_CODE[code] = cls
    return cls


def _fmt(spec: str) -> struct.Struct:
    return struct.Struct("<" + spec)


# --- host -> device -------------------------------------------------------------
@register
@dataclass(frozen=True, slots=True)
class Hello(Message):
    """Open a session (unsequenced).  A new nonce resets the device's session."""

    CODE: ClassVar[int] = 0x01
    FMT: ClassVar[struct.Struct] = _fmt("BHHB")
    UNSEQUENCED: ClassVar[bool] = True
    version: int
    nonce: int
    watchdog_ms: int
    report_ms: int


@register
@dataclass(frozen=True, slots=True)
class SyncRequest(Message):
    """Clock sample and heartbeat (unsequenced): the device answers :class:`SyncReply`."""

    CODE: ClassVar[int] = 0x02
    FMT: ClassVar[struct.Struct] = _fmt("I")
    UNSEQUENCED: ClassVar[bool] = True
    stamp: int


@register
@dataclass(frozen=True, slots=True)
class Config(Message):
    """(Re)initialise one stepper's queue: stopped, empty at ``index``, end at ``end_pos``."""

    CODE: ClassVar[int] = 0x03
    FMT: ClassVar[struct.Struct] = _fmt("BBBBi")
    stepper: int
    step_pin: int
    dir_pin: int
    index: int
    end_pos: int


@register
@dataclass(frozen=True, slots=True)
class DirPin(Message):
    CODE: ClassVar[int] = 0x04
    FMT: ClassVar[struct.Struct] = _fmt("BB")
    stepper: int
    dir_pin: int


@register
@dataclass(frozen=True, slots=True)
class Truncate(Message):
    """Drop the queue's entries from ``index`` on, if none of them has begun (a cut)."""

    CODE: ClassVar[int] = 0x05
    FMT: ClassVar[struct.Struct] = _fmt("BB")
    stepper: int
    index: int


@register
@dataclass(frozen=True, slots=True)
class Start(Message):
    """Start the queues in ``mask`` at device tick ``at`` (32-bit; past: at once)."""

    CODE: ClassVar[int] = 0x06
    FMT: ClassVar[struct.Struct] = _fmt("BI")
    mask: int
    at: int


@register
@dataclass(frozen=True, slots=True)
class ForceStop(Message):
    """Stop at once and drop the queue; read and write index become ``index``.

    ``stop_id`` names the stop: the :class:`Halt` that went ahead of it with the same
    id is done, a late copy of it is ignored."""

    CODE: ClassVar[int] = 0x07
    FMT: ClassVar[struct.Struct] = _fmt("BBB")
    stepper: int
    index: int
    stop_id: int = 0


@register
@dataclass(frozen=True, slots=True)
class SetEndPos(Message):
    """Renumber the queue's positions so that the queue ends at ``pos``."""

    CODE: ClassVar[int] = 0x08
    FMT: ClassVar[struct.Struct] = _fmt("Bi")
    stepper: int
    pos: int


@register
@dataclass(frozen=True, slots=True)
class Pin(Message):
    CODE: ClassVar[int] = 0x09
    FMT: ClassVar[struct.Struct] = _fmt("BB")
    pin: int
    level: int


@register
@dataclass(frozen=True, slots=True)
class Detach(Message):
    CODE: ClassVar[int] = 0x0A
    FMT: ClassVar[struct.Struct] = _fmt("BB")
    stepper: int
    detached: int


@register
@dataclass(frozen=True, slots=True)
class PcntAttach(Message):
    CODE: ClassVar[int] = 0x0B
    FMT: ClassVar[struct.Struct] = _fmt("BhhBh")
    stepper: int
    low: int
    high: int
    dir_high_counts_up: int
    value: int


@register
@dataclass(frozen=True, slots=True)
class PcntClear(Message):
    CODE: ClassVar[int] = 0x0C
    FMT: ClassVar[struct.Struct] = _fmt("B")
    stepper: int


@register
@dataclass(frozen=True, slots=True)
class StatusRequest(Message):
    """Ask for :class:`Status` of every stepper and :class:`DeviceStatus` (unsequenced)."""

    CODE: ClassVar[int] = 0x0D
    FMT: ClassVar[struct.Struct] = _fmt("")
    UNSEQUENCED: ClassVar[bool] = True


@register
@dataclass(frozen=True, slots=True)
class EmergencyStop(Message):
    """Stop every queue at once and refuse motion until the next Hello (unsequenced).

    ``nonce``: the session it is meant for (0: whatever session), so that a late copy
    cannot stop the next session."""

    CODE: ClassVar[int] = 0x0E
    FMT: ClassVar[struct.Struct] = _fmt("H")
    UNSEQUENCED: ClassVar[bool] = True
    C_NAME: ClassVar[str] = "ESTOP"
    nonce: int = 0


@register
@dataclass(frozen=True, slots=True)
class Bye(Message):
    """The host ends its session (unsequenced): motion stops, no watchdog trip counted."""

    CODE: ClassVar[int] = 0x0F
    FMT: ClassVar[struct.Struct] = _fmt("H")
    UNSEQUENCED: ClassVar[bool] = True
    nonce: int


@register
@dataclass(frozen=True, slots=True)
class Halt(Message):
    """Stop one stepper at once, ahead of the queue (unsequenced; X and force stops).

    The device discards that stepper's entries, starts and cuts until the sequenced
    :class:`ForceStop` with the same ``stop_id`` arrives; a copy of a Halt whose id
    the device has already seen does nothing.  ``nonce`` names the session."""

    CODE: ClassVar[int] = 0x10
    FMT: ClassVar[struct.Struct] = _fmt("BBH")
    UNSEQUENCED: ClassVar[bool] = True
    stepper: int
    stop_id: int
    nonce: int


ENTRY_BASE = 0x40  # 0x40 | stepper
E_INDEX_MASK = 0x0F  # Entry flags: the low bits of the entry's write index
E_TOGGLE_DIR = 0x10
E_DIR_LEVEL = 0x20
E_COUNT_UP = 0x40
E_CONT = 0x80


@register
@dataclass(frozen=True, slots=True)
class Entry(Message):
    """One queue command: ``steps`` pulses ``ticks`` apart (5 bytes on the wire).

    ``index`` is the entry's write index (mod 256; 4 bits travel) for the device's
    own check against lost and repeated commands.  ``cont``: the host sent it as the
    continuation of a running queue - a device whose queue already ran dry restarts
    it at once (and counts an underrun).
    """

    CODE: ClassVar[int] = ENTRY_BASE
    CODES: ClassVar[tuple[int, ...]] = tuple(ENTRY_BASE | s for s in range(MAX_STEPPERS))
    CODE_HAS_INDEX: ClassVar[bool] = True
    stepper: int
    index: int
    steps: int
    ticks: int
    toggle_dir: bool
    dir_level: bool
    count_up: bool
    cont: bool

    def encode(self) -> bytes:
        flags = (self.index & E_INDEX_MASK) | (E_TOGGLE_DIR if self.toggle_dir else 0) \
            | (E_DIR_LEVEL if self.dir_level else 0) | (E_COUNT_UP if self.count_up else 0) \
            | (E_CONT if self.cont else 0)
        return bytes((ENTRY_BASE | self.stepper, flags, self.steps,
                      self.ticks & 0xFF, self.ticks >> 8))

    @classmethod
    def decode(cls, data: bytes, pos: int) -> tuple[Message, int]:
        if pos + 5 > len(data):
            raise ProtocolError("Entry: truncated")
        code, flags, steps, lo, hi = data[pos:pos + 5]
        return cls(code & 0x07, flags & E_INDEX_MASK, steps, lo | (hi << 8),
                   bool(flags & E_TOGGLE_DIR),
                   bool(flags & E_DIR_LEVEL), bool(flags & E_COUNT_UP),
                   bool(flags & E_CONT)), pos + 5


# --- device -> host -------------------------------------------------------------
@register
@dataclass(frozen=True, slots=True)
class Ident(Message):
    """The device's answer to Hello: its profile, clock, queue depth and receive slots."""

    CODE: ClassVar[int] = 0x81
    FMT: ClassVar[struct.Struct] = _fmt("BHHIIBBBBHHH")
    version: int
    nonce: int
    boot_id: int
    ticks_per_s: int
    clock_hz: int  # rate of the tick counter per host-clock second (differs when sped up)
    max_steppers: int
    queue_len: int  # entries of each queue ring (a power of two, 16 .. 128)
    rx_slots: int  # out-of-order frames the device holds (the host sends rx_slots + 1)
    slot_payload: int  # the largest payload of a host frame
    watchdog_ms: int
    min_cmd_ticks_div: int  # ticks_per_s // min_cmd_ticks (a cross-check of the profile)
    features: int = 0  # bit per optional message family the device understands
    name: str = ""

    def encode(self) -> bytes:
        fields = astuple(self)[:-1]
        raw = self.name.encode("ascii")[:24]
        return bytes((self.CODE,)) + self.FMT.pack(*fields) + bytes((len(raw),)) + raw

    @classmethod
    def decode(cls, data: bytes, pos: int) -> tuple[Message, int]:
        size = cls.FMT.size
        if pos + size + 1 > len(data):
            raise ProtocolError("Ident: truncated")
        fields = cls.FMT.unpack_from(data, pos)
        n = data[pos + size]
        start = pos + size + 1
        if start + n > len(data):
            raise ProtocolError("Ident: truncated name")
        name = data[start:start + n].decode("ascii", "replace")
        return cast(Any, cls)(*fields, name=name), start + n


@register
@dataclass(frozen=True, slots=True)
class SyncReply(Message):
    CODE: ClassVar[int] = 0x82
    FMT: ClassVar[struct.Struct] = _fmt("II")
    stamp: int
    device_tick: int


PROGRESS_BASE = 0x50  # 0x50 | stepper
P_RUNNING = 0x01
P_HAS_ENTRY = 0x02
P_HAS_PCNT = 0x04
P_START_PENDING = 0x08
P_DETACHED = 0x10
P_CUT_REFUSED = 0x20  # a Truncate came too late: entries, starts, SetEndPos are dropped
P_HALTED = 0x40  # a Halt stopped the queue; it waits for its ForceStop


@register
@dataclass(frozen=True, slots=True)
class Progress(Message):
    """A stepper's queue state: read index, steps left of the entry at it, flags."""

    CODE: ClassVar[int] = PROGRESS_BASE
    CODES: ClassVar[tuple[int, ...]] = tuple(PROGRESS_BASE | s for s in range(MAX_STEPPERS))
    CODE_HAS_INDEX: ClassVar[bool] = True
    stepper: int
    flags: int
    index: int
    steps_left: int
    pcnt: int = 0

    def encode(self) -> bytes:
        out = bytes((PROGRESS_BASE | self.stepper, self.flags, self.index, self.steps_left))
        if self.flags & P_HAS_PCNT:
            out += struct.pack("<h", self.pcnt)
        return out

    @classmethod
    def decode(cls, data: bytes, pos: int) -> tuple[Message, int]:
        if pos + 4 > len(data):
            raise ProtocolError("Progress: truncated")
        code, flags, index, steps = data[pos:pos + 4]
        pos += 4
        pcnt = 0
        if flags & P_HAS_PCNT:
            if pos + 2 > len(data):
                raise ProtocolError("Progress: truncated counter")
            (pcnt,) = struct.unpack_from("<h", data, pos)
            pos += 2
        return cls(code & 0x07, flags, index, steps, pcnt), pos

    @property
    def running(self) -> bool:
        return bool(self.flags & (P_RUNNING | P_START_PENDING))

    @property
    def has_entry(self) -> bool:
        return bool(self.flags & P_HAS_ENTRY)


@register
@dataclass(frozen=True, slots=True)
class Status(Message):
    """A stepper in full: queue state as :class:`Progress` plus position and counters."""

    CODE: ClassVar[int] = 0x84
    FMT: ClassVar[struct.Struct] = _fmt("BBBBiIHh")
    stepper: int
    flags: int
    index: int
    steps_left: int
    position: int
    pulses: int
    underruns: int
    pcnt: int

    def progress(self) -> Progress:
        return Progress(self.stepper, self.flags, self.index, self.steps_left, self.pcnt)


D_WATCHDOG = 0x01  # motion stopped by the host-silence watchdog
D_ESTOP = 0x02  # motion stopped by an emergency stop
D_SESSION = 0x04  # a host session is open

DEVICE_COUNTERS = ("frames_ok", "entries", "frames_duplicate", "frames_out_of_order",
                   "crc_errors", "framing_errors", "entries_lost", "entries_duplicated",
                   "overflows", "underruns", "late_starts", "watchdog_trips", "rejected",
                   "tx_dropped", "frames_held", "cuts", "cuts_refused", "halts", "discarded")


@register
@dataclass(frozen=True, slots=True)
class DeviceStatus(Message):
    """Device-wide state and counters (wrapping: 32 bits for the first two, else 16)."""

    CODE: ClassVar[int] = 0x85
    FMT: ClassVar[struct.Struct] = _fmt("IBII" + "H" * (len(DEVICE_COUNTERS) - 2))
    tick: int
    state: int
    frames_ok: int
    entries: int
    frames_duplicate: int
    frames_out_of_order: int
    crc_errors: int
    framing_errors: int
    entries_lost: int
    entries_duplicated: int
    overflows: int
    underruns: int
    late_starts: int
    watchdog_trips: int
    rejected: int
    tx_dropped: int
    frames_held: int
    cuts: int
    cuts_refused: int
    halts: int
    discarded: int

    def counters(self) -> dict[str, int]:
        return {name: getattr(self, name) for name in DEVICE_COUNTERS}


@register
@dataclass(frozen=True, slots=True)
class Nak(Message):
    """Frames are missing: the device expects ``expected`` and holds the frames
    ``expected + 1 + i`` for every bit ``i`` set in ``held`` - resend only the others."""

    CODE: ClassVar[int] = 0x86
    FMT: ClassVar[struct.Struct] = _fmt("BH")
    expected: int
    held: int = 0


# --- user outputs (issue 12; docs/serial-protocol.md section 16) -----------------
O_ANALOG = 0x01  # OutputSet flags: an analog (PWM) output, value = duty count
O_SYNCHRONIZED = 0x02  # made when every queue has executed every entry received before


@register
@dataclass(frozen=True, slots=True)
class OutputPwm(Message):
    """(Re)start the PWM timer of analog output ``number`` on ``pin`` at once: periods of
    ``counts`` counts of ``clock_div`` timer clocks (the profile's rule), duty ``count``."""

    CODE: ClassVar[int] = 0x20
    FMT: ClassVar[struct.Struct] = _fmt("BBIII")
    number: int
    pin: int
    clock_div: int
    counts: int
    count: int


@register
@dataclass(frozen=True, slots=True)
class OutputSet(Message):
    """Set a user output: digital ``value`` 0/1, analog ``value`` = duty count; at once, or
    (``O_SYNCHRONIZED``) after the motion of every entry received before it."""

    CODE: ClassVar[int] = 0x21
    FMT: ClassVar[struct.Struct] = _fmt("BBBI")
    flags: int
    number: int
    pin: int
    value: int

    @property
    def analog(self) -> bool:
        return bool(self.flags & O_ANALOG)

    @property
    def synchronized(self) -> bool:
        return bool(self.flags & O_SYNCHRONIZED)


@register
@dataclass(frozen=True, slots=True)
class OutputCancel(Message):
    """Drop the synchronized output changes not made yet (an alarm on the host)."""

    CODE: ClassVar[int] = 0x22
    FMT: ClassVar[struct.Struct] = _fmt("")


T_CANCEL = 0x80  # OutputAt flags: drop every timed change not made yet (other fields unused)
TIMED_SLOTS = 8  # timed changes a device holds waiting for their tick (section 16)


@register
@dataclass(frozen=True, slots=True)
class OutputAt(Message):
    """A timed output change: ``value`` as in :class:`OutputSet` (flags ``O_ANALOG``),
    made at device tick ``at`` by the device's clock (a tick already past: at once);
    ``T_CANCEL``: drop the timed changes not made yet.  Only to a device with
    ``F_TIMED_OUTPUTS``; it holds up to ``TIMED_SLOTS``."""

    CODE: ClassVar[int] = 0x23
    FMT: ClassVar[struct.Struct] = _fmt("BBBII")
    flags: int
    number: int
    pin: int
    value: int
    at: int

    @property
    def analog(self) -> bool:
        return bool(self.flags & O_ANALOG)


@register
@dataclass(frozen=True, slots=True)
class OutputNext(Message):
    """The next timed output change of the output the previous :class:`OutputAt` or
    ``OutputNext`` of the session named (its flags and pin): ``value`` made at device
    tick ``that one's at + after`` - 5 bytes instead of 12, so that a dense run of
    changes (the laser's power while the path decelerates) fits a 115 200-baud line.
    Only to a device with ``F_TIMED_OUTPUTS``; with no timed change before it in the
    session the device refuses it (section 16)."""

    CODE: ClassVar[int] = 0x24
    FMT: ClassVar[struct.Struct] = _fmt("HH")
    value: int
    after: int


@register
@dataclass(frozen=True, slots=True)
class PwmGrid(Message):
    """The PWM periods of ``pin`` on the device clock (after an OutputPwm, a device with
    ``F_TIMED_OUTPUTS``): they begin at ``origin + k * period`` (mod 2^32);
    ``period`` 0: not a whole number of ticks (no grid).  A timed change at ``at``
    shows from the period after the one that contains ``at``, so of the changes that
    fall in one period only the last shows: the host need not send the others."""

    CODE: ClassVar[int] = 0x87
    FMT: ClassVar[struct.Struct] = _fmt("BII")
    pin: int
    origin: int
    period: int


# --- inputs and limit switches (issue 13; docs/serial-protocol.md section 18) -------
W_OFF = 0  # WatchInput.mode: stop watching the pin
W_DIGITAL = 1  # digital input, no pull-up
W_PULLUP = 2  # digital input with the pull-up resistor
W_ANALOG = 3  # analog input, 0..1023
L_UP = 0x01  # Limit.flags: the limit stops steps that count up (else down)
L_CLEAR = 0x80  # ... remove the limit of that direction
S_ANALOG = 0x01  # SetInput.flags: a pot's value 0..1023 (else a level 0/1)
# Ident.features: the optional message families a device understands (section 5)
F_INPUTS = 0x0001  # section 18: WatchInput, Limit; Input, LimitHit, Started
F_SIM_INPUTS = 0x0002  # SetInput: the device's inputs are a simulation's (section 18)
F_TIMED_OUTPUTS = 0x0004  # OutputAt: timed output changes (section 16)


@register
@dataclass(frozen=True, slots=True)
class WatchInput(Message):
    """Read ``pin`` as an input and report it (:class:`Input`): ``mode`` W_*;
    analog inputs are sampled every ``period_ms`` (0: 50 ms)."""

    CODE: ClassVar[int] = 0x30
    FMT: ClassVar[struct.Struct] = _fmt("BBB")
    pin: int
    mode: int
    period_ms: int


@register
@dataclass(frozen=True, slots=True)
class Limit(Message):
    """A limit switch: while ``stepper`` steps in the direction of ``flags`` and ``pin``
    reads ``level``, stop it and the queues in ``stop_mask`` at once (:class:`LimitHit`)."""

    CODE: ClassVar[int] = 0x31
    FMT: ClassVar[struct.Struct] = _fmt("BBBBB")
    stepper: int
    pin: int
    level: int
    flags: int
    stop_mask: int


@register
@dataclass(frozen=True, slots=True)
class SetInput(Message):
    """The world outside a *simulated* device (Ident feature F_SIM_INPUTS): a switch
    holds ``pin`` at level ``value`` (0/1), or with ``flags`` S_ANALOG a pot turns the
    analog input ``pin`` to ``value`` (0..1023).  The device reads it from its pin as
    a board would; other devices refuse it."""

    CODE: ClassVar[int] = 0x32
    FMT: ClassVar[struct.Struct] = _fmt("BHB")
    pin: int
    value: int
    flags: int


@register
@dataclass(frozen=True, slots=True)
class Input(Message):
    """A watched input's value (0/1, or 0..1023 analog) and the device tick it was
    read at: on every change, when the watch begins, and with the slow refresh."""

    CODE: ClassVar[int] = 0xA0
    FMT: ClassVar[struct.Struct] = _fmt("BHI")
    pin: int
    value: int
    tick: int


@register
@dataclass(frozen=True, slots=True)
class LimitHit(Message):
    """A limit on ``pin`` stopped queue ``stepper`` at device tick ``tick``: no entry is
    left (read = write = ``index``), the pulses stopped at ``position``.  The queue
    refuses entries and starts until the host's ForceStop for it."""

    CODE: ClassVar[int] = 0xA1
    FMT: ClassVar[struct.Struct] = _fmt("BBBiI")
    stepper: int
    pin: int
    index: int
    position: int
    tick: int


@register
@dataclass(frozen=True, slots=True)
class Started(Message):
    """Queue ``stepper`` began its first entry at device tick ``tick`` (a Start on time
    or late, or an entry that restarted a queue that had run dry)."""

    CODE: ClassVar[int] = 0xA2
    FMT: ClassVar[struct.Struct] = _fmt("BI")
    stepper: int
    tick: int




def message_types() -> list[type[Message]]:
    """Every registered message type, by its (first) type byte."""
    seen: dict[type[Message], int] = {}
    for code, cls in sorted(_BY_CODE.items()):
        seen.setdefault(cls, code)
    return list(seen)


def decode_messages(payload: bytes) -> list[Message]:
    """All messages of a frame's payload (raises :class:`ProtocolError`)."""
    msgs, error = decode_prefix(payload)
    if error:
        raise ProtocolError(error)
    return msgs


def decode_prefix(payload: bytes) -> tuple[list[Message], str]:
    """The messages up to the first one that does not parse, and what stopped it
    ('' when the whole payload parsed): a device acts on those and drops the rest."""
    out: list[Message] = []
    pos = 0
    n = len(payload)
    while pos < n:
        cls = _BY_CODE.get(payload[pos])
        if cls is None:
            return out, f"unknown message type 0x{payload[pos]:02x}"
        try:
            msg, pos = cls.decode(payload, pos if cls.CODE_HAS_INDEX else pos + 1)
        except ProtocolError as exc:
            return out, str(exc)
        out.append(msg)
    return out, ""


def pack_messages(encoded: list[bytes], max_payload: int = MAX_PAYLOAD) -> list[bytes]:
    """Group encoded messages into payloads of at most ``max_payload`` bytes, in order."""
    payloads: list[bytes] = []
    cur = b""
    for m in encoded:
        if cur and len(cur) + len(m) > max_payload:
            payloads.append(cur)
            cur = b""
        cur += m
    if cur:
        payloads.append(cur)
    return payloads
