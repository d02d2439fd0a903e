"""The interactive console on a virtual wall clock: driven line by line
(:func:`make_console`, :func:`advance`) or through prompt-toolkit's pipe input
(:func:`run_session`)."""

from __future__ import annotations

import asyncio
import os
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

from prompt_toolkit.input import create_pipe_input
from prompt_toolkit.output import DummyOutput

from stepperdemo.front.console import Console


class FakeClock:
    """Virtual wall clock: time passes only when the console sleeps or a caller moves
    :attr:`now`."""

    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now

    async def sleep(self, seconds: float) -> None:
        self.now += max(seconds, 0.0005)
        await asyncio.sleep(0)


async def settle(steps: int = 50) -> None:
    """Let the event loop run ``steps`` rounds (no time passes)."""
    for _ in range(steps):
        await asyncio.sleep(0)


async def wait(clock: FakeClock, seconds: float) -> None:
    """Let ``seconds`` of (fake) wall-clock time pass."""
    end = clock.now + seconds
    while clock.now < end:
        await asyncio.sleep(0)


def make_console(directory: str | Path, arch: str = "atmega328p",
                 clock: Callable[[], float] | None = None, **options: Any) -> Console:
    """A console without a terminal, its history in ``directory``, on ``clock`` (a new
    :class:`FakeClock` unless given); the caller drives it (:func:`advance`)."""
    return Console(arch, history=os.path.join(directory, "history"),
                   clock=FakeClock() if clock is None else clock, output=DummyOutput(),
                   **options)


def advance(console: Console, seconds: float, step_s: float = 0.05) -> None:
    """``seconds`` of the console's :class:`FakeClock` in steps of ``step_s``, the
    real-time driver and the output flushed after each, as the REPL's ticker does."""
    for _ in range(round(seconds / step_s)):
        console.clock.now += step_s  # a FakeClock
        console.driver.advance()
        console.flush()


Script = Callable[[Any, FakeClock, Console], Awaitable[None]]


def run_session(script: Script, directory: str | Path, arch: str = "atmega328p",
                **options: Any) -> tuple[Console, int]:
    """The REPL on a :class:`FakeClock` with pipe input: ``script(inp, clock, console)``
    types into it, then Ctrl-D ends it; the console and its exit code."""

    async def main() -> tuple[Console, int]:
        clock = FakeClock()
        with create_pipe_input() as inp:
            console = Console(arch, clock=clock, sleep=clock.sleep, input=inp,
                              output=DummyOutput(),
                              history=os.path.join(directory, "history"), **options)
            task = asyncio.ensure_future(console.run())
            await settle()
            await script(inp, clock, console)
            inp.send_text("\x04")  # Ctrl-D
            rc = await asyncio.wait_for(task, 30)
            return console, rc

    return asyncio.run(main())
