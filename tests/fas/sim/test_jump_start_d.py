"""Build d's first write with linear acceleration (`J`) or a jump start (`j`), the model
beside its replica (docs/timing-model.md, "forty-sixth pass"): the ramp config's
``update()`` computes the cubic ramp's figures where s_h > 0
(``BUILD_D_REPLICA_CUBIC_UPDATE_TICKS``, variant H46 of ``bench/d_corpus.py``), a start
from rest computes ``calculate_ticks(s_jump)`` where s_jump > 0, and
``calculate_ramp_steps()`` where that jump is over the maximum speed
(``BUILD_D_REPLICA_JUMP_START_TICKS``, variant Q46).  Both build d's default since the
forty-sixth pass (the corpus passes with them); the other chips and builds keep 0."""

from __future__ import annotations

import pytest

from fas.arch import ATMEGA328P
from fas.ramp import generator as generator_module
from fas.sim import SimBackend
from fas.sim import timing as sim_timing_module
from fas.sim.timing import sim_timing
from stepperdemo.program import make_program

from .build_d_with import d_corpus, default_with

#: both charges off on build d's default (the model before the forty-sixth pass)
OFF = ["fill_cubic_update_ticks=0", "fill_jump_start_ticks=0,0"]

# the firmware's first step of each run (steps_A.tsv: 234 581.500, 235 167.875,
# 235 060.938 and 230 613.062 us) in ticks
FIRMWARE_FIRST_STEP = {
    "M1 A2000 V400 J100 R3000 W": 3753304,  # d05
    "M1 A2000 V400 j30 R3000 W": 3762686,  # d06
    "M1 A2000 V400 J300 j60 R5000 W": 3760975,  # d07
    "M1 A2000 V150 R6000 W": 3689809,  # d01: neither
}


def _first_rise(backend: SimBackend) -> int:
    import sys

    from rigs import ROOT

    sys.path.insert(0, str(ROOT / "bench" / "replica"))
    import pulse_widths  # noqa: PLC0415

    return pulse_widths.backend_pulses(backend)["A"][0][0]


def _offsets() -> dict[str, int]:
    return {text: _first_rise_of(text) - fw for text, fw in FIRMWARE_FIRST_STEP.items()}


def _first_rise_of(text: str) -> int:
    backend = SimBackend("atmega328p", record=True, build="d")
    app = make_program("demo", backend, scripted=True)
    app.run_script(text, firmware_end=True)
    return _first_rise(backend)


def test_h46_q46_set_build_ds_table_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    d = sim_timing(ATMEGA328P, "d")
    assert d.fill_cubic_update_ticks == sim_timing_module.BUILD_D_REPLICA_CUBIC_UPDATE_TICKS
    assert d.fill_jump_start_ticks == sim_timing_module.BUILD_D_REPLICA_JUMP_START_TICKS
    # the other AVR chips and builds keep the fitted table's 0
    fitted = sim_timing_module.AVR_TIMING
    assert (fitted.fill_cubic_update_ticks, fitted.fill_jump_start_ticks) == (0, ())
    e_before = sim_timing(ATMEGA328P, "e")
    default_with(monkeypatch)
    d_corpus.set_build_d(OFF)
    d = sim_timing(ATMEGA328P, "d")
    assert (d.fill_cubic_update_ticks, sum(d.fill_jump_start_ticks)) == (0, 0)
    default_with(monkeypatch, "H46", "Q46")  # absolute: back to the default's figures
    d = sim_timing(ATMEGA328P, "d")
    assert d.fill_cubic_update_ticks == sim_timing_module.BUILD_D_REPLICA_CUBIC_UPDATE_TICKS
    assert d.fill_jump_start_ticks == sim_timing_module.BUILD_D_REPLICA_JUMP_START_TICKS
    e = sim_timing(ATMEGA328P, "e")
    assert (e.fill_cubic_update_ticks, e.fill_jump_start_ticks) == (
        e_before.fill_cubic_update_ticks, e_before.fill_jump_start_ticks)


@pytest.mark.parametrize(("text", "cubic", "jump"), [
    ("M1 A2000 V400 J100 R3000 W", [True], [0]),
    ("M1 A2000 V400 j30 R3000 W", [False], [1]),
    ("M1 A2000 V400 j5000 R3000 W", [False], [2]),  # over the maximum speed: clipped
    ("M1 A2000 V400 J300 j60 R5000 W", [True], [1]),
    ("M1 A2000 V150 R6000 W", [False], [0]),
])
def test_the_generator_says_what_it_computed_for_a_moves_first_command(
        monkeypatch: pytest.MonkeyPatch, text: str, cubic: list[bool], jump: list[int]) -> None:
    seen: list[tuple[bool, int]] = []
    saved = generator_module.RampGenerator.get_next_command

    def get_next_command(self: generator_module.RampGenerator, *a: object) -> object:
        first = self._parameters.apply
        cmd = saved(self, *a)  # type: ignore[arg-type]
        if first:
            seen.append((self.cubic_updated, self.jump_maths))
        return cmd

    monkeypatch.setattr(generator_module.RampGenerator, "get_next_command", get_next_command)
    _first_rise_of(text)
    assert seen == list(zip(cubic, jump, strict=True))


def test_h46_q46_move_the_first_steps_toward_the_firmware(
        monkeypatch: pytest.MonkeyPatch) -> None:
    default_with(monkeypatch)
    d_corpus.set_build_d(OFF)
    before = _offsets()
    # without them: the first step early by the computation's cost (the replica's first
    # write -289 / -286 / -641 ticks, forty-fifth pass); d01 (neither) as it was
    assert [before[t] for t in FIRMWARE_FIRST_STEP] == [-355, -388, -882, -77]
    d_corpus.set_build_d(["fill_jump_start_ticks=0,0"] + d_corpus.VARIANTS["H46"])
    h46 = _offsets()
    default_with(monkeypatch, "H46", "Q46")  # the default
    both = _offsets()
    d05, d06, d07, d01 = FIRMWARE_FIRST_STEP
    # H46 moves the runs with `J` by its figure and the one without nothing
    assert h46[d05] - before[d05] == sim_timing_module.BUILD_D_REPLICA_CUBIC_UPDATE_TICKS
    assert h46[d07] - before[d07] == sim_timing_module.BUILD_D_REPLICA_CUBIC_UPDATE_TICKS
    assert h46[d06] == before[d06]
    # Q46 the runs with `j` (neither clipped)
    jump = sim_timing_module.BUILD_D_REPLICA_JUMP_START_TICKS[0]
    assert both[d06] - h46[d06] == jump
    assert both[d07] - h46[d07] == jump
    assert both[d05] == h46[d05]
    assert both[d01] == h46[d01] == before[d01]
    # each nearer the firmware: within the 96 ticks of the replica's own lead and the
    # nested interrupts' shortfall (start_steps.py's `nested`: -120..-144 here)
    for text in (d05, d06, d07):
        assert abs(both[text]) < abs(before[text])
    assert [both[t] for t in FIRMWARE_FIRST_STEP] == [-32, -47, -218, -77]
