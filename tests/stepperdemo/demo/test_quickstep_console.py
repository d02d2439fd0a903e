"""StepperDemo's QuickStep commands: config mode l/q/p/b, the move hold, status lines."""

from __future__ import annotations

from fas.sim import SimBackend
from rigs.demo import EndReason, lines, run, text
from stepperdemo.demo.app import StepperDemo

TPS = 16_000_000


def test_config_commands_acknowledge_and_the_table_names_the_planner():
    app, reason = run("c M1 q20 p5 b200 l1 x ?")
    assert reason == EndReason.IDLE
    out = lines(app)
    assert "FIFO depth M1 = 20 orders (0 of 1024 bytes of RAM in use)" in out
    assert "plateaus M1 = 5" in out
    assert "base time = 200 us on timer 2 (8 bit, 12 .. 16384 us)" in out
    assert "planner M1: QuickStep, FIFO 20 orders, 5 plateaus, base time 200 us on timer 2" in out
    assert (">> M1: @0 acceleration  [steps/s^2]=0 speed [us/step]=0 planner=QuickStep "
            "fifo=0/20 plateaus=5 base=200us ") in out
    assert "   M2: @0 acceleration  [steps/s^2]=0 speed [us/step]=0 " in out


def test_bad_settings_change_nothing():
    app, _ = run("c M1 q20 l1 q0 q256 p0 b11 b16385 l7 x ?")
    t = text(app)
    assert t.count("ERROR") == 6
    assert "fifo=0/20 plateaus=8 base=auto" in t


def test_status_lines_show_the_plateau_and_the_ramp_state():
    app, _ = run("c M1 l1 p4 x M1 A2000 V200 R2000 W")
    status = [ln for ln in lines(app) if ln.startswith("M1: @")]
    assert any(ln.endswith(" ACC   QS 1/4 ") for ln in status)
    assert any(" COAST QS 4/4 " in ln or " ACC   QS 4/4 " in ln for ln in status)
    assert any(ln.endswith(" RED   QS 1/4 ") for ln in status)
    assert app.steppers[0].get_current_position() == 2000


def test_a_move_that_waits_for_room_holds_the_input_and_says_so():
    app, _ = run("c M1 q3 p4 l1 x M1 A2000 V200 R2000 R-500 W")
    out = lines(app)
    hold = out.index("QuickStep FIFO of M1 full: input held until the move is queued "
                     "(5 orders waiting)")
    released = out.index("QuickStep move queued")
    assert hold < released < out.index("Move steps -500")
    assert app.steppers[0].get_current_position() == 1500


def test_every_normal_mode_command_works_with_quickstep():
    app, reason = run("c M1 l1 p3 x M1 A3000 V300 f w300 K w100 S W b w200 X W "
                      "a-2000 w300 a0 w100 S W + - @100 P0 W U N F O R10 W ?")
    assert reason == EndReason.IDLE
    t = text(app)
    assert "Unknown command" not in t and "ERROR" not in t
    assert app.steppers[0].get_current_position() == 10
    assert not app.steppers[0].is_running()


def test_interactive_hold_then_release():
    backend = SimBackend("atmega328p")
    app = StepperDemo(backend, scripted=False)
    app.run_until(TPS // 10)
    app.feed("c M1 q2 p2 l1 x M1 A5000 V500 R400 ")
    app.run_until(backend.now() + 2 * TPS)  # (the usage text alone takes 0.2 s)
    assert app.qs_hold is None  # everything queued by now
    assert "QuickStep FIFO of M1 full" in text(app)
    app.feed("W ")
    app.run_until(backend.now() + 3 * TPS)
    assert "STOPPED" in text(app)
    assert app.steppers[0].get_current_position() == 400
