"""docs/architecture.md stays true: its recipes run as they stand, every file it names
exists, and the arrows it states hold.

A recipe is a ``### `` section of the page's "Recipes".  Its ``python`` blocks run in
order: ``# new module: PATH`` makes PATH's module (as an import would), ``# add to:
PATH`` runs the lines in that module's namespace (as if appended to the file), any
other block runs as a script; a ``text`` block after a script is what the script
prints.  Whatever the blocks add to modules is taken away again afterwards.
"""

from __future__ import annotations

import ast
import importlib
import io
import re
import sys
import types
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "architecture.md"
FENCE = re.compile(r"^```(\w*)\n(.*?)^```", re.M | re.S)
NEW = "# new module: "
ADD = "# add to: "


def module_name(path: str) -> str:
    return path.removesuffix(".py").replace("/", ".")


def recipes() -> dict[str, list[tuple[str, str]]]:
    """Recipe title -> its code blocks ``(language, code)`` in page order."""
    text = DOC.read_text()
    part = text.split("\n## 3. Recipes", 1)[1].split("\n## ", 1)[0]
    pieces = re.split(r"^### (.+)$", part, flags=re.M)
    return {title.strip(): [(m.group(1), m.group(2)) for m in FENCE.finditer(body)]
            for title, body in zip(pieces[1::2], pieces[2::2], strict=True)}


class Sandbox:
    """Runs recipe blocks; :meth:`restore` undoes what they did to modules."""

    def __init__(self) -> None:
        self.saved: dict[str, tuple[types.ModuleType, dict, dict]] = {}
        self.new: list[str] = []

    def _save(self, module: types.ModuleType) -> None:
        if module.__name__ not in self.saved:
            names = dict(module.__dict__)
            tables = {k: dict(v) for k, v in names.items() if type(v) is dict
                      and not k.startswith("__")}
            self.saved[module.__name__] = (module, names, tables)

    def new_module(self, path: str, code: str) -> None:
        name = module_name(path)
        assert not (ROOT / path).exists(), f"the recipe's {path} exists in the tree"
        parent = importlib.import_module(name.rpartition(".")[0])
        self._save(parent)
        module = types.ModuleType(name)
        module.__file__ = str(ROOT / path)
        module.__package__ = parent.__name__
        sys.modules[name] = module
        self.new.append(name)
        exec(compile(code, path, "exec"), module.__dict__)
        setattr(parent, name.rpartition(".")[2], module)

    def add_to(self, path: str, code: str) -> None:
        assert (ROOT / path).exists(), path
        module = importlib.import_module(module_name(path))
        self._save(module)
        exec(compile(code, f"{path} (added)", "exec"), module.__dict__)

    def script(self, code: str, title: str) -> bytes:
        out = io.TextIOWrapper(io.BytesIO(), encoding="utf-8")
        stdout, sys.stdout = sys.stdout, out
        try:
            exec(compile(code, f"docs/architecture.md: {title}", "exec"),
                 {"__name__": "__recipe__"})
        finally:
            sys.stdout = stdout
        out.flush()
        return out.buffer.getvalue()  # type: ignore[attr-defined]

    def run(self, title: str) -> None:
        printed = None
        for language, code in recipes()[title]:
            first = code.split("\n", 1)[0]
            if language == "text":
                assert printed is not None, "an output block follows a script"
                assert printed.decode().replace("\r\n", "\n") == code
            elif first.startswith(NEW):
                self.new_module(first.removeprefix(NEW).strip(), code)
            elif first.startswith(ADD):
                self.add_to(first.removeprefix(ADD).strip(), code)
            else:
                printed = self.script(code, title)

    def restore(self) -> None:
        for name in self.new:
            sys.modules.pop(name, None)
        for module, names, tables in self.saved.values():
            for key in set(module.__dict__) - set(names):
                del module.__dict__[key]
            module.__dict__.update(names)
            for key, table in tables.items():
                names[key].clear()
                names[key].update(table)


@pytest.fixture
def sandbox() -> Iterator[Sandbox]:
    box = Sandbox()
    try:
        yield box
    finally:
        box.restore()


# ----------------------------------------------------------------- the recipes
def test_the_page_has_the_three_recipes_of_issue_22() -> None:
    assert list(recipes()) == ["Add a planner", "Add a chip profile", "Add a console program"]


