"""Grbl 1.1's receive path (issue 24): real-time bytes, the 128-byte ring, lines."""

from stepperdemo.gcode.grbl_rx import (
    DOOR,
    FLOOD_TOGGLE,
    HOLD,
    JOG_CANCEL,
    RESET,
    RESUME,
    RX_SIZE,
    SPINDLE_MINUS_10,
    STATUS,
    GrblReceiver,
    RxLine,
)


def lines(rx: GrblReceiver) -> list[RxLine]:
    out = []
    while (line := rx.take_line()) is not None:
        out.append(line)
    return out


def test_realtime_bytes_leave_the_stream_wherever_they_are():
    rx = GrblReceiver()
    assert rx.receive(b"G1 X1?0 !Y2~0\x18\n") == [STATUS, HOLD, RESUME, RESET]
    assert lines(rx) == [RxLine("G1X10Y20", False)]


def test_realtime_bytes_inside_a_comment_act_too():
    rx = GrblReceiver()
    assert rx.receive(b"G0 X1 (tool change!)\n") == [HOLD]
    assert lines(rx) == [RxLine("G0X1", False)]


def test_no_byte_at_or_above_0x80_enters_a_line():
    rx = GrblReceiver()
    # UTF-8 'A-umlaut' is C3 84: 0xC3 is dropped, 0x84 is the safety door (as on real Grbl)
    got = rx.receive("(Ä à Û)G1 X\x85\x9b5\n".encode("utf-8", "surrogatepass")
                     .replace(b"\xc2\x85", b"\x85").replace(b"\xc2\x9b", b"\x9b"))
    assert got == [DOOR, FLOOD_TOGGLE, SPINDLE_MINUS_10, JOG_CANCEL, SPINDLE_MINUS_10]
    assert rx.dropped_high == 3
    assert lines(rx) == [RxLine("G1X5", False)]


def test_the_ring_holds_128_bytes_and_drops_the_rest():
    rx = GrblReceiver()
    line = b"G1 X12345.678 Y-1234.567 F1200\n"  # 31 bytes
    rx.receive(line * 4)  # 124 bytes
    assert rx.free == RX_SIZE - 124
    rx.receive(b"G1X1\n")  # 5 more: only 4 fit
    assert rx.free == 0 and rx.dropped == 1
    assert len(lines(rx)) == 4  # the fifth line lost its line end ...
    rx.receive(b"G0X2\n")
    assert lines(rx) == [RxLine("G1X1G0X2", False)]  # ... and runs into the next one


def test_a_line_leaves_the_ring_as_it_is_read():
    rx = GrblReceiver()
    rx.receive(b"G1 X1 F100\nG1 X2\n")
    assert rx.free == RX_SIZE - 17
    assert rx.take_line() == RxLine("G1X1F100", False)
    assert rx.free == RX_SIZE - 6  # the parser holds line 1; the ring has room again
    rx.receive(b"G1 X3")  # a partial line
    assert rx.take_line() == RxLine("G1X2", False)
    assert rx.take_line() is None  # partial: read out of the ring, kept until its end
    assert rx.free == RX_SIZE
    rx.receive(b"\n")
    assert rx.take_line() == RxLine("G1X3", False)


def test_filtering_as_grbl():
    rx = GrblReceiver()
    rx.receive(b"n10 g1 x1 ; comment ?\n/G0 X2\n( open comment\n\t\n(a)g(b)4 p(c)1\n")
    assert [x.text for x in lines(rx)] == ["N10G1X1", "G0X2", "", "", "G4P1"]


def test_cr_lf_and_lone_cr_end_one_line_each():
    rx = GrblReceiver()
    rx.receive(b"G0X1\r\nG0X2\rG0X3\n\n")
    assert [x.text for x in lines(rx)] == ["G0X1", "G0X2", "G0X3", ""]


def test_overlong_lines_are_flagged_whole():
    rx = GrblReceiver(line_max=10)
    rx.receive(b"G1 X123456 Y7890\nG0X1\n")
    assert lines(rx) == [RxLine("G1X123456Y", True), RxLine("G0X1", False)]


def test_reset_forgets_what_was_not_parsed():
    rx = GrblReceiver()
    rx.receive(b"G1X1\nG1 X")
    rx.take_line()
    rx.take_line()
    rx.receive(b"2\nG0")
    rx.reset()
    assert rx.free == RX_SIZE and rx.take_line() is None
    rx.receive(b"X9\n")
    assert lines(rx) == [RxLine("X9", False)]
