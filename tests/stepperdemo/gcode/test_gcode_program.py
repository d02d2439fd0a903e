"""The G-code program: the acceptance program in the VCD, lines answered, queue, alarms."""

import io
import math

import pytest

from fas.sim import SimBackend
from rigs.vcd import read_vcd
from stepperdemo.front.cli import main
from stepperdemo.gcode.reports import status_report
from stepperdemo.program import EndReason, make_program

TPS = 16_000_000
# the program: move X, M62 P0, move back, M63 P0, then M64 P1 and M67 E1 Q23.87
ACCEPTANCE = """G1 X2000 F600000
M62 P0
G1 X0
M63 P0
M64 P1
M67 E1 Q23.87
G4 P0.1
M2
"""


def run(text: str, arch: str = "atmega328p", **options):
    backend = SimBackend(arch, record=True)
    app = make_program("gcode", backend, scripted=True, **options)
    reason = app.run_script(text, max_ticks=600 * TPS)
    return backend, app, reason


def lines(app) -> list[str]:
    return app.transcript.decode().split("\r\n")[2:-1]  # without the banner


def test_acceptance_program_in_the_vcd_esp32(tmp_path, capsys):
    path = tmp_path / "prog.gcode"
    path.write_text(ACCEPTANCE)
    vcd_path = tmp_path / "run.vcd"
    rc = main(["gcode", "--arch", "esp32", str(path), "--vcd", str(vcd_path), "--report",
               "--vcd-timescale", "exact"])  # PWM duty to the tick
    out = capsys.readouterr().out
    assert rc == 0
    assert "error" not in out
    vcd = read_vcd(str(vcd_path))
    per_tick = 625  # 100 ps units at 16 MHz
    steps = vcd.rising("StepA")
    assert len(steps) == 4000
    first_move_end, second_move_start = steps[1999], steps[2000]
    (rise,) = vcd.rising("Dout0")
    (fall,) = vcd.falling("Dout0")
    assert first_move_end < rise < second_move_start  # after move 1, before move 2
    assert fall > steps[-1]  # after the last step of move 2
    # M64 is immediate, but it is read only after M63 has changed (M63 holds the parser)
    assert vcd.rising("Dout1")[0] >= fall
    a_rise, a_fall = vcd.rising("Aout1"), vcd.falling("Aout1")
    assert a_rise[0] > fall  # M67 after M63, synchronized
    periods = [b - a for a, b in zip(a_rise, a_rise[1:], strict=False)]
    assert set(periods) == {3200 * per_tick}  # 200 us: 5000 Hz
    assert a_fall[0] > a_rise[0]
    highs = [f - r for r, f in zip(a_rise, a_fall, strict=False)]  # the run may end high
    mean = sum(highs) / (len(highs) * 3200 * per_tick) * 100
    resolution = 100 / 8192  # 13 bits
    assert abs(mean - 23.87) <= resolution / 2 + 100 / 3200 / len(highs)
    assert "[MSG:Aout1 23.8647% (1955/8192 at 5000 Hz)]" in out
    assert "Aout1 (pin 16)" in out and "Dout0 (pin 32)  1 rise(s), 1 fall(s)" in out


def test_diagonal_axes_start_together_stay_on_the_line_and_end_together():
    backend, app, reason = run("G1 X10000 Y3000 F600000\n")
    assert reason == EndReason.IDLE
    xs, ys = backend.recorder.rising(9), backend.recorder.rising(10)
    assert (len(xs), len(ys)) == (10_000, 3_000)
    assert xs[-1] == ys[-1]  # last steps on the same tick
    events = sorted([(t, 0) for t in xs] + [(t, 1) for t in ys])
    x = y = 0
    worst = 0.0
    for _t, axis in events:
        x, y = x + (axis == 0), y + (axis == 1)
        worst = max(worst, abs(x * 3000 - y * 10000) / math.hypot(10000, 3000))
    assert worst <= 1.0
    start, lead = app.machine.motion_log[0]
    # both queues started on one tick: their first commands are pauses from the same start
    assert xs[0] > start + lead and ys[0] > start + lead


