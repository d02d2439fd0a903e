"""Fuzzing the G-code program (``stepperdemo gcode``, a Grbl 1.1 controller) through
the program interface.

The target makes the program with :func:`stepperdemo.program.make_program` and
drives it as a file run does (``run_script``: a line at a time, as
``stepperdemo gcode FILE``) or as a G-code sender on a serial line does
(``feed``: bytes at 115 200 baud, virtual time passing in between); it reads the
transcript, the clock, the library's steppers and the receive counters of the
machine (``machine.rx.dropped``/``dropped_high``) - nothing else of its insides.

Inputs (:func:`gcode_case`):

* ``line`` cases: short programs of the G-code grammar (:func:`gcode_line`) - motion
  with every axis word, feeds, modal codes, G92, dwells, the user outputs of seed 003
  (M62-M68), program ends, ``$`` commands (``$$ $G $X $# $I $N $C $H $SLP $RST= $J=``
  ...), comments, line numbers, block delete, malformed words and numbers;
* ``bytes`` cases (:func:`grbl_stream`): what a sender sends - lines of that grammar
  and scenes (a move then Ctrl-X and lines while in alarm, a feed hold mid-line and
  lines while held, jogs and jog cancels, sleep, check mode, startup lines, overrides),
  Grbl's real-time bytes (:data:`GRBL_REALTIME`) put into the middle of lines, bytes
  >= 0x80 and control bytes inside lines, overlong lines (past the 128-byte buffer and
  past the line buffer), line-end mixes and noise.  A ``count`` sender counts the
  characters of unanswered lines against Grbl's 128-byte buffer (as bCNC, cncjs,
  UGS do); a ``blast`` sender does not.

Invariants (:func:`check_gcode`):

* no exception, from the first byte to the end of the probe;
* Grbl's dropped bytes: every byte >= 0x80 that is no real-time command is dropped
  (``rx.dropped_high`` counts exactly those sent); no byte is dropped for a full
  buffer while the sender counts (``rx.dropped`` stays 0 unless a line longer than the
  buffer was sent or the sender did not count);
* every line is answered exactly once (``ok`` or ``error:N``): the line ends that
  reached the receive path between two flushes of its buffer (a reset, an alarm that
  aborts a cycle) are answered at most once each, and the last stretch - with nothing
  dropped and the machine brought out of a hold or sleep as a sender does - exactly
  once each; a file run answers every line it read;
* what it prints is what senders parse: printable ASCII lines; ``error:N`` with
  Grbl's numbers (1-39), ``ALARM:N`` (1-9); status reports ``<State|MPos:x,y,z|...>``
  in one of Grbl's states with at least three axis values, one for each ``?`` sent
  (the sender sends each on its own); ``$$`` lines plain ``$N=value``;
* the session goes on: after the input ``?`` answers with a status report and, once
  out of a hold, sleep or alarm, ``$X``, ``$$`` and ``G4 P0`` one answer each;
* each axis's position by the library equals the one counted from its step and
  direction pins, up to what the program declared (:class:`.common.PinTracker`).
"""

from __future__ import annotations

import random
import re
from collections import deque

from fas.sim import SimBackend

from .common import BYTES, LINE, Case, FuzzResult, drive, noise, settle, start

PROGRAM = "gcode"
AXIS_WORDS = "XYZABC"
CTRL_X = b"\x18"
STATUS = b"?"
HOLD = b"!"
RESUME = b"~"
DOOR = b"\x84"
JOG_CANCEL = b"\x85"
#: Grbl 1.1's real-time commands (its interface.md): taken out of the stream wherever
#: they arrive, mid-line and inside comments included, never part of a line
GRBL_REALTIME: frozenset[int] = frozenset(
    {0x18, ord("?"), ord("!"), ord("~"), 0x84, 0x85, *range(0x90, 0x98), *range(0x99, 0x9F),
     0xA0, 0xA1})  # (0x98 is none: Grbl drops it as any other byte >= 0x80)
#: the ones a fuzzed stream puts in (status and overrides more often than a reset)
REALTIME: tuple[bytes, ...] = (
    STATUS, STATUS, STATUS, HOLD, RESUME, RESUME, CTRL_X, DOOR, JOG_CANCEL,
    *(bytes([b]) for b in range(0x90, 0x9F) if b != 0x98), b"\xa0", b"\xa1")
RX_SIZE = 128  # Grbl's receive buffer: what a counting sender counts against
BYTES_PER_MS = 11.52  # 115 200 baud, 10 bits a byte
SLICE = 16  # bytes a serial line delivers between two looks of the controller

