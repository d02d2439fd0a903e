"""The interactive console, driven through prompt-toolkit's pipe input on a fake clock."""

import asyncio

from prompt_toolkit.input import create_pipe_input
from prompt_toolkit.output import DummyOutput

from stepperdemo.front.console import Console, RealTimeDriver


class FakeClock:
    """Virtual wall clock: time passes only when the console sleeps."""

    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t

    async def sleep(self, seconds: float) -> None:
        self.t += max(seconds, 0.0005)
        await asyncio.sleep(0)


async def settle(steps: int = 50) -> None:
    for _ in range(steps):
        await asyncio.sleep(0)


async def wait(clock: FakeClock, seconds: float) -> None:
    """Let ``seconds`` of (fake) wall-clock time pass."""
    end = clock.t + seconds
    while clock.t < end:
        await asyncio.sleep(0)


def run_session(script, tmp_path):
    """script(inp, clock, console) is an async function typing into the console."""

    async def main():
        clock = FakeClock()
        with create_pipe_input() as inp:
            console = Console("atmega328p", clock=clock, sleep=clock.sleep, input=inp,
                              output=DummyOutput(), history=str(tmp_path / "history"),
                              redraw_postpone_s=None)
            task = asyncio.ensure_future(console.run())
            await settle()
            await script(inp, clock, console)
            inp.send_text("\x04")  # Ctrl-D
            rc = await asyncio.wait_for(task, 30)
            return console, rc

    return asyncio.run(main())


def test_move_and_wait_shows_the_stop(tmp_path):
    async def script(inp, clock, console):
        inp.send_text("M1 A1000 V100 R500\r")
        await settle()
        inp.send_text("W\r")
        await wait(clock, 4.0)

    console, rc = run_session(script, tmp_path)
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

    console, rc = run_session(script, tmp_path)
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

    console, rc = run_session(script, tmp_path)
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
    clock.t = 0.5
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

    run_session(script, tmp_path)
    idle = seen["idle"]
    times = {s.split("t=")[1].split("s")[0] for s in idle}
    assert len(times) >= 6  # >= 3 redraws per second of wall time, each with a new time
    assert all("running 0" in s and " normal mode " in s for s in idle)
    assert len(seen["moving"]) >= 3 and all("running 1" in s for s in seen["moving"])
    assert "running 0" in seen["after"][-1]  # the move ended: the toolbar says so
