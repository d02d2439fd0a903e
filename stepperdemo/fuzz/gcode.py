"""Fuzzing the G-code program (``stepperdemo gcode``) through the program interface.

The target knows nothing of the program's insides: it makes the program with
:func:`stepperdemo.program.make_program` and drives it with ``run_script`` (a file's
lines, as ``stepperdemo gcode FILE`` streams them) or ``feed`` (bytes as a serial
line delivers them, in timed chunks), and reads only the transcript, the clock and
the library's steppers - so it keeps working when the program's insides change.

Inputs (:func:`gcode_case`):

* ``line`` cases: short programs of the G-code grammar (:func:`gcode_line`) - motion
  with every axis word, feeds, modal codes, G92, dwells, the user outputs of seed 003
  (M62-M68), program ends, ``$`` commands (settings, ``$$ $G $X $# $I $N $C $H $J=``
  ...), comments, line numbers, block delete, and malformed words and numbers;
* ``bytes`` cases: grammar lines with real-time bytes in the middle of a line
  (:data:`REALTIME`), bytes >= 0x80 and control bytes inside lines, overlong lines,
  CR/LF mixes, and noise, in chunks with virtual time between them (a real-time byte
  can arrive during a move).

**Hook for the Grbl real-time grammar**: :data:`REALTIME` holds the real-time bytes the
program takes out of the stream wherever they arrive; a later step adds Grbl 1.1's
(``!``, ``~``, 0x84, 0x85, 0x90-0x9D, 0x9E, 0xA0, 0xA1) to it and, beside
:func:`realtime_case`, the invariants of their states (hold, resume, jog cancel).  The
probe (:func:`probe`) expects a state that takes lines (Idle, Run, Alarm): with Grbl's
Sleep, Hold and Door it first has to bring the program out of them as a sender does
(Ctrl-X, ``~``), by the state its ``?`` reports.

Invariants (:func:`check_gcode`):

* no exception, from the first byte to the end of the probe;
* a ``line`` case that ran to its end answered every line that has content exactly
  once (``ok`` or ``error...``; a blank line may be answered or skipped); a ``bytes``
  case of clean lines with ``?`` among them answers every line once too, and gives at
  least one status report;
* the session goes on: after the input (and a console Ctrl-C if it was still busy)
  ``?`` gives a status report ``<...>``, and ``$X``, ``$$``, ``G4 P0`` are answered
  one response each (``$$`` with its ``$N=`` lines when ``ok``);
* each axis's position by the library equals the one counted from its step and
  direction pins, up to what the program declared (:class:`.common.PinTracker`).
"""

from __future__ import annotations

import random

from fas.sim import SimBackend

from ..program import make_program
from .common import BYTES, LINE, Case, FuzzResult, PinTracker, drive, noise, settle

PROGRAM = "gcode"
AXIS_WORDS = "XYZABC"
CTRL_X = b"\x18"
#: real-time bytes: taken out of the stream wherever they arrive (the hook: Grbl's
#: further real-time bytes join here, see the module text)
REALTIME: tuple[bytes, ...] = (b"?", CTRL_X)
STATUS = b"?"

POSITIONS = [0, 1, -1, 2, 10, 50, 100, 250, -250, 500, 1000, -1000, 5000, 20000, 100000,
             2**31 - 1, -(2**31), 2**40]
FEEDS = ["1", "60", "600", "6000", "60000", "600000", "6000000", "0", "-100", "0.5",
         "12000", "24000", "240000"]
# a feed so slow that a step waits for days: rare (the program's answer costs it time)
TINY_FEEDS = ["0.001", "0.0001"]
DWELLS = ["0", "0.001", "0.01", "0.05", "0.2", "1", "-1", "0.5"]
SETTING_VALUES = {
    1: ["0", "25", "255", "256", "-1", "1.5", "10"],
    100: ["0.1", "0.5", "1", "2", "10", "80", "0", "-1", "1e9", "1000"],
    110: ["1", "60", "6000", "600000", "1e9", "0", "120000"],
    120: ["1", "100", "10000", "1000000", "0", "500"],
    140: ["1", "50", "1000", "5000", "20000", "1000000", "0", "-5"],
    150: ["0", "2", "8", "13", "25", "32", "60", "127", "128", "255", "-1"],
    160: ["3", "5", "6", "9", "11", "16", "44", "127", "255", "x"],
}
DOLLAR_PLAIN = ["$", "$$", "$G", "$X", "$#", "$I", "$N", "$C", "$H", "$SLP", "$RST=$",
                "$RST=#", "$RST=*", "$N0=G91", "$N1=", "$999=1", "$abc", "$100", "$=5",
                "$x", "$ $", "$J=G91 X10 F6000", "$J=G90 Y-20 F600", "$J=X5", "$J=G91 G1 X1"]
