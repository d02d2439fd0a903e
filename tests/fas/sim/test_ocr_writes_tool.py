"""``bench/replica/ocr_writes.py`` (docs/timing-model.md, "thirty-fourth pass"): the step
vector's pin clear and compare write found in a disassembly, and the cycles between them
read per channel from a runner's marks."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench" / "replica"))

import ocr_writes  # noqa: E402

LISTING = """
00000100 <__vector_11>:
     100:	1f 92       	push	r1
     102:	80 93 82 00 	sts	0x0082, r24	; 0x800082
     106:	90 93 80 00 	sts	0x0080, r25	; 0x800080
     10a:	90 93 82 00 	sts	0x0082, r25	; 0x800082
     10e:	90 93 89 00 	sts	0x0089, r25	; 0x800089
     112:	80 93 88 00 	sts	0x0088, r24	; 0x800088
     116:	18 95       	reti

00000200 <__vector_12>:
     200:	90 93 82 00 	sts	0x0082, r25	; 0x800082
     204:	90 93 8b 00 	sts	0x008B, r25	; 0x80008b
     208:	80 93 8a 00 	sts	0x008A, r24	; 0x80008a
     20c:	18 95       	reti
"""


def test_the_sites_are_the_last_clear_and_the_channels_compare_write() -> None:
    # the first force-compare write is the empty queue's path; the pin's clear on the
    # stepping path is the last one before the compare's low byte
    assert ocr_writes.write_sites(LISTING, (11, 12)) == [(0x10A, 0x112), (0x200, 0x208)]
    with pytest.raises(ValueError, match="__vector_13"):
        ocr_writes.write_sites(LISTING, (11, 13))


def test_the_histogram_pairs_each_clear_with_the_next_write_of_its_channel() -> None:
    ev = ["100 V 11", "125 M 0 0 0 0 0 0", "150 M 1 0 0 0 0 0", "160 R",
          "300 M 2 0 0 0 0 0", "310 M 0 0 0 0 0 0", "326 M 3 0 0 0 0 0",
          "359 M 1 0 0 0 0 0", "400 M 1 0 0 0 0 0"]  # the last write has no clear
    a, b = ocr_writes.histograms(ev, 2)
    assert dict(a) == {25: 1, 49: 1}
    assert dict(b) == {26: 1}