POSITIONS = [0, 1, -1, 2, 10, 50, 100, 250, -250, 500, 1000, -1000, 5000, 20000, 100000,
             2**31 - 1, -(2**31), 2**40]
FEEDS = ["1", "60", "600", "6000", "60000", "600000", "6000000", "0", "-100", "0.5",
         "12000", "24000", "240000"]
# a feed so slow that a step waits for days: rare (the program's answer costs it time)
TINY_FEEDS = ["0.001", "0.0001"]
DWELLS = ["0", "0.001", "0.01", "0.05", "0.2", "1", "-1", "0.5"]
SETTING_VALUES = {
    1: ["0", "25", "255", "256", "-1", "1.5", "10"],
    10: ["0", "1", "2", "3", "4"],
    100: ["0.1", "0.5", "1", "2", "10", "80", "0", "-1", "1e9", "1000"],
    110: ["1", "60", "6000", "600000", "1e9", "0", "120000"],
    120: ["1", "100", "10000", "1000000", "0", "500"],
    130: ["0", "10", "200", "-5"],
    140: ["1", "50", "1000", "5000", "20000", "1000000", "0", "-5"],
    150: ["0", "2", "8", "13", "25", "32", "60", "127", "128", "255", "-1"],
    160: ["3", "5", "6", "9", "11", "16", "44", "127", "255", "x"],
    170: ["0", "1", "2"],
}
OTHER_SETTINGS = ["$0=10", "$0=2", "$2=0", "$3=5", "$13=0", "$20=1", "$21=0", "$22=1",
                  "$32=1", "$32=0", "$27=1.000", "$999=1", "$1.5=2", "$100.=1", "$-1=2"]
DOLLAR_PLAIN = ["$", "$$", "$G", "$X", "$#", "$I", "$N", "$C", "$H", "$SLP", "$RST=$",
                "$RST=#", "$RST=*", "$RST=", "$RST=X", "$N0=G91", "$N1=", "$N0=G4P0.1",
                "$N1=M64P0", "$N0=$X", "$N2=G0X1", "$N0=G1", "$I=fuzz", "$I=" + "i" * 90,
                "$abc", "$100", "$=5", "$x", "$ $", "$XX", "$GG", "$$$", "$#1", "$HX",
                "$SLPX", "$J=G91 X10 F6000", "$J=G90 Y-20 F600", "$J=X5", "$J=G91 G1 X1",
                "$J=G91 X1", "$J=G53 X0 F100", "$J=G91 Z-2 F60000", "$J=M3", "$J",
                "$JX1", "$J=G91 X1000 F120", "$J=G21 G91 X5 Y5 F3000", "$J=G4 P1"]
MODAL = ["G90", "G91", "G21", "G20", "G17", "G18", "G19", "G54", "G55", "G94", "G93",
         "G61", "G64", "G80", "G92.1", "G28", "G30", "G2 X1 Y1 I1", "G3 X0 Y2 R1",
         "G38.2 X1", "G53 G0 X0", "G43.1 Z1", "G49", "G10 L20 P1 X0", "G90.1", "G91.1",
         "M3 S1000", "M4 S500", "M5", "M7", "M8", "M9", "T2 M6", "S12000",
         # issue 25's words: arcs, planes, inches, inverse time, offsets, probing, laser
         "G2 X10 Y0 I5 J0 F600", "G3 X0 Y0 R-5 F600", "G17 G2 X5 Y5 R5 F3000",
         "G18 G3 X1 Z1 I1 K0 F600", "G19 G2 Y2 Z0 J1 K0 F600", "G2 X0 Y0 I0 J0 F600",
         "G3 X1 Y1 R0.1 F600", "G2 X1 I0.5 F6000 P2", "G20 G0 X1", "G21", "G93 G1 X10 F2",
         "G94", "G10 L2 P2 X5", "G55 G0 X1", "G59", "G28.1", "G30.1", "G28 X1",
         "G38.2 Z-5 F100", "G38.3 X5 F100", "G38.4 Y1 F60", "G38.5 Z1 F60", "G43.1 Z2",
         "M3 S12000", "M4 S500 G1 X5 F600", "$32=1", "$32=0", "M3 S0", "S-1", "$12=0.01"]
