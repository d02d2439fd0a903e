"""Grbl 1.1's controller byte by byte on virtual time (issue 24): real-time bytes, states,
feed hold along the path, jogs, resets and alarms, reports, $ commands."""

import math

import pytest

from stepperdemo.gcode.program import RawGrbl

TPS = 16_000_000
X_STEP, Y_STEP = 6, 7  # atmega2560: StepperDemo's steppers 1 and 2
MM = "$100=80\n$101=80\n$102=80\n$110=12000\n$111=12000\n$120=500\n$121=500\n"


def grbl(arch: str = "atmega2560", setup: str = "", **kw) -> RawGrbl:
    g = RawGrbl(arch, record=True, **kw)
    if setup:
        g.send(setup.encode())
        g.settle()
    g.take()
    return g


def lines(data: bytes) -> list[str]:
    return data.decode().split("\r\n")[:-1]


def status(g: RawGrbl) -> str:
    g.send(b"?")
    out = [ln for ln in lines(g.take()) if ln.startswith("<")]
    return out[-1]


def test_realtime_bytes_act_mid_line_and_leave_the_line_whole():
    g = grbl()
    g.send(b"G1 X1?0 F6")
    assert lines(g.take())[0].startswith("<Idle|MPos:0.000,0.000,0.000|Bf:15,119|")
    g.send(b"000\n")
    g.settle()
    assert g.take() == b"ok\r\n"
    assert g.machine.positions()[0] == 10


def test_bytes_at_or_above_0x80_never_enter_a_line_and_overlong_lines_are_error_11():
    g = grbl()
    g.send(b"G1 X\xc3\xa95 F6000\n")  # an e-acute: both bytes dropped (0xA9 is no command)
    long_line = b"G0 X" + b"1" * 300 + b"\n"
    for at in range(0, len(long_line), 100):  # as a sender would: never past the ring
        g.send(long_line[at:at + 100])
    g.send(b"G0 Y2\n")
    g.settle()
    assert lines(g.take()) == ["ok", "[MSG:line longer than 255 characters]", "error:11", "ok"]
    assert g.machine.positions()[:2] == [5, 2]
    assert g.machine.rx.dropped_high == 2


def test_unknown_words_and_lines_in_alarm_answer_error_and_the_session_goes_on():
    g = grbl()
    g.send(b"G1 X10 F600 W3\nhello world\nG2 X1 Y1 R0.5 F9\nG0 X3\n")
    g.settle()
    assert lines(g.take()) == [
        "[MSG:unknown word W3]", "error:20",
        "[MSG:H needs a number: 'HELLOWORLD' is not G-code]", "error:2",
        "[MSG:arc radius R0.5 is less than half the distance to the target (0.707107)]",
        "error:34",
        "ok"]
    g.send(b"G0 X400\n")
    g.advance(0.01)
    g.send(b"\x18")  # reset while moving: ALARM:3, locked
    g.send(b"G0 X0\n$X\nG0 X0\n")
    g.settle()
    out = lines(g.take())
    assert out[:5] == ["ok", "[MSG:reset while moving; the position may be lost]", "ALARM:3",
                       "", "Grbl 1.1h ['$' for help]"]
    assert out[5:] == ["[MSG:'$H'|'$X' to unlock]",
                       "[MSG:alarm lock: $X to unlock (or ctrl-x)]", "error:9",
                       "[MSG:Caution: Unlocked]", "ok", "ok"]
    assert g.machine.positions()[0] == 0 and g.machine.alarms == 1


def test_empty_lines_cr_lf_and_lone_cr_answer_once_each():
    g = grbl()
    g.send(b"\n\r\nG0 X1\rG0 X2\r\n")
    g.settle()
    assert lines(g.take()) == ["ok", "ok", "ok", "ok"]


def hold_program(g: RawGrbl) -> None:
    """A diagonal at 6000 mm/min on an 80 steps/mm machine: 16000 x 8000 steps."""
    g.send(b"G1 X200 Y100 F6000\n")
    g.advance(1.0)  # cruising (the acceleration takes 0.2 s)


