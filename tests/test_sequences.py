"""Every scenario file in sequences/ runs and meets its expectations."""

from pathlib import Path

import pytest

from rigs import ROOT
from stepperdemo.scenarios.runner import known_summary, run_file
from stepperdemo.scenarios.scenario import collect, load

FILES = collect([ROOT / "sequences"])


class KnownDeviation(Exception):
    """A scenario's [known_deviation] checks still fail, as the file says."""


def _param(path: Path):
    sc = load(path)
    marks = [pytest.mark.long] if sc.long else []
    if sc.known_deviations:  # strict: the day one of them is met, the test fails
        reason = "; ".join(f"{what}: measured {entry['measured']}"
                           + (f" ({entry['reason']})" if "reason" in entry else "")
                           for what, entry in sc.known_deviations.items())
        marks.append(pytest.mark.xfail(strict=True, raises=KnownDeviation, reason=reason))
    return pytest.param(path, id=str(path.relative_to(ROOT / "sequences")), marks=marks)


@pytest.mark.parametrize("path", [_param(p) for p in FILES])
def test_scenario(path):
    res = run_file(path)
    failed = [c for c in res.checks if not c.ok]
    assert res.error is None, res.error
    # every other check passes, and every known deviation is still there (a met one is
    # a failed check: "MET: remove from known_deviation")
    assert not failed, "\n".join(
        f"{c.what}: expected {c.expected}, measured {c.measured}, tolerance {c.tolerance}"
        + (" - a known deviation met: remove it from [known_deviation]" if c.known else "")
        for c in failed)
    if any(c.known for c in res.checks):
        raise KnownDeviation(known_summary(res))


def test_every_conformance_folder_has_a_scenario():
    conformance = ROOT.parent / "shared" / "conformance"
    if not conformance.is_dir():
        pytest.skip("the conformance data is not on this machine")
    names = {p.stem for p in (ROOT / "sequences" / "conformance").glob("*.toml")}
    folders = {p.name for p in conformance.iterdir() if p.is_dir()}
    assert folders <= names


def _local_runs() -> list[Path]:
    """Runs of a local build of the firmware (issue 16: commands during fast motion)."""
    return sorted(p.parent for p in (ROOT / "sequences" / "reference").glob("*/run_info.json"))


def test_during_motion_runs_land_within_the_promised_bound():
    """Commands taken while a stepper runs fast (``w``, ``U``, ``S``/``X`` at 2-20 kHz):
    final positions within max(10 steps, 0.5 %) of the firmware's, for a dozen runs."""
    import json

    runs = _local_runs()
    assert len(runs) >= 12
    for ref in runs:
        info = json.loads((ref / "run_info.json").read_text())
        sc = load(ROOT / "sequences" / "conformance" / f"{ref.name}.toml")
        assert sc.input == info["input"].strip() and sc.reference == ref
        for exp in sc.steppers:
            if exp.letter not in info["position_from_pins"]:
                continue
            position = info["position_from_pins"][exp.letter]
            assert exp.values["position"] == position
            bound = max(10, abs(position) // 200)
            assert exp.tol.get("position", 0) <= bound, (ref.name, exp.tol)