MALFORMED = ["G", "X", "G1 X1 X2", "G1 (unclosed", "Q5", "G1 X1e3", "G1 X--1", "ZZZ",
             "G0 X1 G1 Y1", "G1 X.", "G1 X+-2", "(only a comment)", "; only a comment",
             "N10", "G1 N10 X1", "%", "/G0 X5", "g0x5", "G0 X5 (a) Y2 (b)", "G0 X5 ; tail",
             "G 1 X 1 0 F 6 0 0", "M", "M62", "M67 E0", "G4", "G92", "\t G0 X1", "G01X1F600",
             "M62 P0 M63 P1", "G0 X1 M64 P0", "G4 P0.1 G0 X1", "F0", "F-1", "T1 M6", "S1000",
             "M3 S100", "M5", "M8", "M9", "M0", "M1", "G1.5 X1", "M3.5", "N99999999 G0",
             "G0 X1 (nested (comment) X2", "G0 X(?)1", "G0 X1 (!)", "G1 X1 F600 ;~",
             "G0 X1 Y", "G0 X1 Y1 Z1 A1 B1 C1", "G0 U1", "G0 X1 V2 W3", "@", "G0 X1 #1",
             "G0X1G0X2", "M30 M2", "G4 P1 X1", "G92.2", "G28.1", "G10 L2 P1 X1"]
LONG_LINES = [80, 81, 127, 128, 129, 200, 255, 256, 257, 300, 400]


def _pos(rng: random.Random) -> str:
    r = rng.random()
    if r < 0.6:
        v = rng.randint(-400, 400)
    elif r < 0.85:
        v = rng.choice(POSITIONS[:12])
    else:
        v = rng.choice(POSITIONS)
    text = str(v)
    r = rng.random()
    if r < 0.15:
        text += "." + str(rng.randint(0, 999))
    elif r < 0.2:
        text = rng.choice([".5", "5.", "+3", "-0", "0.0001", "-.25"])
    return text


def _axis_words(rng: random.Random) -> str:
    letters = rng.sample(AXIS_WORDS[:3], rng.randint(1, 3)) if rng.random() < 0.85 \
        else rng.sample(AXIS_WORDS, rng.randint(1, 4))
    return " ".join(f"{a}{_pos(rng)}" for a in letters)


def long_line(rng: random.Random, n: int | None = None) -> str:
    """A line of ``n`` characters: a move with a long comment, or a long number, or
    many words (past the 128-byte buffer, past the line buffer)."""
    n = n or rng.choice(LONG_LINES)
    r = rng.random()
    if r < 0.4:
        return ("G1 X1 F600 (" + "c" * n)[:n - 1] + ")"
    if r < 0.7:
        return "G0 X" + "1" * n
    return ("G91 G1 F6000 " + "X0.01 " * n)[:n]


def gcode_line(rng: random.Random) -> str:
    """One line of the G-code program's language: mostly meaningful, some mistakes."""
    r = rng.random()
    if r < 0.38:
        code = rng.choice(["G0", "G1", "G1", "G00", "G01", "", "g1", "G0"])
        line = f"{code} {_axis_words(rng)}".strip()
        if (code.upper().endswith("1") or rng.random() < 0.2) and rng.random() < 0.8:
            line += f" F{rng.choice(TINY_FEEDS if rng.random() < 0.01 else FEEDS)}"
        return line
    if r < 0.46:
        return rng.choice(MODAL)
    if r < 0.5:
        return rng.choice(["G92 " + _axis_words(rng), "G92.1", "G92 X0 Y0 Z0"])
    if r < 0.55:
        return rng.choice(["G4 P", "G4 P", "G04 P", "G4 X"]) + rng.choice(DWELLS)
    if r < 0.68:
        code = rng.choice(["M62", "M63", "M64", "M65", "M67", "M68"])
        if code in ("M67", "M68"):
            e = rng.choice(["0", "1", "2", "3", "4", "-1", "0.5"])
            q = rng.choice(["0", "10", "33.3", "50", "99.9", "100", "150", "-5"])
            return f"{code} E{e} Q{q}"
        return f"{code} P{rng.choice(['0', '1', '2', '3', '4', '-1', '1.5'])}"
    if r < 0.7:
        return rng.choice(["M2", "M30", "M02"])
    if r < 0.82:
        k = rng.random()
        if k < 0.5:
            return rng.choice(DOLLAR_PLAIN)
        if k < 0.6:
            return rng.choice(OTHER_SETTINGS)
        base = rng.choice(list(SETTING_VALUES))
        number = base if base in (1, 10, 170) else base + rng.randint(0, 6 if base < 140 else 4)
        return f"${number}={rng.choice(SETTING_VALUES[base])}"
    if r < 0.95:
        return rng.choice(MALFORMED)
    return long_line(rng)


def gcode_lines(rng: random.Random, most: int = 8) -> list[str]:
    """A short program: a few lines, often a relative-mode prelude."""
    lines = [gcode_line(rng) for _ in range(rng.randint(1, most))]
    if rng.random() < 0.3:
        lines.insert(0, "G91")
    return lines


