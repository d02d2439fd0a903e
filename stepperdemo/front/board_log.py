"""``--log FILE``: the board session's transcript with timestamps.

One line per event: seconds since the session started (the start is written in
the header, local time), then ``>`` for a command sent, ``<`` for a line the board
printed (its CR LF removed), ``#`` for a line of the console itself::

    # stepperdemo py-fas-0.1.0 board log: /dev/ttyUSB0 at 115200 baud, started ...
         0.412 < StepperDemo Version ...
         2.031 > M1
         2.052 < Select stepper 1

Every line is flushed as it is written, so the log survives a crash.
"""

from __future__ import annotations

import datetime
from typing import TextIO

from .. import messages as msg


class BoardLog:
    def __init__(self, path: str, port: str, baud: int) -> None:
        self._file: TextIO | None = open(path, "a", encoding="utf-8")  # noqa: SIM115 - written until close()
        start = datetime.datetime.now().astimezone().isoformat(timespec="milliseconds")
        self._write(msg.LOG_HEADER.format(version=msg.VERSION, port=port, baud=baud,
                                          start=start))

    def _write(self, line: str) -> None:
        if self._file is not None:
            self._file.write(line + "\n")
            self._file.flush()

    def sent(self, t_s: float, data: bytes) -> None:
        text = data.decode("utf-8", "replace").strip(" \r\n")
        if text:
            self._write(msg.LOG_SENT.format(t=t_s, text=text))

    def received(self, t_s: float, line: str) -> None:
        self._write(msg.LOG_RECEIVED.format(t=t_s, text=line))

    def note(self, t_s: float, text: str) -> None:
        self._write(msg.LOG_NOTE.format(t=t_s, text=text))

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None
