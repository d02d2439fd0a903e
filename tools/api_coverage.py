"""Keep docs/api-coverage.md true: every Python name it lists exists where it says.

The coverage table maps each public name of FastAccelStepper's headers to ours, with
``file:line``.  This tool finds the definitions again:

    python tools/api_coverage.py            # check; exit 1 and list what is wrong
    python tools/api_coverage.py --update   # rewrite the file:line column

A Python reference is ``Class.member`` (``Stepper``, ``Drive``, ``Engine``, ``Profile``,
``PulseCounter``), ``module.name`` (``codes``, ``timed``, ``arch``, ``errors``) or
``Class.member / Class.other`` for a name served by two.

``--update`` also rewrites the table of known deviations (between the two marker
comments): every ``[known_deviation]`` entry of the scenario files in ``sequences/``,
with the value it names; the check fails while that table is out of date.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:  # Python 3.10: the same parser as a package (pyproject.toml)
    import tomli as tomllib

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "api-coverage.md"

OWNERS = {
    "Stepper": "fas/stepper.py", "Engine": "fas/engine.py", "Profile": "fas/arch.py",
    "DriverPool": "fas/arch.py", "PulseCounter": "fas/channel.py", "TimedMove": "fas/timed.py",
    "Drive": "fas/drive.py",
    "codes": "fas/codes.py", "timed": "fas/timed.py", "arch": "fas/arch.py",
    "errors": "fas/errors.py", "allocate": "fas/allocate.py", "StepperQueue": "fas/queue.py",
}
ROW = re.compile(r"^\|(?P<up>[^|]*)\|(?P<py>[^|]*)\|(?P<where>[^|]*)\|(?P<rest>.*)$")


def locate(ref: str) -> str | None:
    """``file:line`` of the definition of one reference, or None."""
    owner, _, name = ref.strip().strip("`").partition(".")
    path = OWNERS.get(owner)
    if path is None or not name:
        return None
    lines = (ROOT / path).read_text().splitlines()
    start = 0
    member, _, sub = name.partition(".")
    if owner[0].isupper():  # a class member: look inside the class body
        cls = re.compile(rf"^class {owner}\b")
        starts = [i for i, ln in enumerate(lines) if cls.match(ln)]
        if not starts:
            return None
        start = starts[0]
    elif sub:  # module.Class.MEMBER (enum members)
        cls = re.compile(rf"^class {member}\b")
        starts = [i for i, ln in enumerate(lines) if cls.match(ln)]
        if not starts:
            return None
        start, member = starts[0], sub
    pattern = re.compile(rf"^\s*(def {member}\(|class {member}\b|{member}\s*[:=])")
    for i in range(start, len(lines)):
        if i > start and owner[0].isupper() and re.match(r"^(class|def) ", lines[i]):
            break  # left the class
        if pattern.match(lines[i]):
            return f"{path}:{i + 1}"
    return None


def rows(text: str):
    for n, line in enumerate(text.splitlines()):
        m = ROW.match(line)
        if not m or "`" not in m["py"]:
            continue
        refs = [r for r in m["py"].split("/") if "`" in r]
        owners = [re.match(r"\s*`(\w+)\.", r) for r in refs]
        if not all(o and o.group(1) in OWNERS for o in owners):
            continue  # not a row of the name tables
        yield n, m, refs


KNOWN_START = "<!-- known deviations: tools/api_coverage.py --update writes this table -->"
KNOWN_END = "<!-- end of known deviations -->"


def known_table() -> str:
    """The known-deviation rows of every scenario file, as a Markdown table."""
    rows = ["| scenario | check | measured | why |", "| --- | --- | --- | --- |"]
    for path in sorted((ROOT / "sequences").rglob("*.toml")):
        data = tomllib.loads(path.read_text(encoding="utf-8"))
        for what, entry in data.get("known_deviation", {}).items():
            reason = str(entry.get("reason", "")).replace("|", "\\|")
            rows.append(f"| `{path.relative_to(ROOT / 'sequences')}` | "
                        f"{what.replace('|', chr(92) + '|')} | "
                        f"{entry['measured']} | {reason} |")
    return "\n".join(rows)


def _known_block(text: str) -> tuple[int, int] | None:
    start, end = text.find(KNOWN_START), text.find(KNOWN_END)
    return None if start < 0 or end < start else (start + len(KNOWN_START), end)


def check() -> list[str]:
    text = DOC.read_text()
    problems = []
    block = _known_block(text)
    if block is None:
        problems.append("the known-deviation table's markers are missing")
    elif text[block[0]:block[1]].strip() != known_table():
        problems.append("the known-deviation table is out of date (--update)")
    for _, m, refs in rows(text):
        wanted = ", ".join(locate(r) or "?" for r in refs)
        if "?" in wanted.split(", "):
            problems.append(f"{m['py'].strip()}: not found")
        elif m["where"].strip() != wanted:
            problems.append(f"{m['py'].strip()}: table says {m['where'].strip()}, "
                            f"defined at {wanted}")
    return problems


def update() -> None:
    text = DOC.read_text()
    block = _known_block(text)
    if block is not None:
        text = text[:block[0]] + "\n" + known_table() + "\n" + text[block[1]:]
        DOC.write_text(text)
    lines = DOC.read_text().splitlines()
    for n, m, refs in list(rows("\n".join(lines))):
        wanted = ", ".join(locate(r) or "?" for r in refs)
        lines[n] = f"|{m['up']}| {m['py'].strip()} | {wanted} |{m['rest']}"
    DOC.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    if "--update" in sys.argv[1:]:
        update()
    problems = check()
    for p in problems:
        print(p)
    sys.exit(1 if problems else 0)