# ------------------------------------------------------------- sender streams
def _move(rng: random.Random) -> str:
    return rng.choice(["G1", "G0", "G1"]) + f" X{rng.randint(-300, 300)} " \
        f"Y{rng.randint(-300, 300)} F{rng.choice(['600', '3000', '6000', '24000'])}"


#: what senders and users do, in lines (``{m}`` a move); real-time bytes as their own
#: items (``RT:...``) - the stream puts more of them into lines at random
SCENES = [
    ["G91", "{m}", "RT:\x18", "{m}", "$$", "G4 P0", "$X", "{m}"],  # alarm and lines in it
    ["G91", "{m}", "{m}", "RT:!", "{m}", "$G", "RT:?", "RT:~", "{m}"],  # hold, then resume
    ["$J=G91 X20 F600", "$J=G91 Y-20 F600", "RT:\x85", "$J=G91 X1 F6000", "G0 X1"],
    ["$SLP", "G0 X1", "$X", "RT:?", "RT:\x18", "$X", "{m}"],  # sleep: only a reset
    ["$C", "{m}", "M62 P0", "G4 P1", "$C", "{m}"],  # check mode
    ["$N0=G91", "$N1=G4 P0.05", "$N", "RT:\x18", "{m}", "$N0=", "$N1="],  # startup lines
    ["G91", "{m}", "RT:\x91", "RT:\x91", "RT:\x96", "{m}", "RT:\x9a", "RT:\x90", "RT:\x95"],
    ["{m}", "RT:\x84", "{m}", "RT:?", "RT:~", "G4 P0"],  # safety door
    ["G91", "M62 P0", "{m}", "M63 P0", "M64 P1", "M65 P1", "M67 E0 Q50", "M68 E0 Q10"],
    ["$H", "$RST=#", "$RST=$", "$I", "$#", "$RST=*", "{m}"],
    ["G91", "{m}", "M0", "{m}", "RT:~", "{m}"],  # program pause
]


def _with_realtime(rng: random.Random, data: bytes, choices: tuple[bytes, ...]) -> bytes:
    """``data`` with real-time bytes put in at random places before its line end,
    mid-line included."""
    body = data.rstrip(b"\r\n")
    eol = data[len(body):]
    out = bytearray(body)
    for _ in range(rng.randint(1, 3)):
        at = rng.randint(0, len(out))
        out[at:at] = rng.choice(choices)
    return bytes(out) + eol


def _dirty(rng: random.Random, line: bytes) -> bytes:
    """A line with bytes >= 0x80, control bytes or lower case inside."""
    out = bytearray(line)
    for _ in range(rng.randint(1, 3)):
        at = rng.randint(0, len(out))
        out[at:at] = bytes([rng.choice([rng.randrange(0x80, 0x100), rng.randrange(0x80, 0x100),
                                         rng.choice([0, 7, 8, 9, 11, 12, 27, 127])])])
    return bytes(out).lower() if rng.random() < 0.2 else bytes(out)


def _stream_lines(rng: random.Random) -> list[str]:
    """Lines, real-time items (``RT:``) and scenes for one stream."""
    out: list[str] = []
    for _ in range(rng.randint(1, 3)):
        if rng.random() < 0.45:
            out += [item.format(m=_move(rng)) for item in rng.choice(SCENES)]
        else:
            out += gcode_lines(rng, 6)
    return out


def grbl_stream(rng: random.Random) -> Case:
    """What a sender sends: lines with real-time bytes mid-line, bytes >= 0x80,
    control bytes, overlong lines, line-end mixes, noise; a ``count`` sender mostly."""
    eol = rng.choice([b"\n", b"\n", b"\n", b"\r\n", b"\r"])
    chunks: list[tuple[int, bytes]] = []
    for item in _stream_lines(rng):
        wait = rng.choice([0, 0, 0, 1, 5, 20, 100, 300])
        if item.startswith("RT:"):
            chunks.append((wait, item[3:].encode("latin-1")))
            continue
        data = item.encode() + (eol if rng.random() < 0.95 else rng.choice(
            [b"\r\n", b"\n\r", b"\n\n", b"\r", b"\n"]))
        k = rng.random()
        if k < 0.25:
            data = _with_realtime(rng, data, REALTIME)
        elif k < 0.35:
            data = _dirty(rng, data)
        elif k < 0.38:
            data = long_line(rng).encode() + eol
        elif k < 0.41:
            data = noise(rng, [b"G1 X10 F600", b"G0 Y-5", b"$$", b"M64 P0", b"$J=G91X1F100",
                               b"?", b"!", b"~"]) + eol
        chunks.append((wait, data))
        if rng.random() < 0.15:
            chunks.append((rng.choice([0, 10, 50]), rng.choice(REALTIME)))
    sender = "blast" if rng.random() < 0.15 else "count"
    return Case(BYTES, chunks=tuple(chunks), sender=sender)


