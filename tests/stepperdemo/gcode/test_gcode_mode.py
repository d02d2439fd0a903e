"""G-code in StepperDemo's g mode and in the interactive console."""

from fas.sim import SimBackend
from rigs.console import run_session, settle, wait
from stepperdemo import messages as msg
from stepperdemo.demo.app import StepperDemo

TPS = 16_000_000
ENTER = msg.ENTER_GCODE_MODE


def demo(line: str, arch: str = "atmega328p"):
    backend = SimBackend(arch, record=True)
    app = StepperDemo(backend, scripted=True)
    app.run_script(line, max_ticks=600 * TPS)
    return backend, app, app.transcript.decode()


def test_g_mode_runs_blocks_and_x_alone_returns_to_stepperdemo():
    backend, app, text = demo("g\nG1 X300 Y-100 F60000\nM62 P0\nG0 X0 Y0\nx\n"
                              "M1 A1000 V100 R50 W")
    assert ENTER in text
    gcode = text[text.index("Grbl 1.1h"):text.index("Exit to main menu")]
    assert gcode.split("\r\n")[1:4] == ["ok", "ok", "ok"]
    assert "Move steps 50" in text[text.index("Exit to main menu"):]
    assert app.steppers[0].get_current_position() == 50
    assert app.steppers[1].get_current_position() == 0
    steps = backend.recorder.rising(9)
    rise = [t for t, lv in zip(*backend.recorder.pin_edges(2), strict=True) if lv][0]  # Dout0
    assert steps[299] < rise < steps[300]
    assert app.steppers[0].get_auto_enable()  # given back to StepperDemo
    assert app.mode_name() == "normal"


def test_g_mode_errors_and_status_stay_in_the_mode():
    _, app, text = demo("g\nG1 X10\nM65 P7\n?\nx\n?")
    assert "[MSG:undefined feed rate: G1 needs F]\r\nerror:22\r\n" in text
    assert "[MSG:output P7 out of range (0..3)]\r\nerror:39\r\n" in text
    assert "<Idle|MPos:0.000,0.000,0.000|Bf:15,128|FS:0,0|WCO:0.000,0.000,0.000>" in text
    assert text.count("Exit to main menu") == 1
    assert "Unknown command" not in text
    assert app.exit_code() == 1  # refused g-mode lines count as failures of the run


def test_x_waits_for_the_queued_blocks():
    backend, app, text = demo("g\nG1 X2000 F60000\nx\nM1 A1000 V100 R1 W")
    exit_at = text.index("Exit to main menu")
    assert app.steppers[0].get_current_position() == 2001
    assert "Move steps 1" in text[exit_at:]


def test_g_mode_completions_and_mode_name():
    backend = SimBackend("atmega328p")
    app = StepperDemo(backend, scripted=False)
    app.feed("g\n")
    app.run_until(TPS // 2)
    assert app.mode_name() == "gcode"
    names = [c for c, _ in app.completions()]
    assert "M62" in names and "x" in names
    app.force_stop_all()  # Ctrl-C in the g mode: an alarm, no exception
    app.feed("x\n")
    app.run_until(TPS)
    assert app.mode_name() == "normal"


def run_console(script, tmp_path, program="demo", arch="atmega328p"):
    return run_session(script, tmp_path, arch, program=program,
                       program_options={} if program == "demo" else {"axes": 2})


def test_gcode_console_answers_lines_in_real_time(tmp_path):
    async def script(inp, clock, console):
        inp.send_text("G1 X500 F60000\r")
        await settle()
        inp.send_text("M64 P1\r")
        await wait(clock, 2.0)
        inp.send_text("?\r")
        await wait(clock, 0.1)

    console, rc = run_console(script, tmp_path, program="gcode")
    assert rc == 0
    assert console.lines.count("ok") >= 3
    assert "<Idle|MPos:500.000,0.000,0.000|Bf:15,127|FS:0,0|WCO:0.000,0.000,0.000>" \
        in console.lines  # 127: the line end after ? waits in the ring
    assert console.app.steppers[0].get_current_position() == 500
    assert console.app.engine.outputs.digital_applied(1) == 1


def test_g_mode_in_the_stepperdemo_console(tmp_path):
    async def script(inp, clock, console):
        inp.send_text("g\r")
        await wait(clock, 0.5)
        inp.send_text("G0 X100\r")
        await wait(clock, 1.0)
        inp.send_text("x\r")
        await wait(clock, 0.5)

    console, rc = run_console(script, tmp_path)
    assert ENTER.rstrip() in console.lines
    assert "Exit to main menu" in console.lines
    assert console.app.steppers[0].get_current_position() == 100


def test_quickstep_and_pwm_do_not_share_timer_2():
    _, _, text = demo("c l1 x g\nM68 E0 Q50\nG0 X10\nx\n")
    assert "[MSG:Aout0: timer 2 runs the QuickStep planner (l0 frees it)]\r\nerror:39" in text
    assert "[MSG:axis X runs the QuickStep planner" in text
    _, _, text = demo("g\nM68 E0 Q50\nx\nc l1 x")
    assert "ERROR timer 2 makes the PWM of a user output: no QuickStep on it" in text


def test_the_board_console_g_mode_has_grbls_128_byte_ring_for_counting_senders():
    """``device --pty --console`` then ``g``: the bytes go to Grbl's receive path at the
    line's rate, so a sender counting 128 bytes loses none (issue 24: the Arduino's
    63-byte buffer lost 34-51 characters of a 92-line program)."""
    from collections import deque

    from stepperdemo.demo.serial_board import SimulatedBoard

    board = SimulatedBoard("atmega2560")
    board.receive(b"g\n")
    board.run_until(board.now() + TPS // 2)
    board.take_output()
    lines = [f"G1 X{(n % 2) * 30} Y{n} F600000" for n in range(92)] + ["M64 P0"]
    inflight: deque[int] = deque()
    out = b""
    oks = 0
    for line in lines:
        data = (line + "\n").encode()
        while sum(inflight) + len(data) > 128:  # wait for answers, as the sender does
            board.run_until(board.now() + TPS // 1000)
            out += board.take_output()
            while oks < out.count(b"ok\r\n"):
                oks += 1
                inflight.popleft()
        board.receive(data)
        inflight.append(len(data))
    board.run_until(board.now() + 5 * TPS)
    out += board.take_output()
    assert out.count(b"ok\r\n") == len(lines) and b"error" not in out
    assert board.rx_dropped == 0 and board.app.gcode.machine.rx.dropped == 0
    assert board.positions()[:2] == [30, 91]
