"""Every profile's G-code (issue 24, item 6): StepperDemo's g mode and ``stepperdemo gcode``
answer $$, ? and a move with the profile's steppers (at most six axes); and the
G-code console's dead ends of issue 26 item 9."""

import pytest

from fas.arch import PROFILES
from fas.sim import SimBackend
from rigs.console import run_session, settle, wait
from stepperdemo.demo.app import StepperDemo
from stepperdemo.front.cli import main
from stepperdemo.gcode.program import RawGrbl

TPS = 16_000_000


@pytest.mark.parametrize("arch", sorted(PROFILES))
def test_every_profiles_g_mode_answers_settings_status_and_a_move(arch):
    backend = SimBackend(arch)
    app = StepperDemo(backend, scripted=True)
    app.run_script("g\n$$\n?\nG1 X200 F60000\n?\nx\n", max_ticks=60 * TPS)
    text = app.transcript.decode()
    gmode = text[text.index("Grbl 1.1h"):text.index("Exit to main menu")]
    out = gmode.split("\r\n")
    axes = min(6, sum(1 for s in app.steppers if s is not None))
    assert f"$10{max(axes, 3) - 1}=1.000" in out and f"$10{max(axes, 3)}=1.000" not in out
    assert out.count("ok") == 4 and "error" not in gmode, gmode  # ? then LF: ok
    status = [ln for ln in out if ln.startswith("<")]
    assert status[0].startswith("<Idle|MPos:" + ",".join(["0.000"] * max(axes, 3)) + "|")
    assert status[1].startswith("<Run|") or status[1].startswith("<Idle|")
    assert app.steppers[0].get_current_position() == 200
    assert app.exit_code() == 0


@pytest.mark.parametrize("arch", sorted(PROFILES))
def test_every_profiles_gcode_program(arch):
    g = RawGrbl(arch)
    g.send(b"$$\nG1 X200 F60000\n?")
    assert g.settle(60)
    out = g.take().decode()
    assert "error" not in out and out.count("ok") == 2  # $$ and G1 (the ? is real-time)
    assert g.machine.positions()[0] == 200
    demo = StepperDemo(SimBackend(arch), scripted=True)
    demo.setup()
    wired = sum(1 for s in demo.steppers if s is not None)  # as StepperDemo connects them
    assert g.machine.axes == min(3, wired)
    assert RawGrbl(arch, axes=9).machine.axes == min(6, wired)


def test_esp32_g_mode_runs_six_axes_and_refuses_opposite_moves_on_a_shared_dir_pin():
    backend = SimBackend("esp32")
    app = StepperDemo(backend, scripted=True)
    app.run_script("g\nG0 X10 Y10 Z10 A10 B10 C10\nG0 X0 Y10\nG0 X5 Y0\nx\n", max_ticks=60 * TPS)
    text = app.transcript.decode()
    assert "[MSG:axes X and Y share direction pin 18: they cannot move in opposite " \
           "directions in one line]\r\nerror:33" in text
    assert [app.steppers[i].get_current_position() for i in range(7)] == [0, 10, 10, 10, 10,
                                                                          10, 0]


def test_a_block_ends_only_at_a_line_end_and_the_run_says_so(capsys):
    rc = main(["-c", "g G1 X100 F6000 x ?"])
    out = capsys.readouterr().out
    assert "<Idle|MPos:0.000,0.000,0.000|Bf:15,128|FS:0,0|WCO:0.000,0.000,0.000>" in out
    assert "[MSG:not executed: 'G1X100F6000X' has no line end (a block ends at LF or " \
           "CR; in -c write $'...\\n...')]" in out
    assert rc == 1
    rc = main(["-c", "g\nG1 X100 F6000\nx\n?"])
    assert rc == 0 and "ok" in capsys.readouterr().out


def test_a_scenario_file_is_not_taken_for_gcode(capsys):
    assert main(["gcode", "sequences/gcode/servo_sweep.toml"]) == 2
    err = capsys.readouterr().err
    assert "sequences/gcode/servo_sweep.toml is a scenario file, not G-code: run it with " \
           "'stepperdemo run sequences/gcode/servo_sweep.toml' (its G-code: " \
           "sequences/gcode/servo_sweep.gcode)" in err


def test_ctrl_x_in_the_gcode_console_is_a_soft_reset(tmp_path):
    async def script(inp, clock, console):
        inp.send_text("G1 X3000 F60000\r")
        await settle()
        await wait(clock, 0.5)
        inp.send_text("\x18")  # Ctrl-X
        await settle()
        await wait(clock, 0.3)
        inp.send_text("$X\r")
        await settle()
        await wait(clock, 0.2)

    console, rc = run_session(script, tmp_path, "atmega328p", program="gcode",
                              program_options={"axes": 2})
    lines = console.lines
    assert lines.count("Grbl 1.1h ['$' for help]") == 2
    assert "ALARM:3" in lines and "[MSG:Caution: Unlocked]" in lines
    assert 0 < console.app.steppers[0].get_current_position() < 3000


def test_ctrl_x_in_the_g_mode_of_the_stepperdemo_console(tmp_path):
    async def script(inp, clock, console):
        inp.send_text("g\r")
        await settle()
        await wait(clock, 0.3)
        inp.send_text("\x18")
        await settle()
        await wait(clock, 0.3)

    console, _ = run_session(script, tmp_path, "atmega328p")
    assert console.lines.count("Grbl 1.1h ['$' for help]") == 2