def gcode_case(rng: random.Random, arch: str = "atmega328p") -> Case:
    if rng.random() < 0.6:
        return grbl_stream(rng)
    return Case(LINE, "\n".join(gcode_lines(rng)).encode())


# --------------------------------------------------------------- the output
BANNER = re.compile(r"^Grbl \S+ \['\$' for help\]$")
ANSWER = re.compile(r"^(ok|error:(\d+))$")
ALARM = re.compile(r"^ALARM:(\d+)$")
GRBL_STATES = ("Idle", "Run", "Hold:0", "Hold:1", "Jog", "Alarm", "Door:0", "Door:1",
               "Door:2", "Door:3", "Check", "Home", "Sleep")
_NUM = r"-?\d+\.\d+"
REPORT = re.compile(rf"^<([A-Za-z]+(?::\d)?)\|[MW]Pos:{_NUM},{_NUM},{_NUM}(,{_NUM}){{0,3}}"
                    r"(\|[A-Za-z]+:[^|<>]*)*>$")
SETTING_LINE = re.compile(r"^\$\d+=-?\d+(\.\d+)?$")
ERROR_CODES = range(1, 40)  # Grbl 1.1's 1-38, Grbl_ESP32's 39
ALARM_CODES = range(1, 10)


def _text_lines(data: bytes) -> list[str]:
    return data.decode("latin-1").replace("\r", "").split("\n")


def responses(transcript: bytes) -> list[str]:
    """The answers to lines, in order: ``ok``, ``error...``."""
    return [ln for ln in _text_lines(transcript) if ln == "ok" or ln.startswith("error")]


def status_reports(transcript: bytes) -> int:
    return sum(1 for ln in _text_lines(transcript) if ln.startswith("<") and ln.endswith(">"))


def line_ends(data: bytes, after_cr: bool = False) -> tuple[int, bool]:
    """Lines ``data`` ends, as Grbl counts them: real-time bytes and other bytes >=
    0x80 are never part of the stream; LF, CR and CR LF each end one line.  Returns
    (lines, whether the last byte was a CR)."""
    n = 0
    for b in data:
        if b in GRBL_REALTIME or b >= 0x80:
            continue
        if b == 0x0A:
            if not after_cr:
                n += 1
            after_cr = False
        elif b == 0x0D:
            n += 1
            after_cr = True
        else:
            after_cr = False
    return n, after_cr


def check_output(res: FuzzResult, out: bytes) -> None:
    """Every line printed is one a sender parses (see the module text)."""
    for ln in _text_lines(out):
        if not ln:
            continue
        # (Grbl keeps DEL in a line: a [MSG:...] reason may quote it)
        text = ln.replace("\x7f", "") if ln.startswith("[MSG:") else ln
        if any(not 0x20 <= ord(c) < 0x7F for c in text):
            res.violations.append(f"output: not printable ASCII: {ln[:120]!r}")
            return
        m = ANSWER.match(ln)
        if m and m.group(2) and int(m.group(2)) not in ERROR_CODES:
            res.violations.append(f"output: {ln} is no Grbl error number")
            return
        m = ALARM.match(ln)
        if ln.startswith("ALARM") and (not m or int(m.group(1)) not in ALARM_CODES):
            res.violations.append(f"output: {ln} is no Grbl alarm")
            return
        if ln.startswith("<"):
            m = REPORT.match(ln)
            if not m or m.group(1) not in GRBL_STATES:
                res.violations.append(f"output: status report not in Grbl's form: {ln[:160]}")
                return
        if ln.startswith("$") and "=" in ln and not ln.startswith("$N") \
                and not SETTING_LINE.match(ln):
            res.violations.append(f"output: $$ line not plain $N=value: {ln[:120]}")
            return