MODAL = ["G90", "G91", "G21", "G20", "G17", "G18", "G54", "G55", "G94", "G93", "G61",
         "G64", "G80", "G92.1", "G28", "G30", "G2 X1 Y1 I1", "G38.2 X1", "G53 G0 X0",
         "G43.1 Z1", "G10 L20 P1 X0", "G90.1"]
MALFORMED = ["G", "X", "G1 X1 X2", "G1 (unclosed", "Q5", "G1 X1e3", "G1 X--1", "ZZZ",
             "G0 X1 G1 Y1", "G1 X.", "G1 X+-2", "(only a comment)", "; only a comment",
             "N10", "G1 N10 X1", "%", "/G0 X5", "g0x5", "G0 X5 (a) Y2 (b)", "G0 X5 ; tail",
             "G 1 X 1 0 F 6 0 0", "M", "M62", "M67 E0", "G4", "G92", "\t G0 X1", "G01X1F600",
             "M62 P0 M63 P1", "G0 X1 M64 P0", "G4 P0.1 G0 X1", "F0", "F-1", "T1 M6", "S1000",
             "M3 S100", "M5", "M8", "M9", "M0", "M1"]
LONG_LINES = [80, 81, 127, 128, 129, 255, 256, 257, 300]


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
        if rng.random() < 0.5:
            return rng.choice(DOLLAR_PLAIN)
        base = rng.choice(list(SETTING_VALUES))
        number = base if base == 1 else base + rng.randint(0, 6 if base < 140 else 4)
        return f"${number}={rng.choice(SETTING_VALUES[base])}"
    if r < 0.95:
        return rng.choice(MALFORMED)
    n = rng.choice(LONG_LINES)
    return ("G1 X1 F600 (" + "c" * n)[:n - 1] + ")" if rng.random() < 0.5 else "G0 X" + "1" * n


def gcode_lines(rng: random.Random, most: int = 8) -> list[str]:
    """A short program: a few lines, often a relative-mode prelude."""
    lines = [gcode_line(rng) for _ in range(rng.randint(1, most))]
    if rng.random() < 0.3:
        lines.insert(0, "G91")
    return lines


def _with_realtime(rng: random.Random, data: bytes, choices: tuple[bytes, ...]) -> bytes:
    """``data`` with real-time bytes put in at random places, mid-line included."""
    out = bytearray(data)
    for _ in range(rng.randint(1, 4)):
        at = rng.randint(0, len(out))
        out[at:at] = rng.choice(choices)
    return bytes(out)


def realtime_case(rng: random.Random) -> Case:
    """Clean lines with ``?`` among them, in chunks during motion: every line answered
    once, every ``?`` a status report (the hook for Grbl's real-time grammar)."""
    chunks = []
    for line in gcode_lines(rng, 6):
        data = _with_realtime(rng, line.encode() + b"\n", (STATUS,))
        chunks.append((rng.choice([0, 0, 5, 20, 100]), data))
    return Case(BYTES, chunks=tuple(chunks))


def gcode_bytes(rng: random.Random) -> Case:
    """Bytes on the serial line: lines with real-time, high and control bytes inside,
    overlong lines, line-end mixes, noise; in chunks with time between them."""
    words = [ln.encode() for ln in ("G1 X10 F600", "G0 Y-5", "$$", "M64 P0", "G91", "?")]
    r = rng.random()
    if r < 0.3:
        return realtime_case(rng)
    chunks = []
    for _ in range(rng.randint(1, 4)):
        k = rng.random()
        if k < 0.3:
            eol = rng.choice([b"\n", b"\r", b"\r\n", b"\n\r", b"\n\n"])
            data = eol.join(ln.encode() for ln in gcode_lines(rng, 4)) + eol
            data = _with_realtime(rng, data, REALTIME)
        elif k < 0.5:
            line = bytearray(gcode_line(rng).encode())
            for _ in range(rng.randint(1, 3)):
                at = rng.randint(0, len(line))
                line[at:at] = bytes([rng.choice([rng.randrange(0x80, 0x100),
                                                 rng.choice([0, 7, 8, 9, 11, 12, 27, 127])])])
            data = bytes(line) + b"\n"
        elif k < 0.6:
            data = b"G1 X1 F600 " + b"Y1 " * rng.randint(30, 100) + b"\n"
        elif k < 0.7:
            data = rng.choice([b"\n", b"\r", b"\r\n"]) * rng.randint(1, 30)
        else:
            data = noise(rng, words) + rng.choice([b"\n", b"", b"\r"])
        chunks.append((rng.choice([0, 0, 1, 10, 50, 200]), data))
    return Case(BYTES, chunks=tuple(chunks))


