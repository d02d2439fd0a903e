"""A session with a board running the original StepperDemo.

The session owns the link and everything the console knows about the board: the
received text (``transcript``), the lines parsed into the board's state and its
status-line trace (:mod:`stepperdemo.watch.status_lines`), the input waiting to go
(:mod:`.board_input`), the log.  The REPL, ``-c`` and ``run --board`` all drive a
board through it; the twin check drives the simulated board through it too, so
both sides of a comparison are read the same way.

When is a scripted run over?  The board never says "done", so :meth:`busy_reason`
reads it from what it said (the rules are in the README, "A board running the
original StepperDemo"):

* input is still queued or held (after ``W``: until the wait is over; in test mode
  until the test completed);
* the board spins in ``W``, pauses in ``w<ms>``, or runs a test (``run test`` until
  ``test completed``);
* a stepper was seen running (a status line, or the table) and the usage and table
  the firmware prints when the last stepper stops have not come yet - unless ``Q``
  turned that printout off; with status lines off (``I``) an acknowledged move
  (``OK`` after ``Move steps``, ``run forward`` ...) counts as seen running;
* the board printed something less than ``quiet_s`` ago (a command's answer, the
  usage and table after a stop, a move that never started: ``R0``).

So a run ends ``quiet_s`` after the last thing the board printed once nothing above
holds.  With ``Q`` off the end of a motion without ``W`` is seen only as the status
lines stopping (the quiet period); with ``I`` and ``Q`` both off not at all.

A port with something else behind it (another sketch, a wrong ``--baud``, a board
that does not run) would hold a ``W`` for ever: when nothing StepperDemo prints (its
banner, a status line, an answer to a command) came within :data:`NO_ANSWER_S` of
the first command sent, :meth:`silent_reason` says so and a run ends
(:attr:`End.NO_ANSWER`).
"""

from __future__ import annotations

from collections.abc import Callable
from enum import Enum

from fas.serial.stream import LinkClosed

from .. import messages as msg
from ..watch.status_lines import BoardState
from .board_input import InputPacer
from .board_link import BoardLink
from .board_log import BoardLog
from .board_options import BOOT_WAIT_S, QUIET_S

POLL_S = 0.05
CONFIG_PROMPT_WAIT_S = 6.0  # ESP32/RP2040 StepperDemo: 5 s for a pin-configuration digit
#: StepperDemo answers a command within milliseconds (a usage text within 0.2 s, an
#: ESP32's start-up prompt within 5 s): nothing of its own this long after the first
#: command was sent, and it is not StepperDemo at this baud rate
NO_ANSWER_S = 3.0


class End(Enum):
    IDLE = "idle"
    MAX_TIME = "max_time"
    LOST = "lost"
    RESET = "reset"
    NO_ANSWER = "no_answer"  # nothing StepperDemo says came (see silent_reason)


