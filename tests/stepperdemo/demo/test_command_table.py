"""StepperDemo's command table: command sets registered explicitly, numbers as strtol."""

from __future__ import annotations

from fas.sim import SimBackend
from stepperdemo.demo import commands, quickstep
from stepperdemo.demo.app import StepperDemo
from stepperdemo.demo.command_registry import COMMANDS
from stepperdemo.demo.command_table import CommandSet, CommandTable, Mode
from stepperdemo.demo.parsing import LONG_MAX, LONG_MIN, parse_number, parse_values, strtol


def test_numbers_parse_like_the_firmwares_strtol():
    assert strtol(b"  -12ab") == (-12, 5)
    assert strtol(b"x") == (0, 0)
    assert parse_number(b"") == 0  # an empty argument is 0, as in the firmware
    assert parse_number(b"12x") is None
    assert parse_number(b"99999999999") == LONG_MAX
    assert parse_number(b"-99999999999") == LONG_MIN
    assert parse_values(b"1,2,3") == [1, 2, 3]
    assert parse_values(b"1,2,3,4") is None
    assert parse_values(b"1,") is None
    assert parse_values(b"") is None


def test_a_command_module_declares_its_set_and_registers_nothing_by_itself():
    # QuickStep's config commands are in the table because the registry names them
    assert (Mode.CONFIG, ord("l")) in COMMANDS.handlers
    assert (Mode.CONFIG, ord("l")) not in CommandTable(commands.FIRMWARE).handlers
    assert ("l<0|1>", "planner: l0 FastAccelStepper ramp, l1 QuickStep") in \
        COMMANDS.hints(Mode.CONFIG)
    assert [e[0] for e in quickstep.COMMANDS.entries] == ["l", "q", "p", "b"]
    assert StepperDemo.command_table is COMMANDS


def test_a_new_command_set_plugs_in_with_one_table_entry():
    extra = CommandSet()
    seen: list[bytes] = []

    @extra.command("Z", Mode.NORMAL, hint="say hello", arg="<n>")
    def cmd_hello(app: StepperDemo, arg: bytes) -> bool:
        seen.append(arg)
        app.println("hello")
        return True

    app = StepperDemo(SimBackend("atmega328p"), scripted=True)
    app.command_table = CommandTable(commands.FIRMWARE, quickstep.COMMANDS, extra)
    app.run_script("Z42 M1 Z")
    assert seen == [b"42", b""]
    assert app.transcript.count(b"hello\r\n") == 2
    assert ("Z<n>", "say hello") in app.command_table.hints(Mode.NORMAL)
    # without it the letter is unknown, as before
    plain = StepperDemo(SimBackend("atmega328p"), scripted=True)
    plain.run_script("Z42")
    assert b"Unknown command: Z42" in plain.transcript