def test_every_line_is_answered_and_errors_do_not_stop_the_program():
    backend, app, reason = run("G1 X100 F60000\nG1 X50 Q3\nM3 S1000 M13\nG0 X0\n")
    assert lines(app) == ["ok", "[MSG:unused word(s): Q]", "error:36",
                          "[MSG:unsupported command M13]", "error:20", "ok"]
    assert app.exit_code() == 1
    assert app.steppers[0].get_current_position() == 0
    assert backend.recorder.rising(9)[-1] > 0 and len(backend.recorder.rising(9)) == 200


def test_dwell_lasts_its_seconds_after_the_motion_before():
    backend, app, _ = run("G1 X400 F600000\nG4 P0.5\nG1 X0\n")
    steps = backend.recorder.rising(9)
    gap = steps[400] - steps[399]
    lead = app.machine.motion_log[1][1]
    first_step = steps[400] - app.machine.motion_log[1][0]
    assert gap >= TPS // 2  # at least the dwell
    assert gap < TPS // 2 + lead + first_step + TPS // 100


def test_acceleration_is_a_per_axis_setting():
    def duration(backend, app):  # from the start of the motion to the last step
        start, lead = app.machine.motion_log[0]
        return backend.recorder.rising(9)[-1] - start - lead

    d_slow = duration(*run("$120=1000\nG1 X2000 F600000\n")[:2])
    d_fast = duration(*run("G1 X2000 F600000\n")[:2])
    # a triangle of 2000 steps: t = 2 sqrt(2000/a)
    assert d_slow / TPS == pytest.approx(2 * math.sqrt(2000 / 1000), rel=0.01)
    assert d_fast / TPS == pytest.approx(2 * math.sqrt(2000 / 10000), rel=0.02)


def test_settings_list_set_and_refuse():
    _, app, _ = run("$$\n$100=80\n$999=1\n$1=300\n$110=abc\n$140=1\n$160=13\n")
    out = lines(app)
    assert "$120=10000.000" in out and "$140=5000" in out and "$102=1.000" in out
    assert not any("(" in line for line in out)  # plain $n=value, as Grbl 1.1
    at = out.index
    assert out[at("[MSG:no setting $999]") + 1] == "error:3"
    assert out[at("[MSG:$1 must be 0..255]") + 1] == "error:3"
    assert out[at("[MSG:setting value 'ABC' is not a number]") + 1] == "error:2"
    assert "[MSG:timer 2 makes 61.04 .. 6.25e+04 Hz, not 1 Hz]" not in out  # nearest
    assert out[at("[MSG:pin 13 has no PWM timer on atmega328p]") + 1] == "error:3"
    assert app.machine.settings.steps_per_unit[0] == 80


def test_status_report_shows_positions_and_outputs_with_170():
    _, app, _ = run("G0 X120 Y-40\nM64 P2\nM68 E1 Q12.5\n?\n")
    status = [ln for ln in lines(app) if ln.startswith("<")][-1]
    # the G0 was queued, M64 and M68 acted at once, then the ? line: the move begins
    assert status.startswith("<Run|MPos:0.000,0.000,0.000|Bf:14,127|")
    _, app, _ = run("G0 X120 Y-40\nG4 P0.01\nM64 P2\nM68 E1 Q12.5\n$170=1\n")
    assert status_report(app.machine) == ("<Idle|MPos:120.000,-40.000,0.000|Bf:15,128|FS:0,0"
                                          "|WCO:0.000,0.000,0.000|Dout:0010"
                                          "|Aout:0.00,12.50,0.00,0.00>")


