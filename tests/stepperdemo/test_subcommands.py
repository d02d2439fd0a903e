"""``stepperdemo NAME``: one registry of subcommands (stepperdemo.subcommands)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from fas.sim import SimBackend
from rigs import ROOT
from stepperdemo import subcommands
from stepperdemo.demo import commands, quickstep
from stepperdemo.demo.app import StepperDemo
from stepperdemo.demo.command_table import CommandSet, CommandTable, Mode
from stepperdemo.front.cli import main
from stepperdemo.program import make_program, programs
from stepperdemo.scenarios.scenario import load
from stepperdemo.subcommands import SUBCOMMANDS, Subcommand

_GREETINGS = CommandSet()


@_GREETINGS.command("Z", Mode.NORMAL, hint="greet")
def _greet(app: StepperDemo, arg: bytes) -> bool:
    app.println("hello " + arg.decode("latin-1"))
    return True


class Greeter(StepperDemo):
    """A console program for the test: StepperDemo with one more command."""

    title = "Greeter"
    command_table = CommandTable(commands.FIRMWARE, quickstep.COMMANDS, _GREETINGS)


@pytest.fixture
def greeter(monkeypatch):
    """The new program, plugged in with its one registry entry."""
    monkeypatch.setitem(SUBCOMMANDS, "greeter", Subcommand(
        ("stepperdemo greeter [options]", "StepperDemo that greets (Z<name>)"),
        program=f"{__name__}:Greeter"))


def test_a_new_console_program_plugs_in_with_one_registry_entry(greeter, capsys, tmp_path):
    assert main(["greeter", "-c", "Zworld M1", "--lf"]) == 0
    out = capsys.readouterr().out
    assert "hello world\n" in out and "Unknown command" not in out
    # the console's help lists it, and it is a program of that name everywhere
    with pytest.raises(SystemExit):
        main(["--help"])
    assert ("  stepperdemo greeter [options]       StepperDemo that greets (Z<name>)"
            in capsys.readouterr().out.splitlines())
    assert programs()["greeter"] == f"{__name__}:Greeter"
    app = make_program("greeter", SimBackend("atmega328p"), scripted=True)
    assert isinstance(app, Greeter)
    scenario = tmp_path / "greet.toml"
    scenario.write_text('name = "greet"\nprogram = "greeter"\ninput = "Zyou"\n')
    assert load(str(scenario)).program == "greeter"


def test_the_help_lists_every_subcommand_of_the_registry(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    for name, sub in SUBCOMMANDS.items():
        usage, text = sub.help
        assert usage.startswith(f"stepperdemo {name}")
        assert f"  {usage:<35} {text.splitlines()[0]}" in out.splitlines()


def test_a_subcommand_runs_a_main_or_hosts_a_program():
    with pytest.raises(ValueError):
        Subcommand(("stepperdemo nothing", "does nothing"))
    for name, sub in SUBCOMMANDS.items():
        if sub.main is not None:
            assert callable(subcommands.main_of(name))
        if sub.program is not None:
            assert programs()[name] == sub.program


def _imports(path: Path) -> set[str]:
    """Every module a file imports (also inside functions), absolute."""
    package = ".".join(path.relative_to(ROOT).with_suffix("").parts[:-1])
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = package.split(".")[:len(package.split(".")) - node.level + 1] \
                if node.level else []
            module = ".".join(base + ([node.module] if node.module else []))
            found.add(module)
            found.update(f"{module}.{a.name}" for a in node.names)
    return found


def test_the_command_line_and_the_gcode_program_do_not_import_each_other():
    front = {p for p in (ROOT / "stepperdemo" / "front").glob("*.py")}
    front |= {ROOT / "stepperdemo" / "subcommands.py", ROOT / "stepperdemo" / "program.py"}
    for path in front:
        assert not any(m.startswith("stepperdemo.gcode") for m in _imports(path)), path
    for path in (ROOT / "stepperdemo" / "gcode").glob("*.py"):
        assert "stepperdemo.front.cli" not in _imports(path), path


def _help(capsys, *argv: str) -> str:
    with pytest.raises(SystemExit) as end:
        main([*argv, "--help"])
    assert end.value.code == 0
    return capsys.readouterr().out


def test_no_help_text_speaks_of_our_issues_or_seeds(capsys):
    # a user reads --help; "issue 15" and "seed 002" are the project's notes, not theirs
    import re

    for argv in ((), *((name,) for name in SUBCOMMANDS)):
        text = _help(capsys, *argv)
        assert not re.search(r"\b(issue|seed)s? ?\d", text, re.IGNORECASE), (argv, text)


def test_a_hosted_program_lists_only_the_options_that_apply_to_it(capsys):
    demo_only = ("--firmware-end", "--test-mode-wait", "--board", "--log", "--quiet-ms",
                 "--boot-wait")
    demo = _help(capsys)
    assert all(option in demo for option in demo_only)
    winder = _help(capsys, "winder")
    assert [option for option in demo_only if option in winder] == []
    assert "--port" in winder and "--vcd" in winder
    with pytest.raises(SystemExit) as end:  # and argparse refuses them
        main(["winder", "--board", "/dev/null", "-c", "status"])
    assert end.value.code == 2
    assert "unrecognized arguments: --board" in capsys.readouterr().err
    assert main(["winder", "-c", "move 1 10 w100", "--lf"]) == 0  # the defaults stand in