class BoardSession:
    """See the module text.  ``output`` gets the raw bytes as they arrive; ``notes``
    gets the console's own lines (a restart, a lost board)."""

    def __init__(self, link: BoardLink, *, output: Callable[[bytes], None] | None = None,
                 notes: Callable[[str], None] | None = None, log: BoardLog | None = None,
                 quiet_s: float = QUIET_S, boot_wait_s: float = BOOT_WAIT_S,
                 lost_note: str | None = msg.BOARD_LOST) -> None:
        """``lost_note``: the note when the board is lost (the REPL's, which offers
        ``/reconnect``); None: no note (a scripted run says it when it ends)."""
        self.link = link
        self.output = output
        self.notes = notes
        self.lost_note = lost_note
        self.log = log
        self.quiet_s = quiet_s
        self.boot_wait_s = boot_wait_s
        self.state = BoardState()
        self.pacer = InputPacer()
        self.transcript = bytearray()
        self.lines = 0
        self.lost: str | None = None
        self.unexpected_resets = 0
        self.input_start_s: float | None = None  # first command sent since the reset
        self._partial = bytearray()
        self.last_rx_s = link.now()
        self.last_tx_s = self.last_rx_s  # when the last input went out
        self._banner_until = link.now() + boot_wait_s  # opening a port may restart it

    def now(self) -> float:
        return self.link.now()

    def note(self, text: str) -> None:
        if self.log is not None:
            self.log.note(self.now(), text)
        if self.notes is not None:
            self.notes(text)

    # --------------------------------------------------------- receiving
    def _received(self, data: bytes, t_s: float) -> None:
        self.transcript += data
        self.last_rx_s = t_s
        if self.output is not None:
            self.output(data)
        buf = self._partial
        buf += data
        while True:
            end = buf.find(b"\n")
            if end < 0:
                return
            line = bytes(buf[:end]).decode("utf-8", "replace").replace("\r", "")
            del buf[:end + 1]
            self._line(line, t_s)

    def _line(self, line: str, t_s: float) -> None:
        self.lines += 1
        if self.log is not None:
            self.log.received(t_s, line)
        queued = len(self.pacer.queue)
        if line.startswith(msg.PRESS_NUMBER_TO_SELECT):  # ESP32: the banner comes 5 s later
            self._banner_until = max(self._banner_until, t_s + CONFIG_PROMPT_WAIT_S)
        kind = self.state.feed(line, t_s)
        self.pacer.on_line(kind, self.state, t_s)
        if kind == "reset":
            self.input_start_s = None
            if t_s > self._banner_until:
                self.unexpected_resets += 1
                dropped = msg.BOARD_RESTART_DROPPED.format(n=queued) if queued else ""
                self.note(msg.BOARD_RESTARTED.format(dropped=dropped))

    # ----------------------------------------------------------- sending
    def send(self, text: str | bytes) -> None:
        """Input for the board (sent as the pacing allows, see :mod:`.board_input`)."""
        self.pacer.put(text.encode("utf-8") if isinstance(text, str) else bytes(text))

    def _write(self, data: bytes) -> bool:
        if self.lost is not None:
            return False
        try:
            self.link.write(data)
        except LinkClosed as exc:
            self._lose(str(exc))
            return False
        t = self.now()
        self.last_tx_s = t
        if self.input_start_s is None:
            self.input_start_s = t
        if self.log is not None:
            self.log.sent(t, data)
        return True

    def _pump(self) -> None:
        while self.lost is None:
            token = self.pacer.next_command(self.now(), self.last_rx_s)
            if token is None or not self._write(token):
                return

    def _lose(self, reason: str) -> None:
        if self.lost is None:
            self.lost = reason
            self.pacer.clear()
            if self.lost_note is not None:
                self.note(self.lost_note.format(reason=reason))

    def poll(self, timeout_s: float = POLL_S) -> bool:
        """Send what may go, wait up to ``timeout_s`` for the board, take what came.
        True when something came."""
        if self.lost is not None:
            return False
        self._pump()
        wake = self.pacer.wake_in(self.now(), self.last_rx_s)
        if wake is not None:
            timeout_s = min(timeout_s, wake)
        try:
            data = self.link.read(max(0.0, timeout_s))
        except LinkClosed as exc:
            self._lose(str(exc))
            return False
        if data:
            self._received(data, self.now())
        self._pump()
        return bool(data)

    # ---------------------------------------------------------- questions
    def silent_reason(self) -> str | None:
        """Why the board is taken not to run StepperDemo (a console text: what came),
        or None.  See the module text."""
        if self.state.answers or self.input_start_s is None:
            return None
        if self.now() - self.input_start_s < NO_ANSWER_S:
            return None
        if not self.transcript:
            return msg.BOARD_SILENT_NOTHING
        return msg.BOARD_SILENT_FOREIGN.format(n=len(self.transcript))

    def busy_reason(self) -> str | None:
        """Why the board is not idle yet (a key of ``messages.BOARD_BUSY_WHY``)."""
        if self.pacer.queue:
            return "input"
        held = self.pacer.holding(self.now(), self.last_rx_s)
        if held is not None:
            return held
        st = self.state
        if st.spinning:
            return "spinning"
        if st.pausing:
            return "pausing"
        if st.test_running:
            return "test"
        if st.busy():
            return "motion"
        # quiet: quiet_s without a byte either way (the answer to a command may come
        # later than the pacer's no-answer window when the host or the board is slow)
        if self.now() - max(self.last_rx_s, self.last_tx_s) < self.quiet_s:
            return "output"
        return None

    # ------------------------------------------------------------ running
    def run_script(self, line: str | bytes, max_s: float) -> End:
        """Send one StepperDemo line and follow the board until it is idle."""
        data = line.encode("utf-8") if isinstance(line, str) else bytes(line)
        self.send(data + b"\n")
        return self.settle(max_s)

    def settle(self, max_s: float) -> End:
        """Follow the board until it is idle (see the module text)."""
        start = self.now()
        while True:
            if self.lost is not None:
                return End.LOST
            if self.unexpected_resets:
                return End.RESET
            if self.silent_reason() is not None:
                return End.NO_ANSWER
            if self.busy_reason() is None and (self.state.answers
                                               or self.input_start_s is None):
                return End.IDLE  # (input without any answer yet: wait for one)
            if self.now() - start >= max_s:
                return End.MAX_TIME
            self.poll(POLL_S)

    def wait_ready(self) -> bool:
        """After an open or a reset: wait for the start banner (until ``boot_wait_s``
        after it) and for the start-up text to end.  False: no banner came (the board
        did not restart, e.g. one without auto-reset)."""
        resets = self.state.resets
        while self.lost is None:
            if self.state.resets > resets:
                if self.now() - self.last_rx_s >= self.quiet_s:
                    return True
            elif self.now() >= self._banner_until:
                return False
            self.poll(POLL_S)
        return False

    def reset(self) -> str:
        """Restart the board; returns how (a console text)."""
        link = self.link
        before = getattr(link, "dtr_resets", 0)
        self.pacer.clear()
        self._partial.clear()
        try:
            link.reset()
        except LinkClosed as exc:
            self._lose(str(exc))
            return str(exc)
        self._banner_until = self.now() + self.boot_wait_s
        self.last_rx_s = self.now()
        self.input_start_s = None
        if getattr(link, "dtr_resets", 0) > before:
            return msg.BOARD_RESET_DTR
        return msg.BOARD_RESET_REOPEN

    def reconnect(self, port: str | None = None) -> None:
        """Open the line again (raises :class:`LinkClosed` when that fails)."""
        self.link.reopen(port)
        self.lost = None
        self.unexpected_resets = 0
        self.state.answers = 0  # perhaps another port: is StepperDemo there?
        self.input_start_s = None
        self.pacer.clear()
        self._partial.clear()
        self._banner_until = self.now() + self.boot_wait_s
        self.last_rx_s = self.now()

    def stop_all(self) -> tuple[list[int], str | None]:
        """Ctrl-C: ``X`` to every stepper at once, past any waiting input; then the
        selected stepper again.  Returns the steppers and the mode left (X is a
        normal-mode command: test and config mode are left with ``x`` first)."""
        self.pacer.clear()
        st = self.state
        numbers = list(range(1, (st.stepper_count or 1) + 1))
        words = []
        left = None
        if st.mode != "normal":
            words.append("x")
            left = st.mode
        for n in numbers:
            words += [f"M{n}", "X"]
        words.append(f"M{st.selected}")
        if self._write((" ".join(words) + "\n").encode("ascii")):
            self.pacer.sent_directly(self.now())
        return numbers, left

    def close(self) -> None:
        self.link.close()
        if self.log is not None:
            self.log.close()