def test_block_queue_takes_lines_only_while_it_has_room():
    text = "".join(f"G1 X{(i + 1) % 2 * 100} F600000\n" for i in range(40))
    backend = SimBackend("atmega328p")
    app = make_program("gcode", backend, scripted=True)
    app.load_script(text)
    app.loop_pass()  # 15 blocks (the first executing), the 16th line waits for room
    m = app.machine
    assert len(m.blocks) == 15 and m.executor.current() is not None
    assert m.pending is not None and m.pending.text == "G1X0F600000"
    assert lines(app).count("ok") == 15  # the line waiting has no answer yet
    app.run_until(m.executor.run.origin + TPS // 4)  # the first block (0.2 s) is done
    assert lines(app).count("ok") == 16 and len(m.blocks) == 15
    app.run_until(app.backend.now() + 10 * TPS)  # 39 more blocks of 0.2 s
    assert lines(app).count("ok") == 40 and app.finished()


def test_abort_is_an_alarm_until_unlocked_and_keeps_the_outputs():
    backend = SimBackend("atmega328p", record=True)
    app = make_program("gcode", backend, scripted=False)
    app.feed("M64 P0\nG1 X5000 F60000\nM62 P1\n")
    app.run_until(TPS // 2)
    assert app.steppers[0].is_running()
    app.force_stop_all()  # the console's Ctrl-C
    pos = app.steppers[0].get_current_position()
    app.feed("G0 X0\n$X\nG0 X0\n")
    app.run_until(app.backend.now() + 10 * TPS)
    out = lines(app)
    assert out[out.index("ALARM:3") - 1].startswith("[MSG:stopped at once by the console")
    assert out[out.index("[MSG:alarm lock: $X to unlock (or ctrl-x)]") + 1] == "error:9"
    assert out[out.index("[MSG:Caution: Unlocked]") + 1] == "ok"
    assert 0 < pos < 5000 and app.steppers[0].get_current_position() == 0
    assert backend.read_pin(2) == 1  # Dout0 stays on (alarm: unchanged)
    assert backend.read_pin(4) == 0  # the synchronized M62 P1 was dropped


def test_soft_reset_switches_outputs_off_and_end_of_program_leaves_them():
    backend, app, _ = run("M64 P0\nM68 E0 Q40\nG4 P0.01\nM2\n")
    assert backend.read_pin(2) == 1  # M2: unchanged
    app.feed("\x18")
    app.run_until(backend.now() + TPS // 100)
    assert backend.read_pin(2) == 0 and app.machine.engine.outputs.analog_applied(0)[1] == 0
    assert app.transcript.decode().count("Grbl 1.1h") == 2


def test_shared_direction_pin_refuses_opposite_directions_on_esp32():
    _, app, _ = run("G0 X100 Y-100\nG0 X100 Y100\n", arch="esp32")
    assert lines(app)[:3] == ["[MSG:axes X and Y share direction pin 18: they cannot move "
                              "in opposite directions in one line]", "error:33", "ok"]


def test_output_without_a_pin_and_pin_override():
    _, app, _ = run("M67 E2 Q10\n$162=5\n")
    assert lines(app) == ["[MSG:Aout2 has no pin on atmega328p (set one with $162)]",
                          "error:39", "[MSG:Aout2: pin 5 is used by stepper 1 direction]",
                          "error:3"]
    _, app, _ = run("$163=45\nM68 E3 Q10\n", arch="atmega2560")  # OC5B instead of OC2B
    assert lines(app) == ["ok", "[MSG:Aout3 10.0000% (320/3200 at 5000 Hz)]", "ok"]
    assert app.engine.outputs.timer_name(3) == "timer 5"


def test_cli_exit_codes_stdin_and_set(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr("sys.stdin", io.StringIO("G0 X10\nG9\n"))
    assert main(["gcode", "-", "--lf"]) == 1
    assert capsys.readouterr().out.splitlines()[2:] == ["ok", "[MSG:unsupported command G9]",
                                                        "error:20"]
    assert main(["gcode", str(tmp_path / "missing.gcode")]) == 2
    assert main(["gcode", "-", "--set", "120=5"]) == 2
    monkeypatch.setattr("sys.stdin", io.StringIO("G1 X10 F600\n"))
    assert main(["gcode", "-", "--set", "$110=60", "--max-time", "0.5"]) == 3
    assert "--set" in capsys.readouterr().err


def test_gcode_help_states_the_acceleration_default(capsys):
    with pytest.raises(SystemExit):
        main(["gcode", "--help"])
    text = capsys.readouterr().out
    assert "acceleration per axis, units/s^2" in text and "default 10000" in text