class Sender:
    """A G-code sender on a serial line to the program (see the module text): it
    sends bytes at 115 200 baud, reads the answers, and keeps the account the
    invariants are checked against."""

    def __init__(self, program, res: FuzzResult, counting: bool, limit: int,
                 machine=None) -> None:
        self.program = program
        #: the Grbl controller behind the program (StepperDemo's g mode: its own)
        self.machine = machine if machine is not None else program.machine
        self.backend = program.backend
        self.res = res
        self.counting = counting
        self.limit = limit
        self.transcript = program.transcript
        self.read_to = len(self.transcript)
        self.rest = b""
        self.inflight: deque[int] = deque()  # bytes of each unanswered line
        self.sending = 0  # bytes of the line being sent not yet sent
        self.ticks_per_byte = max(1, int(self.backend.profile.ticks_per_ms / BYTES_PER_MS))
        self.rx = self.machine.rx
        # the stretch since the last reset or alarm
        self.lines = self.answers = 0
        self.after_cr = False
        self.overfilled = False  # more than RX_SIZE bytes were unanswered (not counting)
        self.dropped_at_start = self.rx.dropped
        self.high_sent = 0
        self.high_at_start = self.rx.dropped_high
        self.statuses = 0  # '?' sent (each on its own: one status report each)
        self.reports = 0
        self.last_state = ""
        self.stretches = 0
        self.total_lines = 0
        self.checking = True  # False: only to bring the machine to rest (the probe)
        # the lines are counted as their bytes reach Grbl's receive path (after a
        # serial buffer in between, StepperDemo's): a reset splits them exactly there
        self._receive = self.machine.receive
        self.machine.receive = self._arrive
        # a stretch ends where the receive buffer is flushed (a reset, an alarm that
        # aborts a cycle): what it held is gone, what the sender sends next is new
        self._flush = self.rx.reset
        self.rx.reset = self._flushed

    def _flushed(self) -> None:
        self.read()  # the answers before the flush belong to the stretch it ends
        self._new_stretch(self.machine.state_name())
        self._flush()

    def _arrive(self, data: bytes) -> None:
        self.read()  # a banner or alarm printed since: the bytes belong to the next stretch
        n, self.after_cr = line_ends(data, self.after_cr)
        self.lines += n
        self.total_lines += n
        self._receive(data)

    def detach(self) -> None:
        self.machine.receive = self._receive
        self.rx.reset = self._flush

    # ------------------------------------------------------------- reading
    def read(self) -> None:
        """Take what the program printed since the last look, line by line."""
        new = bytes(self.transcript[self.read_to:])
        self.read_to = len(self.transcript)
        data = self.rest + new
        *lines, self.rest = data.split(b"\n")
        for raw in lines:
            ln = raw.rstrip(b"\r").decode("latin-1")
            if ANSWER.match(ln):
                self.answers += 1
                if self.inflight:
                    self.inflight.popleft()
            elif ln.startswith("<"):
                self.last_state = ln[1:].split("|", 1)[0]
                self.reports += 1

    def _new_stretch(self, why: str) -> None:
        """A reset or an alarm: what was received and not yet read is gone; a sender
        starts counting again (the rest of a line under way counts anew)."""
        self._close_stretch(exact=False, why=f"a flush in state {why}")
        self.inflight.clear()
        if self.sending:
            self.inflight.append(self.sending)
        self.lines = self.answers = 0
        self.after_cr = False
        self.overfilled = self.sending > RX_SIZE
        self.dropped_at_start = self.rx.dropped

    def _close_stretch(self, exact: bool, why: str = "") -> None:
        self.stretches += 1
        if not self.checking:
            return
        dropped = self.rx.dropped - self.dropped_at_start
        if dropped and not self.overfilled:
            self.res.violations.append(
                f"{dropped} bytes dropped for a full buffer while the sender kept at most "
                f"{RX_SIZE} unanswered")
        if self.answers > self.lines or (exact and not dropped and self.answers != self.lines):
            self.res.violations.append(
                f"{self.answers} answers (ok/error) to {self.lines} lines sent"
                + (f" before {why!r}" if why else ""))

    # ------------------------------------------------------------- sending
    def _feed(self, data: bytes) -> None:
        """``data`` arrives on the line: its bytes' worth of time passes."""
        p = self.program
        for b in data:
            if b >= 0x80 and b not in GRBL_REALTIME:
                self.high_sent += 1
        p.feed(data)
        p.run_until(self.backend.now() + len(data) * self.ticks_per_byte)
        # a program that takes its input a byte per loop pass (StepperDemo) takes it
        # all before the next byte arrives
        for _ in range(4 * len(data)):
            if not p.input_pending():
                break
            p.run_until(self.backend.now() + self.ticks_per_byte)
        self.read()

    def send_realtime(self, data: bytes) -> None:
        if STATUS in data:
            self.statuses += data.count(STATUS)
        self._feed(data)

    def _room(self, size: int) -> bool:
        return not self.inflight or sum(self.inflight) + size <= RX_SIZE

    def at_rest(self) -> bool:
        """Only new input could make the controller do anything."""
        return self.machine.wake_tick() is None and not self.program.input_pending()

    def settle(self, limit: int) -> bool:
        """Run until the controller rests or ``limit`` (True: it rests)."""
        p = self.program
        while not self.at_rest():
            if self.backend.now() >= limit:
                return False
            wake = p.next_wake_tick()
            now = self.backend.now()
            p.run_until(min(now + 1 if wake is None else max(wake, now + 1), limit))
        return True

    def wait_for_room(self, size: int) -> bool:
        """A counting sender waits until the line fits (False: it never did in time).
        A line held back by a hold or sleep is let go as a user does: ``~``, Ctrl-X."""
        p = self.program
        asked = 0
        while not self._room(size):
            if self.backend.now() >= self.limit:
                return False
            wake = p.next_wake_tick()
            if self.at_rest():  # nothing will happen by itself: ask, then act
                if asked > 3:
                    return False
                asked += 1
                self.send_realtime(STATUS)
                if self.last_state in ("Hold:0", "Door:0"):
                    self.send_realtime(RESUME)
                elif self.last_state == "Sleep":
                    self.send_realtime(CTRL_X)
                continue
            p.run_until(min(max(wake, self.backend.now() + 1), self.limit))
            self.read()
        return True

    def send_line(self, data: bytes) -> bool:
        """A line (real-time bytes inside it go out as they come); False: out of time."""
        counted = sum(1 for b in data if b not in GRBL_REALTIME)
        if self.counting and not self.wait_for_room(counted):
            return False
        if sum(self.inflight) + counted > RX_SIZE:
            self.overfilled = True
        self.inflight.append(counted)
        self.sending = counted
        piece = bytearray()
        for b in data:
            if b in GRBL_REALTIME:
                if piece:
                    self._feed(bytes(piece))
                    piece.clear()
                self.send_realtime(bytes([b]))
                continue
            piece.append(b)
            self.sending -= 1
            if len(piece) >= SLICE:
                self._feed(bytes(piece))
                piece.clear()
        if piece:
            self._feed(bytes(piece))
        self.sending = 0
        return self.backend.now() < self.limit

    def wait(self, ms: int) -> None:
        if ms:
            self.program.run_until(min(self.backend.now() + ms * self.backend.profile
                                       .ticks_per_ms, self.limit))
            self.read()

    # ------------------------------------------------------------ the end
    def come_to_rest(self, limit: int) -> str:
        """Run until at rest, bringing the machine out of a hold or sleep as a sender
        does (``~``, Ctrl-X); a machine still busy at ``limit`` is reset (Ctrl-X).
        Returns the last state reported."""
        for _ in range(6):
            self.settle(limit)
            self.read()
            self.send_realtime(STATUS)
            state = self.last_state
            if state in ("Hold:0", "Door:0"):
                self.send_realtime(RESUME)
            elif state == "Sleep" or self.backend.now() >= limit:
                self.send_realtime(CTRL_X)
                limit = self.backend.now() + self.backend.profile.ticks_per_s
            elif self.at_rest():
                return state
        return self.last_state

    def finish(self) -> None:
        """The checks of the whole stream."""
        self.read()
        self.detach()
        self._close_stretch(exact=True)
        if self.reports != self.statuses:
            self.res.violations.append(f"{self.reports} status reports for {self.statuses} "
                                       "'?' sent one at a time")
        high = self.rx.dropped_high - self.high_at_start
        if high != self.high_sent:
            self.res.violations.append(f"{self.high_sent} bytes >= 0x80 sent that are no "
                                       f"real-time command, {high} dropped")


