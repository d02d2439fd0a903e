"""The interactive console, driven through prompt-toolkit's pipe input on a fake clock."""

from rigs.console import FakeClock, run_session, settle, wait
from stepperdemo.front.console import RealTimeDriver


def test_move_and_wait_shows_the_stop(tmp_path):
    async def script(inp, clock, console):
        inp.send_text("M1 A1000 V100 R500\r")
        await settle()
        # the move takes ~1 s: its status lines come every 100 ms until the W blocks
        # (how much fake time 50 rounds of settle() cover depends on when the chip next
        # wakes, so the W waits for the clock, not for the rounds)
        await wait(clock, 0.3)
        inp.send_text("W\r")
        await wait(clock, 4.0)

    console, rc = run_session(script, tmp_path, redraw_postpone_s=None)
    assert rc == 0
    lines = console.lines
    assert "Move steps 500" in lines and "OK" in lines
    assert "Blocking wait for running stepper to stop" in lines
    assert lines.index("STOPPED") > lines.index("Move steps 500")
    assert any(ln.startswith("M1: @") and "=> 500" in ln for ln in lines)
    assert console.app.steppers[0].get_current_position() == 500
    assert (tmp_path / "history").read_text().count("R500") == 1


def test_ctrl_c_force_stops_a_running_move(tmp_path):
    async def script(inp, clock, console):
        inp.send_text("M1 A1000 V100 f\r")
        await wait(clock, 1.0)
        inp.send_text("\x03")  # Ctrl-C
        await settle()
        await wait(clock, 0.5)

    console, rc = run_session(script, tmp_path, redraw_postpone_s=None)
    s = console.app.steppers[0]
    assert not s.is_running()
    assert s.get_current_position() > 100
    assert "all steppers force-stopped" in console.lines


def test_meta_commands_and_errors_keep_the_session(tmp_path):
    async def script(inp, clock, console):
        # the ESP32 firmware first asks for a pin configuration: "0" answers it
        for line in ("/help", "/nonsense", "/speed 0", "/speed 10", "/time", "/arch",
                     "V0", "Zzz", "/arch esp32", "0", "M3 A1000 V100 R20"):
            inp.send_text(line + "\r")
            await settle()
        await wait(clock, 1.0)

    console, rc = run_session(script, tmp_path, redraw_postpone_s=None)
    text = "\n".join(console.lines)
    assert "Console commands" in text
    assert "unknown console command '/nonsense'" in text
    assert "/speed: give a factor" in text
    assert "profile atmega328p" in text
    assert "ERROR invalid value" in text and "Unknown command: Zzz" in text
    assert "restarted on profile esp32" in text
    assert console.backend.profile.name == "esp32"
    assert console.app.steppers[2].get_current_position() == 20


def test_real_time_driver_follows_the_clock_and_sleeps_when_idle():
    from fas.sim import SimBackend
    from stepperdemo.demo.app import StepperDemo

    clock = FakeClock()
    app = StepperDemo(SimBackend("esp32"), scripted=False)
    driver = RealTimeDriver(app, scale=2.0, clock=clock)
    app.feed("0")  # the answer to the firmware's start-up prompt
    clock.now = 0.5
    driver.advance()
    assert app.backend.now() == 16_000_000  # 0.5 s at x2
    # nothing runs and no LED: the console may sleep until input arrives
    assert driver.advance() is None
    app.feed("M1 A1000 V100 R100\n")
    assert driver.advance() == 0.0


def test_toolbar_moves_on_while_nobody_types(tmp_path):
    """Time, running steppers and mode redraw several times a second with no key and
    no output (status lines off, so nothing else makes the prompt redraw)."""
    seen: dict[str, list[str]] = {}

    async def script(inp, clock, console):
        await wait(clock, 0.5)
        console.toolbar_shown.clear()
        await wait(clock, 2.0)  # idle: no key, no output
        seen["idle"] = list(console.toolbar_shown)
        inp.send_text("I M1 A1000 V1000 R1500\r")  # status lines off, then a 1.5 s move
        await settle()
        n = len(console.lines)
        console.toolbar_shown.clear()
        await wait(clock, 1.0)
        assert len(console.lines) == n  # nothing printed while it moves
        seen["moving"] = list(console.toolbar_shown)
        await wait(clock, 2.0)
        seen["after"] = list(console.toolbar_shown)

    run_session(script, tmp_path, redraw_postpone_s=None)
    idle = seen["idle"]
    times = {s.split("t=")[1].split("s")[0] for s in idle}
    assert len(times) >= 6  # >= 3 redraws per second of wall time, each with a new time
    assert all("running 0" in s and " normal mode " in s for s in idle)
    assert len(seen["moving"]) >= 3 and all("running 1" in s for s in seen["moving"])
    assert "running 0" in seen["after"][-1]  # the move ended: the toolbar says so


def test_toolbar_sees_the_short_moves_of_test_sequence_01(tmp_path):
    """Sequence 01 moves 53 steps in ~14 ms once a second: a toolbar drawn 4 times a
    second almost never saw it running (issue 26).  It now counts a stepper that moved
    since the last draw, and says that a test runs."""
    seen: list[str] = []

    async def script(inp, clock, console):
        inp.send_text("t\r")
        await settle()
        inp.send_text("M1 01 R\r")
        await settle()
        console.toolbar_shown.clear()
        await wait(clock, 3.0)
        seen.extend(console.toolbar_shown)

    console, _ = run_session(script, tmp_path, redraw_postpone_s=None)
    assert len(seen) >= 9
    assert all(" test mode | M1 | test running |" in s for s in seen)
    moved = [s for s in seen if "running 1" in s]
    assert len(moved) >= 2  # one per second of the sequence, at least
    assert console.app.steppers[0].get_current_position() != 0


def test_toolbar_lists_question_mark_once_with_what_it_does_in_the_mode():
    from stepperdemo.front.console import toolbar_hints

    normal = [("M<n>", "stepper"), ("?", "usage and stepper table"), ("I", "toggle")]
    assert toolbar_hints(normal) == "M<n>  ?  I  /help"
    gcode = [(f"G{n}", "") for n in range(12)] + [("?", "status"), ("x", "leave")]
    assert toolbar_hints(gcode).endswith("G11  ? status  /help")
    assert toolbar_hints([("A", "a")]) == "A  /help"


def test_toolbar_of_each_mode(tmp_path):
    async def script(inp, clock, console):
        for line in ("", "c", "x", "g"):
            inp.send_text(line + "\r")
            await settle()
            await wait(clock, 0.3)
            console.toolbar_shown.clear()
            text = "".join(t for _, t in console.toolbar())
            hints[console.app.mode_name()] = text.split(" | ")[-1]

    hints: dict[str, str] = {}
    run_session(script, tmp_path, redraw_postpone_s=None)
    assert hints["normal"].count("?") == 1 and hints["normal"].endswith("A<accel>  /help")
    assert hints["config"].count("?") == 1
    assert hints["gcode"].endswith("M68  ? status  /help") and "usage" not in hints["gcode"]
