"""Build d's print body from a buffer read from its replica (docs/timing-model.md,
"thirty-ninth pass"): StepperDemo's ``DemoBuild.buffer_char_ticks`` (variant P39 of
``bench/d_corpus.py``), the tails read again under it (T39), and the corpus files that
build d's read variants close with it.  All of them are build d's default since the fortieth
pass (build d) (``READ`` on top of the fitted figures, the variant FIT, is that default)."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from stepperdemo.demo import build as demo_build_module
from stepperdemo.demo.build import (
    BUILD_D_REPLICA_COMMAND_TAILS,
    BUILD_D_REPLICA_PRINT_BODY,
    BUILD_D_REPLICA_RUNNING_TAILS,
    BUILD_D_REPLICA_TAILS_P39,
)
from stepperdemo.scenarios.runner import run_file

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench"))
sys.path.insert(0, str(ROOT / "bench" / "replica"))

import command_costs  # noqa: E402
import d_corpus  # noqa: E402

from .test_coast_tails_d import _d_with  # noqa: E402

# build d as read from its replica, with the print body and the tails read under it
READ = ["D33", "P30", "L34", "W34", "C37", "P39", "T39", "E45", "H46", "Q46",
        # ... and six of the eight of the forty-second to forty-seventh passes (fiftieth;
        # not the ramp task's sections K43 and T44)
        "R47", "S42", "P43", "L43", "N44", "F44"]


def _writes(name: str) -> list[tuple[bytes, list[int] | None, bool]]:
    """Every console write of ``sequences/conformance/<name>.toml``: (its text, the CPU
    after each character beyond char_ticks, whether it came from the message table)."""
    with command_costs.model_hooks() as log:
        res = run_file(ROOT / "sequences" / "conformance" / f"{name}.toml")
    assert res.error is None, res.error
    return log["write_data"]


def test_a_buffer_prints_characters_cost_107_the_tables_are_unchanged(
        monkeypatch: pytest.MonkeyPatch) -> None:
    _d_with(monkeypatch, ["D33", "P30"])
    before = _writes("d34")
    d_corpus.set_build_d(d_corpus.VARIANTS["P39"])
    after = _writes("d34")
    assert [w[0] for w in after][:40] == [w[0] for w in before][:40]
    buffer = table = 0
    for (data, cpu0, tab0), (data1, cpu1, tab1) in zip(before[:40], after[:40], strict=True):
        assert data1 == data and tab1 == tab0
        if tab0:  # the message table's texts keep their look-ups and char_ticks
            assert cpu1 == cpu0
            table += 1
        else:  # a number, a line end, a status line's piece: 121 - 14 a character
            assert cpu0 is None and cpu1 == [-14] * len(data)
            buffer += 1
    assert buffer >= 10 and table >= 3


def test_the_body_is_the_replicas_and_build_ds_328ps_alone() -> None:
    # 1 990 prints from a buffer without a wait for room, each 14 ticks a gap under 121
    # (bench/replica/command_costs.py's marks on build d's replica of dm01-dm12, d21,
    # d34, test_sd_07)
    assert BUILD_D_REPLICA_PRINT_BODY == {"buffer_char_ticks": 107}
    assert d_corpus.VARIANTS["P39"] == ["buffer_char_ticks=107"]
    builds = [*demo_build_module.BY_PROFILE.items(),
              *(item for table in demo_build_module.BY_BUILD.values() for item in table.items())]
    assert [(name, b.buffer_char_ticks) for name, b in builds if b.buffer_char_ticks] == [
        ("atmega328p", 107)]  # build d's (build e's 328P keeps the timing's char_ticks)


def test_the_tails_read_under_the_body_are_14_more_where_a_buffer_print_ends() -> None:
    old = {**BUILD_D_REPLICA_COMMAND_TAILS, **BUILD_D_REPLICA_RUNNING_TAILS}
    assert set(BUILD_D_REPLICA_TAILS_P39) == set(old)
    ends_in_buffer = set("ASVRfHX")  # a number's or a line end's "\r\n" last
    for letter, ticks in BUILD_D_REPLICA_TAILS_P39.items():
        assert ticks == old[letter] + (14 if letter in ends_in_buffer else 0), letter
    assert d_corpus.VARIANTS["T39"] == [f"cmd_tail_ticks.{k}={v}"
                                        for k, v in BUILD_D_REPLICA_TAILS_P39.items()]


def test_the_tails_reader_counts_a_buffer_prints_last_character() -> None:
    log = {"cmd": [(100, "A1000"), (5000, "U")],
           "spend": [(100, 680), (2100, 330), (2430, 330)],
           "write": [2000], "write_len": [2], "write_last": [-14]}
    assert command_costs.model_tails(log) == [660 - 14]
    log["write_last"] = [0]  # a table's text: char_ticks alone
    assert command_costs.model_tails(log) == [660]


def _check(name: str, what: str) -> object:
    res = run_file(ROOT / "sequences" / "conformance" / f"{name}.toml")
    assert res.error is None, res.error
    (check,) = [c for c in res.checks if c.what == what]
    return check


# the four former known deviations of build d's 328P (docs/api-coverage.md until the
# fortieth pass) and the files the read variants left out before the body (test_sd_07,
# dm09) or closed (d34, test_sd_18): build d's default as read meets the firmware
@pytest.mark.parametrize("name,what", [
    ("d14", "A pulse high total us"),
    ("d21", "A position"),
    ("d21", "A pulses"),
    ("d35", "A pulse high total us"),
    ("d38", "A pulse high total us"),
    ("test_sd_07_328p", "A pulse high total us"),
    ("dm09", "A position"),
    ("d34", "A position"),
    ("test_sd_18_328p", "A step time max |dev| us"),
])
def test_build_d_as_read_meets_the_firmware(name: str, what: str) -> None:
    check = _check(name, what)  # build d's default figures
    assert abs(check.measured - check.expected) <= check.tolerance  # type: ignore[attr-defined]


def test_without_the_body_test_sd_07_is_412(monkeypatch: pytest.MonkeyPatch) -> None:
    _d_with(monkeypatch, ["D33", "P30", "L34", "T34", "W34", "C37", "T37"])
    assert round(_check("test_sd_07_328p", "A pulse high total us").measured) == 412  # type: ignore[attr-defined]
    d_corpus.set_build_d(d_corpus.VARIANTS["P39"])
    assert round(_check("test_sd_07_328p", "A pulse high total us").measured) == 416  # type: ignore[attr-defined]


def test_the_read_variants_on_the_fitted_figures_are_build_ds_default(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """One source of truth: the fitted figures with the variants read make the default's
    tables, and the variants once more change nothing (the task's phase, a difference
    read against the fitted one, is not added twice)."""
    from fas.sim import timing as sim_timing_module  # noqa: PLC0415

    tm = sim_timing_module.BY_BUILD["d_time_measurement"]
    default = (sim_timing_module.BY_FAMILY["avr"], tm["atmega328p"],
               demo_build_module.BY_PROFILE["atmega328p"])
    assert READ == d_corpus.DEFAULT_READ
    assert default[0].task_phase_ticks == sim_timing_module.AVR_TIMING.task_phase_ticks + 217

    def now() -> tuple[object, ...]:
        b = demo_build_module.BY_PROFILE["atmega328p"]
        return (sim_timing_module.BY_FAMILY["avr"], tm["atmega328p"], b, b.cmd_ticks,
                b.cmd_tail_ticks)

    want = (*default, default[2].cmd_ticks, default[2].cmd_tail_ticks)
    _d_with(monkeypatch, READ)  # (FIT first)
    assert now() == want
    d_corpus.set_build_d([s for v in READ for s in d_corpus.VARIANTS[v]])
    assert now() == want
    d_corpus.set_build_d(d_corpus.VARIANTS["FIT"])
    assert sim_timing_module.BY_FAMILY["avr"] is sim_timing_module.AVR_TIMING
    assert demo_build_module.BY_PROFILE["atmega328p"] is demo_build_module.ATMEGA328P_FITTED_BUILD