def _probe_line(program, line: bytes, limit: int, res: FuzzResult) -> str:
    transcript = program.transcript
    mark = len(transcript)
    program.feed(line + b"\n")
    settle(program, limit, res)
    new = bytes(transcript[mark:])
    answers = responses(new)
    if len(answers) != 1:
        res.violations.append(f"probe: {line.decode()} answered {len(answers)} times: "
                              f"{new[:160]!r}")
        return ""
    if line == b"$$" and answers[0] == "ok" and b"$100=" not in new:
        res.violations.append(f"probe: $$ answered ok without settings: {new[:160]!r}")
    return answers[0]


def probe(program, limit: int, res: FuzzResult) -> None:
    """The session goes on: a status report on ``?``; out of a hold, sleep or alarm
    as a sender gets out of them; then ``$X``, ``$$``, ``G4 P0`` one answer each."""
    sender = Sender(program, res, counting=True, limit=limit)
    sender.checking = False  # (what the case left behind may still be answered)
    program.feed(b"\n")  # ends a line left open by the input (it is answered or not)
    state = sender.come_to_rest(limit)
    sender.detach()
    if not state:
        res.violations.append("probe: no status report on '?'")
        return
    if state not in ("Idle", "Alarm", "Check"):
        res.violations.append(f"probe: the machine did not come to rest (state {state!r})")
        return
    budget = max(limit - program.backend.now(), program.backend.profile.ticks_per_s)
    for line in (b"$X", b"$$", b"G4 P0"):  # (each with time of its own)
        _probe_line(program, line, program.backend.now() + budget, res)
    mark = len(program.transcript)
    program.feed(STATUS)
    text = bytes(program.transcript[mark:]).decode("latin-1")
    if not re.search(r"<(Idle|Check)\|", text):
        res.violations.append(f"probe: after $X the state is not Idle: {text[:120]!r}")


