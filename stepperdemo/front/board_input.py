"""Input to a board running StepperDemo, paced the way the firmware can take it.

The firmware takes one character per loop pass from a small receive buffer (63
characters on an AVR); while it prints a long text (the usage, 2190 characters, is
about 190 ms at 115200 baud) or spins in ``W`` or ``T`` it takes none, and what
arrives beyond the buffer is lost.  So the console sends one command at a time (the
command and the separator after it) and holds the next one:

* after most commands until the board answered: a line came and then the board was
  quiet for :data:`ANSWER_GAP_S` or printed a status line (which the firmware prints
  at the end of a loop pass, so the answer is out) - or nothing at all came for
  :data:`NO_ANSWER_S`;
* after ``W`` until the wait is over: the board's ``Blocking wait ...`` and then
  ``STOPPED`` (or any other line: the wait returned at once because the stepper runs
  without end; or ``Unknown command: W`` in config mode); in test mode, also until
  the running test has completed (``test completed``).  That is what ``W`` means in a
  StepperDemo input line (SPEC 4.1), on the board as on the simulation;
* after ``T`` (direct drive, the loop blocked for 2 x 3200 steps of 200 us) for
  :data:`DIRECT_DRIVE_S` from its ``test direct drive`` answer.

Ctrl-C bypasses all of it (:meth:`InputPacer.clear` and a direct write).
"""

from __future__ import annotations

import re
from collections import deque

from ..demo import direct_drive
from ..watch.status_lines import BoardState

ANSWER_GAP_S = 0.02  # longer than a USB adapter's latency timer (16 ms on FTDI)
NO_ANSWER_S = 0.06  # a command that prints nothing (+ or T while running)
DIRECT_DRIVE_S = (2 * direct_drive.STEPS * (direct_drive.HIGH_US + direct_drive.LOW_US)
                  / 1e6 + 0.2)
SEPARATORS = b" \r\n"
_TOKEN = re.compile(rb"[ \r\n]*[^ \r\n]+[ \r\n]*|[ \r\n]+")


def split_commands(data: bytes) -> list[bytes]:
    """``b"M1 A100\\n"`` -> ``[b"M1 ", b"A100\\n"]``: each command with its separators."""
    return _TOKEN.findall(data)


class InputPacer:
    """Commands waiting to go to the board, and why the next one waits (module text)."""

    def __init__(self) -> None:
        self.queue: deque[bytes] = deque()
        self.hold: str | None = None  # "answer", "W", "W stop", "W test", "T"
        self._sent_s = 0.0
        self._lines = 0  # lines received since the last command went out
        self._last_status = False  # the last of them was a status line
        self._until_s: float | None = None

    # ------------------------------------------------------------- queue
    def put(self, data: bytes) -> None:
        self.queue.extend(split_commands(data))

    def clear(self) -> None:
        self.queue.clear()
        self.hold = None
        self._until_s = None

    def pending(self) -> bool:
        return bool(self.queue) or self.hold is not None

    def held_by(self) -> str | None:
        """Why input waits, for the toolbar (None: nothing waits for the board)."""
        if self.hold in (None, "answer"):
            return None
        return self.hold

    # ----------------------------------------------------------- pacing
    def _release_at(self, last_rx_s: float) -> float | None:
        """When a timed hold ends (None: it ends on what the board says)."""
        if self._until_s is not None:
            return self._until_s
        if self.hold == "answer":
            gap = ANSWER_GAP_S if self._lines else NO_ANSWER_S
            return max(last_rx_s, self._sent_s) + gap
        return None

    def released(self, now_s: float, last_rx_s: float) -> bool:
        """Has the current hold ended (clears it when it has)?"""
        if self.hold is None:
            return True
        if self.hold == "answer" and self._lines and self._last_status:
            self.hold = None
            return True
        at = self._release_at(last_rx_s)
        if at is None or now_s < at:
            return False
        self.hold = self._until_s = None
        return True

    def next_command(self, now_s: float, last_rx_s: float) -> bytes | None:
        """The next command to send now, or None (nothing queued, or it must wait)."""
        if not self.queue or not self.released(now_s, last_rx_s):
            return None
        token = self.queue.popleft()
        word = token.strip(SEPARATORS)
        self._sent_s = now_s
        self._lines = 0
        self._last_status = False
        self.hold = ("W" if word == b"W" else "answer") if word else None
        return token

    def unanswered(self, now_s: float) -> bool:
        """The last command has had no answer at all yet (and may still get one)."""
        return (self.hold == "answer" and not self._lines
                and now_s < self._sent_s + NO_ANSWER_S)

    def holding(self, now_s: float, last_rx_s: float) -> str | None:
        """Why the board is not done with the input sent (None: it is)."""
        if not self.released(now_s, last_rx_s) and self.hold != "answer":
            return self.hold
        return "answer" if self.unanswered(now_s) else None

    def sent_directly(self, now_s: float) -> None:
        """Something went out past the queue (Ctrl-C's stop): wait for its answer."""
        self._sent_s = now_s
        self._lines = 0
        self._last_status = False
        self._until_s = None
        self.hold = "answer"

    def wake_in(self, now_s: float, last_rx_s: float) -> float | None:
        """Seconds until the next command may go (None: nothing waits for a timer)."""
        if not self.queue:
            return None
        if self.hold is None:
            return 0.0
        at = self._release_at(last_rx_s)
        return None if at is None else max(0.0, at - now_s)

    def on_line(self, kind: str | None, state: BoardState, now_s: float) -> None:
        """A line came from the board (``kind`` as :meth:`BoardState.feed` says)."""
        self._lines += 1
        self._last_status = kind == "status"
        if kind == "reset":
            self.clear()  # a new start: nothing typed before it belongs to it
            return
        hold = self.hold
        if hold == "answer" and kind == "direct_drive":
            self.hold = "T"
            self._until_s = now_s + DIRECT_DRIVE_S
        elif hold == "W":
            if kind == "unknown":
                self.hold = None
            elif kind == "spin":
                self.hold = "W stop" if state.spinning else None
                self._after_wait(state)
            elif kind == "stopped":  # "Blocking wait" was missed (a reset, a lost byte)
                self.hold = None
                self._after_wait(state)
        elif hold == "W stop":
            self.hold = None  # STOPPED, or a line that shows the wait returned at once
            self._after_wait(state)
        elif hold == "W test" and kind == "test_done":
            self.hold = None

    def _after_wait(self, state: BoardState) -> None:
        if self.hold is None and state.mode == "test" and state.test_running:
            self.hold = "W test"
