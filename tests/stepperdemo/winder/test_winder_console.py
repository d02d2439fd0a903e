"""The winder in the interactive console (pipe input, fake clock) and on a device."""

from __future__ import annotations

import asyncio

from prompt_toolkit.document import Document
from prompt_toolkit.input import create_pipe_input
from prompt_toolkit.output import DummyOutput

from fas.device.loopback import Loopback
from fas.serial.protocol import F_INPUTS
from rigs.console import FakeClock, settle, wait
from stepperdemo.front.console import Console, ProgramCompleter
from stepperdemo.program import make_program

TPS = 16_000_000


def toolbar_text(console) -> str:
    return "".join(text for _style, text in console.toolbar())


def test_winder_repl_toolbar_completion_history_and_ctrl_c(tmp_path):
    async def main():
        clock = FakeClock()
        with create_pipe_input() as inp:
            console = Console("atmega328p", clock=clock, sleep=clock.sleep, input=inp,
                              output=DummyOutput(), history=str(tmp_path / "history"),
                              program="winder")
            task = asyncio.ensure_future(console.run())
            await settle()
            inp.send_text("ratio 1:2 interlock 1 pots pot 1 900\r")
            await settle()
            await wait(clock, 0.6)
            bar = toolbar_text(console)
            inp.send_text("status\r")
            await settle()
            await wait(clock, 0.2)
            inp.send_text("bogus 7\r")
            await settle()
            await wait(clock, 0.1)
            inp.send_text("\x03")  # Ctrl-C
            await settle()
            await wait(clock, 0.3)
            inp.send_text("\x04")
            rc = await asyncio.wait_for(task, 30)
            return console, bar, rc

    console, bar, rc = asyncio.run(main())
    assert rc == 0
    assert "A0=900" in bar and "S1:pot A0" in bar and "S2:interlock 1:2" in bar
    assert "interlock on 1:2 engaged" in bar and "A3-" in bar
    lines = console.lines
    assert "interlock engaged: S2 follows S1 at 1:2 (from S1 @0, S2 @0)" in lines
    assert any(ln.startswith("S1 spindle  @") for ln in lines)
    assert "ERROR unknown command 'bogus 7' (help: ?)" in lines
    assert "all steppers force-stopped" in lines
    app = console.app
    assert not app.steppers[0].is_running() and not app.steppers[1].is_running()
    s1, s2 = (s.get_current_position() for s in app.steppers)
    assert s1 > 0 and abs(s2 - s1 / 2) <= 1
    assert "pot 1 900" in (tmp_path / "history").read_text()
    words = [c.text for c in ProgramCompleter(console).get_completions(Document("mo"), None)]
    assert "move " in words  # the command and a space for its arguments


def test_on_a_board_the_pots_and_switches_are_its_pins():
    with Loopback(record=True, connect=False) as lb:
        dev = lb.device
        dev.features = F_INPUTS  # a board: no simulated inputs
        lb.backend = lb.open_backend()
        app = make_program("winder", lb.backend, scripted=True)
        base = dev.machine.now
        dev.schedule_input(base + TPS // 2, 14, 900, analog=True)  # A0
        dev.schedule_input(base + TPS, 14, 512, analog=True)
        app.run_script("pots pot 1 900 switch A3 1 w1500", max_ticks=10 * TPS)
        text = app.transcript.decode()
        assert "ERROR pot 1 900: on a device the pots are its pins" in text
        assert "ERROR switch A3 1: on a device the switches are its pins" in text
        assert lb.backend.settle()
        moved = dev.position(0)
        assert moved > 500 and moved == app.steppers[0].get_current_position()
        assert "S1 stopped at" in text


def test_a_simulated_device_takes_pot_and_switch_from_the_line():
    """The issue's lines through --port on the Python device: the host turns the
    device's simulated pot, the winder reads it back from the device's report."""
    with Loopback(record=True) as lb:
        dev = lb.device
        app = make_program("winder", lb.backend, scripted=True)
        app.run_script("pots pot 1 900 w500 pot 1 512 w800 period 2 50 move 2 65535 w300 "
                       "switch A3 1 w300", max_ticks=10 * TPS)
        text = app.transcript.decode()
        assert "ERROR" not in text
        assert "A0 = 900: S1 forward" in text and "S1 stopped at" in text
        assert "A3: S2 stopped at its upper limit" in text
        assert lb.backend.settle()
        switch = [t for t, lv in zip(*dev.recorder.pin_edges(17), strict=True) if lv == 0][-1]
        assert dev.recorder.rising(10)[-1] < switch  # not one step after the switch
        assert dev.position(1) == app.steppers[1].get_current_position() > 0