def test_planner_recipe_registers_a_planner_that_moves_a_stepper(sandbox) -> None:
    from fas import planners

    sandbox.run("Add a planner")  # its script asserts positions and step periods
    assert "steady" in planners.names()
    sandbox.restore()
    assert "steady" not in planners.names() and "fas.steady" not in sys.modules


def test_chip_recipe_runs_stepperdemo_on_the_new_profile(sandbox, capsys) -> None:
    from fas.arch import PROFILES
    from fas.sim import SimBackend
    from stepperdemo.chip_sheet import chip_sheet
    from stepperdemo.chip_sheet import main as sheet_main
    from stepperdemo.demo.app import StepperDemo
    from stepperdemo.front.cli import main as cli_main

    sandbox.run("Add a chip profile")
    line = "M1 A1000 V100 R3200 W"
    runs = {}
    for name in ("atmega168", "atmega328p"):  # the 328P's figures: the same run, tick for tick
        backend = SimBackend(name, record=True)
        demo = StepperDemo(backend)
        demo.run_script(line)
        assert backend.recorder is not None
        runs[name] = (bytes(demo.transcript), backend.now(), backend.recorder.rising(9))
    assert runs["atmega168"] == runs["atmega328p"]
    assert len(runs["atmega168"][2]) == 3200
    sheet = chip_sheet("atmega168")
    assert sheet.chip.ram_bytes == 1024 and sheet.outputs.user_digital_pins == (2, 4, 12, 14)
    assert sheet_main(["atmega168"]) == 0
    assert "(none: this chip has no quickstep table)" in capsys.readouterr().out
    out = io.TextIOWrapper(io.BytesIO(), encoding="utf-8")
    stdout, sys.stdout = sys.stdout, out
    try:  # what `stepperdemo --arch atmega168 -c LINE` runs
        assert cli_main(["--arch", "atmega168", "-c", line]) == 0
    finally:
        sys.stdout = stdout
    out.flush()
    assert out.buffer.getvalue() == runs["atmega328p"][0]  # type: ignore[attr-defined]
    sandbox.restore()
    assert "atmega168" not in PROFILES


def test_program_recipe_is_hosted_through_the_subcommand_registry(sandbox, capsys) -> None:
    from fas.sim import SimBackend
    from stepperdemo.front.cli import main as cli_main
    from stepperdemo.program import make_program, programs
    from stepperdemo.subcommands import SUBCOMMANDS

    sandbox.run("Add a console program")  # stepperdemo jog -c "...": the page's output
    assert programs()["jog"] == "stepperdemo.jog:Jog"
    with pytest.raises(SystemExit):
        cli_main(["--help"])
    assert "stepperdemo jog" in capsys.readouterr().out
    jog = make_program("jog", SimBackend("esp32"), scripted=False)  # typed, in real time
    jog.run_until(16_000)
    jog.feed("-25\n")
    assert jog.input_pending() and jog.next_wake_tick() == jog.backend.now()
    jog.run_until(16_000_000)
    assert jog.transcript.decode().splitlines()[1:] == ["@-25"]
    assert jog.next_wake_tick() is None and jog.mode_name() == "jog"
    sandbox.restore()
    assert "jog" not in SUBCOMMANDS and "stepperdemo.jog" not in sys.modules


# ------------------------------------------------------------ what the page says
def test_every_file_the_page_names_exists() -> None:
    text = DOC.read_text()
    named = set(re.findall(r"`((?:fas|stepperdemo|tests|docs|firmware)/[\w/.-]*)`", text))
    named |= {"stepperdemo/" + p for p in re.findall(
        r"`((?:demo|front|watch|scenarios)/[\w/.-]*)`", text)}
    new = {line.removeprefix(NEW).strip() for line in text.splitlines()
           if line.startswith(NEW)}
    assert len(named) > 40
    missing = sorted(p for p in named - new
                     if "<" not in p and not (ROOT / p).exists())
    assert missing == []
    assert all(not (ROOT / p).exists() for p in new)


def test_fas_never_imports_stepperdemo() -> None:
    found = []
    for path in sorted((ROOT / "fas").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom)
                     and node.level == 0 else [])
            found += [f"{path.relative_to(ROOT)}: {n}" for n in names
                      if n == "stepperdemo" or n.startswith("stepperdemo.")]
    assert found == []