def check_gcode(case: Case, arch: str = "atmega328p", max_time_s: float = 10.0,
                probe_session: bool = True) -> FuzzResult:
    """Run one case on a fresh simulated chip and return what it broke."""
    res = FuzzResult(case.data, arch, PROGRAM, case)
    backend = SimBackend(arch, record=True)
    tps = backend.profile.ticks_per_s
    try:
        program, tracker = start(PROGRAM, backend, res)
        limit = backend.now() + int(max_time_s * tps)
        mark = len(program.transcript)
        if case.kind == LINE:
            _run_file(program, case, limit, res)
        elif case.sender:
            _run_sender(program, case, limit, res)
        else:
            res.lines = sum(line_ends(c)[0] for _, c in case.chunks)
            done = drive(program, case.chunks, limit, res)
            res.end = "idle" if done else "max_time"
            if not done:
                program.feed(CTRL_X)  # a sender's reset
        if probe_session:
            probe(program, backend.now() + int(max_time_s * tps), res)
        check_output(res, bytes(program.transcript[mark:]))
        tracker.check()
    except Exception as exc:  # the whole point: nothing may raise
        res.record_exception(exc)
    return res


def _run_file(program, case: Case, limit: int, res: FuzzResult) -> None:
    """A file run: every line it read answered once; all of them unless a sleep, a
    hold, a reset or an alarm kept the rest from being read."""
    backend = program.backend
    sent = case.text.replace(b"\r", b"\n").split(b"\n")
    res.lines = len(sent)
    mark = len(program.transcript)
    end = program.run_script(case.text.decode("utf-8", "replace"),
                             max_ticks=limit - backend.now())
    res.end = end.name.lower()
    for _ in range(5):  # a pause (M0, !) or a sleep in the file: as its user goes on
        state = program.machine.state_name()
        if state in ("Hold:0", "Door:0"):
            program.feed(RESUME)
        elif state == "Sleep":
            program.feed(CTRL_X)
        else:
            break
        res.end = "idle" if settle(program, limit, res) else "max_time"
    new = bytes(program.transcript[mark:])
    content = sum(1 for ln in sent if ln.strip(b" \t"))
    answers = len(responses(new))
    state = program.machine.state_name()
    interrupted = any(BANNER.match(ln) or ALARM.match(ln) for ln in _text_lines(new)) or \
        state in ("Sleep", "Hold:0", "Hold:1", "Door:0", "Door:2") or res.end != "idle"
    if answers > content or (not interrupted and answers != content):
        res.violations.append(f"lines: {answers} answers (ok/error) for {content} lines "
                              f"(ended {res.end}, {state})")
    program.load_script("")  # the user stops the file here
    if res.end != "idle":
        program.feed(CTRL_X)  # a sender's reset


def _run_sender(program, case: Case, limit: int, res: FuzzResult, machine=None) -> None:
    sender = Sender(program, res, counting=case.sender == "count", limit=limit,
                    machine=machine)
    stream(sender, case)


def stream(sender: Sender, case: Case) -> None:
    """Send a ``bytes`` case as its sender does, bring the controller to rest and
    check the account (see :class:`Sender`)."""
    program, res, limit = sender.program, sender.res, sender.limit
    for wait_ms, data in case.chunks:
        if program.backend.now() >= limit:
            break
        if line_ends(data)[0] == 0 and all(b in GRBL_REALTIME for b in data):
            sender.send_realtime(data)
        elif not sender.send_line(data):
            break
        sender.wait(wait_ms)
    state = sender.come_to_rest(limit)
    res.end = state.lower()
    sender.finish()
    res.lines = sender.total_lines