def gcode_case(rng: random.Random, arch: str = "atmega328p") -> Case:
    if rng.random() < 0.35:
        return gcode_bytes(rng)
    return Case(LINE, "\n".join(gcode_lines(rng)).encode())


# ------------------------------------------------------------------- checks
def _lines_of(data: bytes) -> list[bytes]:
    """The lines of ``data``: CR and LF each end one (CR LF: a line and a blank one)."""
    return data.replace(b"\r", b"\n").split(b"\n")


def responses(transcript: bytes) -> list[str]:
    """The answers to lines, in order: ``ok``, ``error...``."""
    return [ln for ln in transcript.decode("utf-8", "replace").replace("\r", "").split("\n")
            if ln == "ok" or ln.startswith("error")]


def status_reports(transcript: bytes) -> int:
    return sum(1 for ln in transcript.decode("utf-8", "replace").replace("\r", "").split("\n")
               if ln.startswith("<") and ln.endswith(">"))


def _answer_count(res: FuzzResult, sent: list[bytes], answers: int, what: str) -> None:
    """Each line with content answered once; a blank line may be answered or skipped."""
    content = sum(1 for ln in sent if ln.strip(b" \t"))
    blank = len(sent) - content
    if not content <= answers <= content + blank:
        res.violations.append(f"{what}: {answers} answers (ok/error) for {content} lines"
                              + (f" and {blank} blank ones" if blank else ""))


PROBE_LINES = (b"$X", b"$$", b"G4 P0")


def probe(program, limit: int, res: FuzzResult) -> None:
    """The session goes on: a status report on ``?``, one answer to each probe line."""
    transcript = program.transcript
    program.feed(b"\n")  # ends a line left open by the input (it is answered or not)
    settle(program, limit, res)
    mark = len(transcript)
    program.feed(STATUS)
    if not settle(program, limit, res) and not res.violations:
        res.violations.append("probe: '?' - the program did not come to rest")
    if status_reports(bytes(transcript[mark:])) < 1:
        res.violations.append(f"probe: no status report on '?': "
                              f"{bytes(transcript[mark:])[:120]!r}")
    for line in PROBE_LINES:
        mark = len(transcript)
        program.feed(line + b"\n")
        settle(program, limit, res)
        new = bytes(transcript[mark:])
        answers = responses(new)
        if len(answers) != 1:
            res.violations.append(f"probe: {line.decode()} answered {len(answers)} times: "
                                  f"{new[:160]!r}")
        elif line == b"$$" and answers[0] == "ok" and b"$1=" not in new \
                and b"$100=" not in new:
            res.violations.append(f"probe: $$ answered ok without settings: {new[:160]!r}")


def check_gcode(case: Case, arch: str = "atmega328p", max_time_s: float = 10.0,
                probe_session: bool = True) -> FuzzResult:
    """Run one case on a fresh simulated chip and return what it broke."""
    res = FuzzResult(case.data, arch, PROGRAM, case)
    backend = SimBackend(arch, record=True)
    tps = backend.profile.ticks_per_s
    try:
        program = make_program(PROGRAM, backend, scripted=True)
        program.run_until(backend.now())  # set-up: the steppers exist from here on
        tracker = PinTracker(backend, program.steppers, res)
        limit = backend.now() + int(max_time_s * tps)
        if case.kind == LINE:
            sent = _lines_of(case.text)
            res.lines = len(sent)
            mark = len(program.transcript)
            end = program.run_script(case.text.decode("utf-8", "replace"), max_ticks=limit
                                     - backend.now())
            res.end = end.name.lower()
            done = res.end == "idle"
            if done:
                _answer_count(res, sent, len(responses(bytes(program.transcript[mark:]))),
                              "lines")
        else:
            res.lines = sum(len(_lines_of(c)) for _, c in case.chunks)
            mark = len(program.transcript)
            done = drive(program, case.chunks, limit, res)
            res.end = "idle" if done else "max_time"
            data = case.data
            if done and CTRL_X not in data and all(set(c) <= _CLEAN for _, c in case.chunks):
                new = bytes(program.transcript[mark:])
                # the piece after the last line end is no line yet
                sent = _lines_of(data.replace(STATUS, b""))[:-1]
                _answer_count(res, sent, len(responses(new)), "bytes")
                if STATUS in data and status_reports(new) < 1:
                    res.violations.append("bytes: '?' gave no status report")
        if not done:
            program.force_stop_all()  # the console's Ctrl-C
        if probe_session:
            probe(program, backend.now() + int(max_time_s * tps), res)
        tracker.check()
    except Exception as exc:  # the whole point: nothing may raise
        res.record_exception(exc)
    return res


# the bytes of clean lines: printable ASCII, tab, CR, LF
_CLEAN = frozenset(range(0x20, 0x7F)) | {9, 10, 13}
