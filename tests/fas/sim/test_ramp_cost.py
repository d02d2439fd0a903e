"""The ramp's log2 arithmetic per command, by value (build e, ``fill_cmd_maths``, off by
default; docs/timing-model.md, "twenty-first pass")."""

from __future__ import annotations

import sys
from dataclasses import replace
from pathlib import Path

import pytest

from fas.sim import timing as sim_timing_module
from fas.sim.channel import SimChannel
from fas.sim.ramp_cost import conversion_ticks, log2_window

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench"))

from .task_cpu import run_task_cpu  # noqa: E402

FAST = "M1 A30000 V45 f w1000 S W"  # ... up to 720 ticks a step (from 0.74 s)

# (ramp step, log2 value converted back, cycles of log2_from + leading_zeros +
# calculate_ticks + log2_to_u32 + log2_to_u16) of single commands of the firmware's
# replica, cycle by cycle (bench/replica/replica.py --profile pitches; the run named)
REPLICA_328P = [  # e01-e12, e17, e18
    (1, 7745, 361), (2, 7621, 349), (2, 8784, 374), (4, 8340, 362), (7, 7158, 329),
    (8, 8272, 355), (14, 6902, 322), (18, 7784, 328), (31, 6921, 328), (33, 7387, 326),
    (46, 6463, 316), (68, 6887, 316), (118, 6115, 306), (130, 7242, 304), (150, 6027, 299),
    (272, 6781, 360), (492, 5588, 333), (524, 5565, 336), (575, 5530, 336),
    (1045, 5878, 328), (1935, 5082, 350), (2066, 5058, 333), (4078, 5119, 353),
    (4156, 5369, 330), (8256, 4859, 332),
]
REPLICA_2560 = [  # e13, e14
    (1, 8257, 393), (4, 7572, 343), (10, 7233, 346), (17, 7037, 337), (41, 6712, 320),
    (69, 6520, 310), (140, 6259, 313), (264, 6025, 357), (551, 5753, 360),
    (1041, 5691, 345), (2136, 5252, 321), (4128, 5009, 346),
]


def test_log2_window_follows_the_librarys_paths() -> None:
    assert log2_window(1) == (1, False)
    assert log2_window(255) == (8, False)  # the 8-bit conversion: one table entry
    assert log2_window(300) == (9, False)  # 9 bits: the bits after the leading one end on 000
    # from 10 bits on, the three bits below the table's index decide: above 2, two entries
    assert log2_window(0xA03) == (12, True)
    assert log2_window(0xA02) == (12, False)
    assert log2_window(0x12345) == log2_window(0x1234)  # 17..20 bits: the value >> 4
    assert log2_window(0xFFFFFFFF)[0] == 16


@pytest.mark.parametrize(("timing", "cases"), [
    (sim_timing_module.AVR_E_TIMING, REPLICA_328P),
    (sim_timing_module.AVR_MEGA_E_TIMING, REPLICA_2560),
])
def test_the_conversions_cost_what_the_replica_spends(
        timing: sim_timing_module.SimTiming, cases: list[tuple[int, int, int]]) -> None:
    assert [conversion_ticks(timing, s, l2) for s, l2, _ in cases] == [c for _, _, c in cases]


def test_no_tables_no_cost() -> None:
    assert conversion_ticks(sim_timing_module.AVR_TIMING, 100, 5000) == 0


def _with(monkeypatch: pytest.MonkeyPatch, **fields: object) -> None:
    table = {k: replace(v, **fields) for k, v in sim_timing_module.BY_BUILD["e"].items()}
    monkeypatch.setitem(sim_timing_module.BY_BUILD, "e", table)


_run = run_task_cpu


