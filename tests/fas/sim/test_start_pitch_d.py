"""Build d's start task: a starting ramp's commands by the branches their planning took
(docs/timing-model.md, "forty-seventh pass"): the replica's ``_getNextCommand()`` costs
more where it looks at the ramp's coast near the speed (a period under two
``MIN_CMD_TICKS``) and multiplies for it, less for a coast (no ``calculate_ticks()``),
more for a decelerating command (``BUILD_D_REPLICA_START_PITCH_TICKS``, variant R47 of
``bench/d_corpus.py``; off: the one figure ``fill_unstarted_multi_cmd_ticks`` for every
such command)."""

from __future__ import annotations

import pytest

from fas.arch import ATMEGA328P
from fas.codes import PATH_CHECK, PATH_COAST, PATH_DEC, PATH_NEAR
from fas.sim import SimBackend
from fas.sim import timing as sim_timing_module
from fas.sim.channel import SimChannel
from fas.sim.ramp_cost import start_pitch_ticks
from fas.sim.timing import sim_timing
from stepperdemo.program import make_program

from .build_d_with import default_with

NEAR, CHECK = PATH_NEAR, PATH_NEAR | PATH_CHECK
# four starts at 1 000 000 steps/s^2, the start task's 14 commands each (the inputs of
# d23, test_sd_09, test_sd_02 and d35) and the branches their planning took after the
# first (one step): eight alike (a period over 1 280 ticks), then near the speed with
# (R1500, R500: 1..510 steps possible to coast) or without (R3200, R20000) the coast
# check's multiplication; test_sd_09's last command decelerates, test_sd_02's last
# coasts at V50's 800 ticks
STARTS = {
    "M1 V30 A1000000 R1500 W": [0] * 8 + [CHECK] * 5,  # d23
    # test_sd_09
    "M1 A1000000 V40 R500 W A100 b w1000 S ? W": [0] * 8 + [CHECK] * 4 + [CHECK | PATH_DEC],
    "? M1 A1000000 V50 R3200 W t W": [0] * 8 + [NEAR] * 4 + [PATH_COAST],  # test_sd_02
    "M1 A1000000 V40 e R20000 W": [0] * 8 + [NEAR] * 5,  # d35
}
SLOW = "M1 A2000 V150 R6000 W"  # d01: a start task of one-step commands only

# the firmware's first step (steps_A.tsv, us) of the four runs above and d01
FIRMWARE_FIRST_STEP_US = {
    "M1 V30 A1000000 R1500 W": 232186.688,
    "M1 A1000000 V40 R500 W A100 b w1000 S ? W": 232215.000,
    "? M1 A1000000 V50 R3200 W t W": 449219.688,
    "M1 A1000000 V40 e R20000 W": 240355.562,
    SLOW: 230613.062,
}


def _start_task(text: str) -> tuple[int, list[tuple[int, int]]]:
    """The first rise of A and the (steps, path) of every write in a task while the
    queue had not started."""
    writes: list[tuple[int, int]] = []
    saved = SimChannel.entry_added

    def entry_added(self: SimChannel) -> None:
        if self.m.in_task and not self.running:
            q = self.q
            writes.append((q.entries[(q.next_write_idx - 1) % q.queue_len].total_steps,
                           self.ramp_path))
        saved(self)

    SimChannel.entry_added = entry_added  # type: ignore[method-assign]
    try:
        backend = SimBackend("atmega328p", record=True, build="d")
        app = make_program("demo", backend, scripted=True)
        app.run_script(text, firmware_end=True)
    finally:
        SimChannel.entry_added = saved  # type: ignore[method-assign]
    return _first_rise(backend), writes


def _first_rise(backend: SimBackend) -> int:
    import sys

    from rigs import ROOT

    sys.path.insert(0, str(ROOT / "bench" / "replica"))
    import pulse_widths  # noqa: PLC0415

    return pulse_widths.backend_pulses(backend)["A"][0][0]


