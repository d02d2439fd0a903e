"""Timer 0's start in build d (docs/timing-model.md, "twenty-ninth pass"): build d's
replica puts timer 0's overflow 405 ticks after the model's (60 runs, each to the tick;
414 where the start-up copied an odd number of bytes until the model rounded its copy up
to even, "thirtieth pass"); ``SimTiming.timer0_lag_ticks`` holds it (build d's default
since the fortieth pass)."""

from __future__ import annotations

from dataclasses import replace

import pytest

from fas.sim import timing as sim_timing
from fas.sim.backend import SimBackend
from stepperdemo.program import make_program

# the input's length -> the firmware's timer 0 start, mod 16 384 (the replica's first
# TIMER0_OVF vector - 96 - 4 - 16 384): d32, d02, d01, d21
FIRMWARE = {11: 11713, 18: 11785, 21: 11803, 30: 11893}


def _phase(n: int) -> tuple[int, int]:
    """(timer 0's start, the machine's next event after setup()) for a line of ``n`` bytes."""
    backend = SimBackend("atmega328p", build="d")
    app = make_program("demo", backend, scripted=True)
    app.load_script("M1 " * (n // 3) + "M1"[: n % 3] if n % 3 else "M1 " * (n // 3))
    app.setup()
    return backend.tick_at_millis(0), backend.next_event_time()  # type: ignore[return-value]


@pytest.mark.parametrize("n", sorted(FIRMWARE))
def test_the_lag_puts_timer_0_at_the_firmwares_start(n: int,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    lagged = sim_timing.BY_FAMILY["avr"]  # build d's 328P
    assert (lagged.timer0_lag_ticks, lagged.timer0_data_align) == (405, 2)
    monkeypatch.setitem(sim_timing.BY_FAMILY, "avr",
                        replace(lagged, timer0_lag_ticks=0, timer0_data_align=1))
    base, task = _phase(n)
    # without the lag early by it, for either parity: the start-up's copy is rounded up
    # to even bytes (boot_data_align, thirtieth pass; before it 414 where the line's
    # length was even)
    assert FIRMWARE[n] - base == 405
    monkeypatch.setitem(sim_timing.BY_FAMILY, "avr", lagged)
    assert _phase(n) == (FIRMWARE[n], task)  # setup() where it was
