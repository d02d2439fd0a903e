"""The README's first screen (issue 26): what it is, the two commands, a table of the
front ends with a link each; its in-page links lead to headings; CI runs its test
command."""

from __future__ import annotations

import re

from rigs import ROOT

README = (ROOT / "README.md").read_text(encoding="utf-8")
FRONT_ENDS = ("`stepperdemo`", "`stepperdemo -c ", "`stepperdemo run ", "`stepperdemo --port ",
              "`stepperdemo device`", "`stepperdemo --board ", "`stepperdemo gcode",
              "`stepperdemo winder`")
SCREEN = 45  # lines: what a newcomer sees before scrolling


def _slug(heading: str) -> str:
    """A heading's anchor as GitHub makes it."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def test_quick_start_has_the_two_commands_and_ci_runs_the_second():
    block = README.split("## Quick start\n", 1)[1].split("```sh\n", 1)[1].split("```", 1)[0]
    install, test = block.strip().splitlines()
    assert install == "python3 -m pip install . && stepperdemo"
    assert test == 'python3 -m pip install ".[test]" && python3 -m pytest'
    ci = (ROOT / ".ci" / "run").read_text().strip().splitlines()
    assert ci[-1] == test


def test_the_first_screen_has_a_table_of_the_front_ends_with_a_link_each():
    screen = README.splitlines()[:SCREEN]
    rows = [line for line in screen if line.startswith("| `stepperdemo")]
    assert len(rows) == 7
    for name in FRONT_ENDS:
        row = next((r for r in rows if name in r), None)
        assert row is not None, name
        assert re.search(r"\]\((#[\w-]+|docs/[\w.-]+)\)", row.split("|")[-2]), row


def test_every_in_page_link_leads_to_a_heading():
    anchors = {_slug(h) for h in re.findall(r"^#+ (.+)$", README, re.MULTILINE)}
    links = set(re.findall(r"\]\(#([\w-]+)\)", README))
    assert links and links <= anchors, links - anchors
    for doc in re.findall(r"\]\((docs/[\w.-]+)\)", README):
        assert (ROOT / doc).is_file(), doc
