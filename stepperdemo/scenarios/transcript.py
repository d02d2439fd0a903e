"""Console transcripts compared with a firmware reference.

A reference transcript is stored with two parts replaced by markers: the firmware's
version string (``<version>``) and its usage text (``<usage>``), which this console
words differently (at the same length, so the timing is the same).  Lines whose
content comes from the moment they are printed -- the status lines (``M1: @...``,
compared up to the ``@``) and the bare numbers of test sequence 07 (compared with
their digits masked) -- are not compared exactly; every other line is byte-exact.
"""

from __future__ import annotations

import gzip
import re
from pathlib import Path

from .. import messages as msg

USAGE_MARK = "<usage>"
VERSION_MARK = "<version>"
_STATUS = re.compile(r"(M\d+: @).*")
_NUMBERS = re.compile(r"^[\d\s/:.-]+$")
_DIGITS = re.compile(r"\d+")


def ours_marked(transcript: bytes) -> str:
    """Our transcript with the usage text and version replaced by the markers."""
    text = transcript.decode("utf-8", "replace")
    text = text.replace(msg.USAGE_NORMAL, USAGE_MARK)
    return text.replace(msg.BANNER_VERSION, msg.BANNER_VERSION.replace(msg.VERSION,
                                                                       VERSION_MARK))


def mark_reference(transcript: bytes, usage_len: int) -> str:
    """A firmware transcript with its version and usage text replaced by the markers.

    The usage text is the block after the four banner lines, ``usage_len`` bytes
    long; every later copy of the same block is replaced too.
    """
    text = transcript.decode("utf-8", "replace")
    lines = text.split("\n", 4)
    if len(lines) < 5:
        return text
    head = "\n".join(lines[:4]) + "\n"
    prefix = msg.BANNER_VERSION.split(msg.VERSION)[0]
    if lines[0].startswith(prefix):
        head = prefix + VERSION_MARK + "\n" + "\n".join(lines[1:4]) + "\n"
    usage = lines[4][:usage_len]
    rest = lines[4]
    if len(usage) == usage_len:
        rest = rest.replace(usage, USAGE_MARK)
    return head + rest


def _masked(line: str) -> str:
    line = _STATUS.sub(r"\1...", line)
    if _NUMBERS.match(line):
        return _DIGITS.sub("#", line)
    return line


def first_difference(ours: str, reference: str) -> str | None:
    """None when the transcripts agree, else a one-line description of the first change."""
    a = ours.split("\n")
    b = reference.split("\n")
    for i, (x, y) in enumerate(zip(a, b, strict=False)):  # (lengths: compared below)
        if _masked(x.rstrip("\r")) != _masked(y.rstrip("\r")):
            return msg.TRANSCRIPT_LINE_DIFF.format(line=i + 1, ours=x.rstrip(),
                                                   ref=y.rstrip())
    if len(a) != len(b):
        return msg.TRANSCRIPT_LENGTH_DIFF.format(ours=len(a), ref=len(b))
    return None


def read_reference(path: Path) -> str:
    data = path.read_bytes()
    if path.suffix == ".gz":
        data = gzip.decompress(data)
    return data.decode("utf-8")


PCNT_MODULO = 32767  # the counter runs -32767..32767 (p7,-32767,32767)


def pcnt_sync_problems(transcript: str, motor: str, tolerance: int) -> list[str]:
    """Upstream's pulse-counter check of its ESP32 hardware tests: every status line of
    ``motor`` (``M1: @pos [pcnt] ...``) has the position within ``tolerance`` steps of the
    counter, modulo 32767, and every stepper-table line (``>> M1: @pos [pcnt]``) has
    them equal.  The lines that break the rule, empty if none."""
    digit = re.escape(motor[1])  # as upstream: the motor's first digit
    running = re.compile(rf"^M[{digit}]:\s+@(-?\d+)\s+\[(-?\d+)\]")
    selected = re.compile(rf"^>> {re.escape(motor)}:\s+@(-?\d+)\s+\[(-?\d+)\]")
    problems = []
    for raw in re.split(r"[\r\n]+", transcript):
        line = raw.strip()
        for pattern, exact in ((running, False), (selected, True)):
            m = pattern.match(line)
            if not m:
                continue
            api = int(m.group(1)) % PCNT_MODULO
            pcnt = int(m.group(2))
            if pcnt < 0:
                pcnt += PCNT_MODULO
            delta = abs(api - pcnt)
            delta = min(delta, PCNT_MODULO - delta)
            if (delta != 0) if exact else (tolerance < delta < PCNT_MODULO - tolerance):
                problems.append(f"{line} (position {api}, counter {pcnt})")
    return problems
