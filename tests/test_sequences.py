"""Every scenario file in sequences/ runs and meets its expectations."""

from pathlib import Path

import pytest

from stepperdemo.scenarios.runner import run_file
from stepperdemo.scenarios.scenario import collect, load

ROOT = Path(__file__).resolve().parent.parent
FILES = collect([ROOT / "sequences"])


def _param(path: Path):
    marks = [pytest.mark.long] if load(path).long else []
    return pytest.param(path, id=str(path.relative_to(ROOT / "sequences")), marks=marks)


@pytest.mark.parametrize("path", [_param(p) for p in FILES])
def test_scenario(path):
    res = run_file(path)
    failed = [c for c in res.checks if not c.ok]
    assert res.error is None, res.error
    assert not failed, "\n".join(
        f"{c.what}: expected {c.expected}, measured {c.measured}, tolerance {c.tolerance}"
        for c in failed)


def test_every_conformance_folder_has_a_scenario():
    conformance = ROOT.parent / "shared" / "conformance"
    if not conformance.is_dir():
        pytest.skip("the conformance data is not on this machine")
    names = {p.stem for p in (ROOT / "sequences" / "conformance").glob("*.toml")}
    folders = {p.name for p in conformance.iterdir() if p.is_dir()}
    assert folders <= names