def test_r47_sets_build_ds_table_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    # build d's default since the fiftieth pass; PRE49 puts back the figures before it
    assert (sim_timing(ATMEGA328P, "d").fill_start_pitch_ticks
            == sim_timing_module.BUILD_D_REPLICA_START_PITCH_TICKS)
    assert sim_timing_module.AVR_TIMING.fill_start_pitch_ticks == ()  # the fitted table
    e_before = sim_timing(ATMEGA328P, "e")
    default_with(monkeypatch, "PRE49")
    assert sim_timing(ATMEGA328P, "d").fill_start_pitch_ticks == ()  # off before
    default_with(monkeypatch, "R47")
    d = sim_timing(ATMEGA328P, "d")
    assert d.fill_start_pitch_ticks == sim_timing_module.BUILD_D_REPLICA_START_PITCH_TICKS
    assert sim_timing(ATMEGA328P, "e") == e_before
    assert sim_timing_module.AVR_TIMING.fill_start_pitch_ticks == ()


def test_the_figures_by_branch() -> None:
    plain, near, check, coast, dec = fig = (-17, 29, 90, -364, 118)
    assert start_pitch_ticks(fig, 0) == plain
    assert start_pitch_ticks(fig, NEAR) == plain + near
    assert start_pitch_ticks(fig, CHECK) == plain + near + check
    assert start_pitch_ticks(fig, CHECK | PATH_DEC) == plain + near + check + dec
    assert start_pitch_ticks(fig, PATH_COAST) == plain + coast


@pytest.mark.parametrize("text", list(STARTS))
def test_the_planner_tells_the_branches_of_each_starting_command(text: str) -> None:
    _, writes = _start_task(text)
    assert writes[0] == (1, 0)  # the first command: one step
    first = writes[1:len(STARTS[text]) + 1]  # the first start's (test_sd_09 starts twice)
    assert [path for _, path in first] == STARTS[text]
    assert all(steps > 1 for steps, _ in first)


def test_r47_moves_each_start_by_its_commands_and_a_slow_start_not_at_all(
        monkeypatch: pytest.MonkeyPatch) -> None:
    # (against the figures before the fiftieth pass, which made R47 and the seven
    # others build d's default: their values below)
    default_with(monkeypatch, "PRE49")
    before = {text: _start_task(text) for text in [*STARTS, SLOW]}
    default_with(monkeypatch, "R47")
    after = {text: _start_task(text) for text in [*STARTS, SLOW]}
    fig = sim_timing_module.BUILD_D_REPLICA_START_PITCH_TICKS
    for text, paths in STARTS.items():
        assert after[text][1] == before[text][1]  # the same commands
        moved = sum(start_pitch_ticks(fig, p) for p in paths)  # the first start's
        assert after[text][0] - before[text][0] == moved, text
    assert after[SLOW] == before[SLOW]
    # the first steps against the firmware's, re-measured (before: -805, -1096, +129,
    # -368): nearer but for test_sd_02, whose +449 of pitch had covered the task's nested
    # interrupts (-166) and tail (-118; bench/replica/start_steps.py)
    fw = {t: round(us * 16) for t, us in FIRMWARE_FIRST_STEP_US.items()}
    assert [before[t][0] - fw[t] for t in STARTS] == [-805, -1096, 129, -368]
    assert [after[t][0] - fw[t] for t in STARTS] == [-311, -544, -182, -289]
    assert after[SLOW][0] - fw[SLOW] == before[SLOW][0] - fw[SLOW] == -77


def test_r47_charges_the_start_tasks_commands_only(monkeypatch: pytest.MonkeyPatch) -> None:
    """d35 writes hundreds of commands of several steps; R47 charges the 13 its start
    task writes before the queue starts, none written to the running queue."""
    from fas.sim import channel as channel_module

    calls: list[int] = []
    saved = channel_module.start_pitch_ticks

    def counted(figures: tuple[int, ...], path: int) -> int:
        calls.append(path)
        return saved(figures, path)

    monkeypatch.setattr(channel_module, "start_pitch_ticks", counted)
    default_with(monkeypatch, "PRE49")  # the figures before the fiftieth pass
    _start_task("M1 A1000000 V40 e R20000 W")
    assert calls == []  # off: not called
    default_with(monkeypatch, "R47")
    _start_task("M1 A1000000 V40 e R20000 W")
    assert calls == STARTS["M1 A1000000 V40 e R20000 W"]