def test_feed_hold_decelerates_along_the_path_and_resume_loses_no_step():
    g = grbl(setup=MM)
    hold_program(g)
    assert lines(g.take()) == ["ok"]
    asked = g.backend.now()
    g.send(b"!?")
    assert lines(g.take())[0].startswith("<Hold:1|")
    g.send(b"~")  # during Hold:1: lost, as in Grbl
    g.advance(0.5)
    assert status(g).startswith("<Hold:0|") and g.machine.hold
    rec = g.machine.executor.holds[-1]
    rec_ahead = g.machine.executor.ahead_ticks + g.machine.executor.piece
    assert asked <= rec.frontier <= asked + rec_ahead  # the deceleration begins this soon
    rising = g.backend.recorder.rising
    # from the pins: the speed before the deceleration and the distance after it
    for pin, n, accel in ((X_STEP, 16000, 500 * 80), (Y_STEP, 8000, 500 * 80 / 2)):
        edges = rising(pin)
        before = [t for t in edges if t < rec.frontier]
        window = [t for t in before if t >= rec.frontier - TPS // 2]  # cruising
        v = (len(window) - 1) / ((window[-1] - window[0]) / TPS)  # steps/s
        # where the axis is when the deceleration begins (between two steps), and where
        # v^2 / 2a later it must stand: the steps it makes are those it passes
        at_frontier = len(before) + (rec.frontier - before[-1]) / TPS * v
        stop = at_frontier + v * v / (2 * accel)
        assert abs(len(edges) - stop) <= 1, (pin, len(edges), stop, v)
        decel_steps = len(edges) - len(before)
        assert decel_steps > 300 * n / 16000  # a real deceleration, not a stop
        periods = [b - a for a, b in zip(edges[len(before):], edges[len(before) + 1:],
                                         strict=False)]
        assert all(b >= a - 2 for a, b in zip(periods, periods[1:], strict=False))  # slower
    g.send(b"~")
    assert g.settle()
    assert g.machine.positions()[:2] == [16000, 8000]
    xs, ys = rising(X_STEP), rising(Y_STEP)
    assert (len(xs), len(ys)) == (16000, 8000)  # every step made once, none lost
    assert xs[-1] == ys[-1]  # and the last ones together
    x = y = 0
    worst = 0.0
    for _t, axis in sorted([(t, 0) for t in xs] + [(t, 1) for t in ys]):
        x, y = x + (axis == 0), y + (axis == 1)
        worst = max(worst, abs(x * 8000 - y * 16000) / math.hypot(16000, 8000))
    assert worst <= 1.0  # on the line through acceleration, hold, stop and restart


def test_synchronized_output_holds_the_parser_so_an_immediate_one_cannot_overtake():
    g = grbl()
    g.send(b"G1 X400 F24000\nM62 P0\nG1 X800 F24000\nM65 P0\n")
    g.settle()
    assert lines(g.take()) == ["ok"] * 4
    xs = g.backend.recorder.rising(X_STEP)
    times, levels = g.backend.recorder.pin_edges(22)  # Dout0
    (rise,) = [t for t, lv in zip(times, levels, strict=True) if lv]
    (fall,) = [t for t, lv in zip(times, levels, strict=True) if not lv]
    assert xs[399] < rise < xs[400]  # M62: after the first move, before the second
    second_start = g.machine.motion_log[1][0]
    assert second_start <= fall < xs[-1]  # M65: at once, once the second move is under way
    assert g.backend.read_pin(22) == 0


def test_dwell_holds_the_parser_and_a_hold_pauses_it():
    g = grbl()
    g.send(b"G4 P0.5\nM64 P1\n")
    g.advance(0.2)
    g.send(b"!")
    g.advance(1.0)  # the dwell does not run on during the hold
    assert g.backend.read_pin(23) == 0 and status(g).startswith("<Hold:0")
    g.send(b"~")
    g.advance(0.25)
    assert g.backend.read_pin(23) == 0
    g.advance(0.1)
    assert g.backend.read_pin(23) == 1
    assert lines(g.take()) == ["ok", "ok"]


def test_jog_and_jog_cancel():
    g = grbl(setup=MM)
    g.send(b"$J=G91 X100 F6000\n")
    g.advance(0.5)
    assert lines(g.take()) == ["ok"]
    assert status(g).startswith("<Jog|")
    g.send(b"G0 Y1\n$J=X1 F1\n")  # G-code waits while jogging; a jog needs G91/G90
    g.advance(0.001)
    assert lines(g.take())[:2] == ["[MSG:G-code waits while jogging (0x85 cancels the jog)]",
                                   "error:9"]
    g.send(b"\x85")
    g.settle()
    stopped = g.machine.positions()[0]
    assert 0 < stopped < 8000 and status(g).startswith("<Idle|")
    assert g.machine.interp.position_steps[0] == stopped  # the parser is where it stopped
    g.send(b"G91 G0 X1\n")
    g.settle()
    assert g.machine.positions()[0] == stopped + 80
    g.send(b"$J=G91 X10 F1000\n")
    g.settle()
    assert g.machine.positions()[0] == stopped + 80 + 800


@pytest.mark.parametrize("line, code", [
    ("$J=G91 X10", 22), ("$J=G91 F100", 26), ("$J=G91 G1 X1 F100", 16), ("$JX=1", 16),
    ("$H", 5), ("$22=1", 3), ("$20=1", 10), ("$32=2", 3), ("$0=2", 6), ("$1=-1", 4),
    ("$Z", 2), ("$$$", 3), ("$RST=X", 3), ("$999=1", 3), ("$N5=G0", 3), ("$110=abc", 2),
])
def test_dollar_commands_refused_with_grbls_number(line, code):
    g = grbl()
    g.send(line.encode() + b"\n")
    g.settle()
    assert lines(g.take())[-1] == f"error:{code}"


def test_state_rules_for_dollar_commands():
    g = grbl()
    g.send(b"G1 X5000 F60000\n")
    g.advance(0.05)
    g.send(b"$$\n$#\n$J=X1 F1\n$G\n")
    g.advance(0.01)
    out = lines(g.take())
    assert out[1:] == ["[MSG:not now: the machine is in Run]", "error:8"] * 2 + [
        "[MSG:jogging only when Idle or jogging, not in Run]", "error:8",
        "[GC:G1 G54 G17 G21 G90 G94 M5 M9 T0 F60000 S0]", "ok"]


def test_reports_wco_ov_and_bf_on_grbls_schedule():
    g = grbl()
    assert status(g) == "<Idle|MPos:0.000,0.000,0.000|Bf:15,128|FS:0,0|WCO:0.000,0.000,0.000>"
    assert status(g) == "<Idle|MPos:0.000,0.000,0.000|Bf:15,128|FS:0,0|Ov:100,100,100>"
    assert status(g) == "<Idle|MPos:0.000,0.000,0.000|Bf:15,128|FS:0,0>"
    g.send(b"G0 X20\nG92 X0\n")
    g.settle()
    g.take()
    assert status(g) == "<Idle|MPos:20.000,0.000,0.000|Bf:15,128|FS:0,0|WCO:20.000,0.000,0.000>"
    g.send(b"$10=0\n")
    g.settle()
    assert status(g) == "<Idle|WPos:0.000,0.000,0.000|FS:0,0>"
    g.send(b"G92.1\n\x91\x91\x97")
    g.settle()
    assert status(g) == "<Idle|WPos:20.000,0.000,0.000|FS:0,0|WCO:0.000,0.000,0.000>"
    assert status(g) == "<Idle|WPos:20.000,0.000,0.000|FS:0,0|Ov:120,25,100>"
    g.send(b"#define\n")  # a line starting with a non-letter
    g.settle()
    assert lines(g.take())[-1] == "error:1"


def test_feed_override_changes_the_speed_at_once_and_fs_shows_it():
    g = grbl(setup=MM)
    g.send(b"G1 X400 F3000\n")
    g.advance(1.0)
    assert "|FS:3000,0" in status(g)
    g.send(b"\x91\x91\x91")  # +30 %
    g.advance(0.5)
    assert "|FS:3900,0|Ov:130,100,100" in status(g)
    g.send(b"\x90")
    g.advance(0.5)
    assert "|FS:3000,0" in status(g)
    assert g.settle() and g.machine.positions()[0] == 32000


def test_idle_hold_door_m0_and_sleep_states():
    g = grbl()
    g.send(b"!")
    assert status(g).startswith("<Hold:0|")
    g.send(b"G0 X5\n")  # not read during the hold
    g.advance(0.2)
    assert g.take() == b"" and g.machine.positions()[0] == 0
    g.send(b"~")
    g.settle()
    assert lines(g.take()) == ["ok"] and g.machine.positions()[0] == 5
    g.send(b"G0 X3000\n")
    g.advance(0.2)
    g.send(b"\x84")
    assert "[MSG:Check Door]" in lines(g.take())
    assert status(g).startswith("<Door:2|")
    g.advance(0.5)
    assert status(g).startswith("<Door:0|")
    g.send(b"~")
    g.settle()
    assert g.machine.positions()[0] == 3000
    g.send(b"M0\nG0 X0\n")
    g.advance(0.1)
    assert status(g).startswith("<Hold:0|") and g.machine.positions()[0] == 3000
    g.send(b"~")
    g.settle()
    assert g.machine.positions()[0] == 0
    g.take()
    g.send(b"$SLP\nG0 X5\n")
    g.settle(1)
    assert lines(g.take()) == ["ok", "[MSG:Sleeping]"] and status(g).startswith("<Sleep|")
    g.send(b"\x18")
    assert status(g).startswith("<Alarm|")


def test_check_mode_parses_without_moving():
    g = grbl()
    g.send(b"$C\nG0 X100\nM64 P0\nG4 P10\nG91 G0 X5\n$G\n$C\n")
    g.settle()
    out = lines(g.take())
    assert out[:6] == ["[MSG:Enabled]", "ok", "ok", "ok", "ok", "ok"]
    assert out[6] == "[GC:G0 G54 G17 G21 G91 G94 M5 M9 T0 F0 S0]"
    assert out[8:11] == ["[MSG:Disabled]", "ok", ""]
    assert g.machine.positions()[0] == 0 and g.backend.read_pin(22) == 0
    assert g.machine.interp.position_steps[0] == 0 and g.machine.interp.absolute  # reset


def test_startup_lines_run_after_a_reset_and_settings_persist():
    g = grbl()
    g.send(b"$N0=G91\n$N1=G4 P9 X\n$N\n$I\n")
    g.settle()
    out = lines(g.take())
    assert out[:2] == ["ok", "[MSG:X needs a number: 'X' is not G-code]"]
    assert out[2:6] == ["error:2", "$N0=G91", "$N1=", "ok"]
    assert out[6] == "[VER:1.1h.20190830:stepperdemo py-fas-0.1.0 atmega2560]"
    assert out[7] == "[OPT:VM,15,128]"  # a PWM spindle and mist coolant (atmega2560)
    g.send(b"$100=80\n\x18")  # the reset comes first: the line in the ring is gone
    g.settle()
    assert g.machine.settings.steps_per_unit[0] == 1
    g.send(b"$100=80\n")
    g.settle()
    g.send(b"\x18")
    g.settle()
    assert lines(g.take())[-1] == ">G91:ok"
    assert not g.machine.interp.absolute and g.machine.settings.steps_per_unit[0] == 80
    g.send(b"$RST=*\n")
    g.settle()
    out = lines(g.take())
    assert out[:3] == ["[MSG:Restoring defaults]", "ok", ""]
    assert g.machine.settings.steps_per_unit[0] == 1 and g.machine.settings.startup == ["", ""]


def test_host_arrival_is_a_power_on():
    g = grbl()
    g.send(b"G0 X50\nM64 P0\n")
    g.settle()
    g.open()
    assert lines(g.take()) == ["ok", "ok", "", "Grbl 1.1h ['$' for help]"]
    assert g.machine.positions()[0] == 0 and g.backend.read_pin(22) == 0


@pytest.mark.parametrize("arch", ["atmega328p", "atmega32u4", "esp32c3"])
def test_two_axis_profiles_report_three_axes(arch):
    g = grbl(arch)
    g.send(b"G0 X5\n")
    g.settle()
    assert status(g).startswith("<Idle|MPos:5.000,0.000,0.000|")
    g.send(b"G0 Z1\n")
    g.settle()
    assert lines(g.take())[-1] == "error:20"
