"""The model's ramp-task tick beside the replica's timer wrap (``bench/replica/task_wrap.py``;
docs/timing-model.md, "twenty-fifth pass")."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench" / "replica"))

import task_wrap  # noqa: E402


def test_the_models_task_phase_is_its_task_timeline() -> None:
    ph = task_wrap.model_task_phase("M1 A1000 V100 R200 W", "e")
    assert 0 <= ph < task_wrap.PERIOD
    # the phase follows the build's figure: build d's task comes 144 ticks later
    # than build e's on a quiet console (twenty-third pass), so the two differ
    assert task_wrap.model_task_phase("M1 A1000 V100 R200 W", "d") != ph


def test_the_wrap_is_read_from_the_replicas_timer_file(tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    work = tmp_path / "w"
    work.mkdir()
    conf = tmp_path / "c"
    (conf / "x").mkdir(parents=True)
    (conf / "x" / "input.txt").write_text("M1 A1000 V100 R200 W\n")
    ph = task_wrap.model_task_phase("M1 A1000 V100 R200 W", "e")
    wrap = (ph + 221) % task_wrap.PERIOD
    lines = [f"T {wrap + k * task_wrap.PERIOD}" for k in range(1, 5)]
    (work / "x.timer").write_text("\n".join(lines) + "\n")
    assert task_wrap.main(["--work", str(work), "--conformance", str(conf), "x"]) == 0
    assert capsys.readouterr().out.strip() == (
        f"x: model task {ph}, replica wrap {wrap}, wrap - task 221 ticks")
    assert task_wrap.signed(65530) == -6 and task_wrap.signed(6) == 6
