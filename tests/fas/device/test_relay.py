"""The fault-injecting line: seeded faults, latency and baud-rate pacing."""

import pytest

from fas.device.relay import Faults, FaultyLine


def _run(faults: Faults, data: bytes, seed: int = 7):
    line = FaultyLine(faults, seed)
    line.take(data, 0)
    return line, line.due(10**12)


def test_clean_line_passes_everything_after_the_latency():
    line = FaultyLine(Faults(latency_ms=2), 1)
    line.take(b"abc", 1000)
    assert line.due(1000 + 1_999_999) == b""
    assert line.due(1000 + 2_000_000) == b"abc"


def test_pacing_spaces_bytes_by_ten_bit_times():
    line = FaultyLine(Faults(baud=115200), 1)
    line.take(b"\x00" * 10, 0)
    byte_ns = 10 * 10**9 // 115200
    assert line.next_ns() == byte_ns
    assert len(line.due(5 * byte_ns)) == 5
    assert len(line.due(10 * byte_ns)) == 5


def test_fault_rates_follow_the_probabilities():
    data = bytes(range(256)) * 400
    line, out = _run(Faults(drop=0.01, corrupt=0.02, dup=0.03), data)
    st = line.stats
    n = len(data)
    assert st.bytes_in == n
    for count, p in ((st.dropped, 0.01), (st.corrupted, 0.02), (st.duplicated, 0.03)):
        assert abs(count - p * n) < 5 * (p * n) ** 0.5
    assert len(out) == st.bytes_out == n - st.dropped + st.duplicated


def test_faults_are_reproducible_from_the_seed():
    data = bytes(range(256)) * 20
    f = Faults(drop=0.01, corrupt=0.01, dup=0.01)
    assert _run(f, data, 5)[1] == _run(f, data, 5)[1]
    assert _run(f, data, 5)[1] != _run(f, data, 6)[1]


def test_bad_probabilities_are_refused():
    with pytest.raises(ValueError):
        Faults(drop=1.5)
    with pytest.raises(ValueError):
        Faults(drop=0.6, corrupt=0.6)


def test_stall_holds_every_byte_until_it_ends():
    line = FaultyLine(Faults(stall_ms=50, stall_every_ms=300), 1)
    ms = 1_000_000
    line.take(b"a", 100 * ms)  # outside a stall: at once
    line.take(b"b", 310 * ms)  # inside the stall 300..350 ms
    line.take(b"c", 349 * ms)
    line.take(b"d", 351 * ms)
    assert line.due(100 * ms) == b"a"
    assert line.due(349 * ms) == b""
    assert line.due(350 * ms) == b"bc"  # all at once when the line moves again
    assert line.due(351 * ms) == b"d"


def test_stalls_need_a_longer_period():
    with pytest.raises(ValueError):
        Faults(stall_ms=50)
    with pytest.raises(ValueError):
        Faults(stall_ms=50, stall_every_ms=40)


def test_bursts_deliver_at_the_latency_timer():
    line = FaultyLine(Faults(chunk_ms=16), 1)
    line.take(b"xy", 1_000_000)
    assert line.due(15_999_999) == b""
    assert line.due(16_000_000) == b"xy"
