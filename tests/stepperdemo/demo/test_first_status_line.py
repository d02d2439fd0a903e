"""The first status line after a move is given: ``v=268435455us/4294967295ticks`` looks
like a bug (issue 26, item 10) but is what the original firmware prints before the
first command is queued (the library's "undefined" period).  Kept: the transcript is
the firmware's, line for line."""

from __future__ import annotations

import gzip

import pytest

from rigs import ROOT
from stepperdemo.front.cli import main
from stepperdemo.scenarios.scenario import load

REFERENCE = ROOT / "sequences" / "reference"


@pytest.mark.parametrize("run", ["d25", "d26", "d30"])
def test_the_first_status_line_is_the_firmwares(run, capsys):
    folder = REFERENCE / run
    with gzip.open(folder / "transcript.txt.gz", "rt", errors="replace") as f:
        firmware = [ln.rstrip("\r\n") for ln in f if ln.startswith("M1: @")]
    command = load(ROOT / "sequences" / "conformance" / f"{run}.toml").input
    main(["-c", command, "--lf"])
    ours = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("M1: @")]
    assert ours[0] == firmware[0]
    assert "v=268435455us/4294967295ticks ACC" in ours[0]
