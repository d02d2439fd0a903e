"""Frames, CRC-16 and messages of the serial protocol."""

import random

import pytest

from fas.serial.protocol import (
    MAX_PAYLOAD,
    SYNC,
    Config,
    DeviceStatus,
    Entry,
    ForceStop,
    FrameDecoder,
    Halt,
    Hello,
    Ident,
    Nak,
    Progress,
    ProtocolError,
    Start,
    Status,
    Truncate,
    crc16,
    decode_messages,
    encode_frame,
    pack_messages,
    seq_diff,
    tick_diff32,
)


def test_crc16_is_ccitt_false():
    assert crc16(b"123456789") == 0x29B1
    assert crc16(b"") == 0xFFFF


def test_frame_layout_is_length_seq_payload_crc_sync():
    frame = encode_frame(5, b"\x01\x02")
    assert frame[0] == len(frame) == 7
    assert frame[1] == 5
    assert frame[2:4] == b"\x01\x02"
    assert (frame[4] << 8 | frame[5]) == crc16(frame[:4])
    assert frame[-1] == SYNC


def test_decoder_takes_frames_split_anywhere():
    frames = [encode_frame(i, bytes([i] * (i % 7))) for i in range(20)]
    stream = b"".join(frames)
    rng = random.Random(3)
    dec = FrameDecoder()
    got = []
    pos = 0
    while pos < len(stream):
        n = rng.randint(1, 9)
        got += dec.feed(stream[pos:pos + n])
        pos += n
    assert got == [(i, bytes([i] * (i % 7))) for i in range(20)]
    assert dec.crc_errors == dec.framing_errors == dec.discarded_bytes == 0


@pytest.mark.parametrize("damage", ["flip", "drop", "dup"])
def test_decoder_loses_only_the_damaged_frame(damage):
    frames = [encode_frame(i, bytes([0x40, i, 3, 0x10, 0x27])) for i in range(3)]
    bad = bytearray(frames[1])
    if damage == "flip":
        bad[4] ^= 0x08
    elif damage == "drop":
        del bad[3]
    else:
        bad[3:3] = bad[3:4]
    dec = FrameDecoder()
    got = dec.feed(frames[0] + bytes(bad) + frames[2])
    assert [seq for seq, _ in got] == [0, 2]
    assert dec.crc_errors + dec.framing_errors >= 1


def test_messages_round_trip():
    msgs = [Hello(1, 0xBEEF, 500, 4), Config(1, 10, 7, 200, -123456), Start(3, 0xFFFFFFF0),
            Entry(5, 0x2A, 255, 65535, True, False, True, True),
            Entry(0, 3, 0, 640, False, True, False, False),
            Progress(1, 0x03, 17, 200), Progress(2, 0x07, 0, 0, -1234),
            Status(1, 3, 4, 5, -7, 123456, 2, 99),
            DeviceStatus(1, 4, *range(2, 21)),
            Ident(2, 2, 3, 16_000_000, 64_000_000, 2, 64, 8, 32, 500, 25000, 0, "atmega328p"),
            Truncate(1, 200), Halt(1, 7, 0xBEEF), ForceStop(0, 9, 255), Nak(5, 0xA001)]
    payload = b"".join(m.encode() for m in msgs)
    back = decode_messages(payload)
    # the entry carries 4 bits of its index
    assert back[3] == Entry(5, 0x0A, 255, 65535, True, False, True, True)
    assert back[:3] + back[4:] == msgs[:3] + msgs[4:]


def test_entry_is_five_bytes():
    assert len(Entry(1, 7, 200, 3000, False, True, True, False).encode()) == 5


def test_unknown_or_truncated_message_is_an_error():
    with pytest.raises(ProtocolError):
        decode_messages(b"\x3f")
    with pytest.raises(ProtocolError):
        decode_messages(Config(1, 10, 7, 0, 0).encode()[:-1])


def test_pack_messages_respects_the_payload_limit_and_order():
    enc = [Entry(0, i, 1, 1000, False, True, True, True).encode() for i in range(30)]
    payloads = pack_messages(enc, 24)
    assert all(len(p) <= 24 for p in payloads)
    assert b"".join(payloads) == b"".join(enc)
    assert all(len(p) <= MAX_PAYLOAD for p in pack_messages(enc))


def test_sequence_and_tick_arithmetic_wrap():
    assert seq_diff(2, 127) == 3
    assert seq_diff(127, 2) == -3
    assert tick_diff32(5, 0xFFFFFFFB) == 10
    assert tick_diff32(0xFFFFFFFB, 5) == -10