def test_the_maths_is_charged_per_computed_command_only_when_on(
        monkeypatch: pytest.MonkeyPatch) -> None:
    base = _run(monkeypatch)
    _with(monkeypatch, fill_cmd_maths=False, fill_fast_acc_ticks=999)
    assert _run(monkeypatch) == base  # off: the tables and figures are not read
    cmd = sim_timing_module.AVR_E_TIMING.fill_cmd_ticks
    _with(monkeypatch, fill_cmd_ticks=cmd + 1000)
    every = (_run(monkeypatch)[1] - base[1]) // 1000  # the commands that are not coast ones
    # every such command took its period from a ramp step: each costs the tables' figure
    # (the one-step commands of the ramp's start keep fill_single_ticks)
    _with(monkeypatch, fill_cmd_ticks=cmd, fill_cmd_maths=True, ramp_log2_from_ticks=(100,) * 16,
          ramp_log2_to_ticks=(0,), ramp_log2_interp_ticks=0, fill_fast_acc_ticks=0)
    steps, stolen = _run(monkeypatch)
    assert steps == base[0]  # no `e`: the task's CPU moves no step
    assert stolen - base[1] == 100 * every
    # the check of too short commands: only accelerating ones from below 2 * 640 ticks
    _with(monkeypatch, ramp_log2_from_ticks=(0,) * 16, fill_fast_acc_ticks=1)
    assert _run(monkeypatch)[1] == base[1]  # the ramp up ends at 1 778 ticks a step
    _with(monkeypatch, fill_cmd_maths=False)
    fast_base = _run(monkeypatch, FAST)[1]
    _with(monkeypatch, fill_cmd_maths=True)
    fast = _run(monkeypatch, FAST)[1] - fast_base
    _with(monkeypatch, fill_cmd_maths=False, fill_cmd_ticks=cmd + 1000)
    fast_every = (_run(monkeypatch, FAST)[1] - fast_base) // 1000
    # the ramp up from 1 280 ticks a step to 720: 165 of the 738 commands
    assert 0 < fast < fast_every // 2


def test_the_channel_gets_the_ramps_own_values(monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[tuple[int, int]] = []
    original = SimChannel.ramp_converted

    def record(self: SimChannel, ramp_step: int, log2_ticks: int) -> None:
        seen.append((ramp_step, log2_ticks))
        original(self, ramp_step, log2_ticks)

    monkeypatch.setattr(SimChannel, "ramp_converted", record)
    _run(monkeypatch)
    steps = [s for s, _ in seen]
    # the ramp up converts rising ramp steps, the ramp down falling ones, down to 1
    top = steps.index(max(steps))
    assert steps[:top + 1] == sorted(steps[:top + 1]) and steps[0] <= 2
    assert steps[top:] == sorted(steps[top:], reverse=True) and steps[-1] <= 2
    assert all(0 < l2 < 16 * 512 for _, l2 in seen)  # periods below 65 536 ticks


def test_the_replicas_pitches_with_the_profile(tmp_path: Path) -> None:
    sys.path.insert(0, str(ROOT / "bench" / "replica"))
    import replica

    (tmp_path / "e09.funcs").write_text("100 200 __vector_13\n300 380 log2_from(unsigned long)\n")
    lines = [  # a task writing two commands of one stepper, a step interrupt nested
        "1000 V 13 | 1 1 |",
        "1400 P 0:380 -1:20", "1400 M 4 511 0 0 30 511",  # the ramp step: 30
        "1500 P 1:100", "1500 M 5 0 0 0 0 7083",  # the log2 value back
        "1600 P 0:100", "1600 M 0 727 1000 5 0 0",
        "1700 P 0:100", "1700 M 4 511 0 0 35 511", "1750 P 1:50", "1750 M 5 0 0 0 0 7037",
        "1800 V 11", "1900 R",
        "2100 P 0:250", "2100 M 0 727 900 5 0 0",
        "2500 P 0:400", "2500 R"]
    (tmp_path / "e09.ev").write_text("\n".join(lines) + "\n")
    (pitch,) = replica.pitches_of(tmp_path / "e09", 13)
    assert (pitch["kind"], pitch["ticks0"], pitch["ticks"], pitch["steps"]) == ("acc", 1000, 900, 5)
    # the CPU from the first write to the second, the nested interrupt's 100 left out
    assert (pitch["pitch"], pitch["nested"]) == (400, 1)
    assert (pitch["ramp_step"], pitch["log2_back"]) == (35, 7037)
    assert pitch["by_function"] == {"__vector_13": 350, "log2_from(unsigned long)": 50}
