"""Command history that follows StepperDemo's input mode.

StepperDemo has three input modes with different commands (normal, test, config);
a line typed in test mode (``01 R``) means nothing in normal mode.  This history
stores each line with the mode it was typed in, and Up/Down recall the lines of the
mode the program (or the board) is in now, plus lines stored without a mode.

The file is prompt-toolkit's ``FileHistory`` format - the mode rides in the comment
line before each entry (``# 2024-05-01 12:00:00.0 mode=test``) - so older history
files load unchanged, and their lines are offered in every mode.
"""

from __future__ import annotations

import datetime
import os
import re
from collections.abc import AsyncGenerator, Callable, Iterable

from prompt_toolkit.history import FileHistory

_MODE = re.compile(r"^#.* mode=(\w+)\s*$")


class ModeHistory(FileHistory):
    def __init__(self, filename: str, mode: Callable[[], str]) -> None:
        super().__init__(filename)
        self.mode = mode
        self._entries: list[tuple[str, str | None]] = []  # newest first

    def _tagged(self) -> Iterable[tuple[str, str | None]]:
        entries: list[tuple[str, str | None]] = []
        lines: list[str] = []
        mode: str | None = None

        def add() -> None:
            if lines:
                entries.append(("".join(lines)[:-1], mode))

        if os.path.exists(self.filename):
            with open(self.filename, "rb") as f:
                for raw in f:
                    line = raw.decode("utf-8", errors="replace")
                    if line.startswith("+"):
                        lines.append(line[1:])
                        continue
                    add()
                    lines = []
                    m = _MODE.match(line)
                    if m is not None:
                        mode = m.group(1)
                    elif line.startswith("#"):
                        mode = None
            add()
        return reversed(entries)

    def _visible(self, mode: str | None) -> bool:
        return mode is None or mode == self.mode()

    async def load(self) -> AsyncGenerator[str, None]:
        if not self._loaded:
            self._entries = list(self._tagged())
            self._loaded_strings = [text for text, _ in self._entries]
            self._loaded = True
        for text, mode in self._entries:
            if self._visible(mode):
                yield text

    def get_strings(self) -> list[str]:
        return [text for text, mode in reversed(self._entries) if self._visible(mode)]

    def append_string(self, string: str) -> None:
        self._entries.insert(0, (string, self.mode()))
        super().append_string(string)

    def store_string(self, string: str) -> None:
        with open(self.filename, "ab") as f:
            f.write(f"\n# {datetime.datetime.now()} mode={self.mode()}\n".encode())
            for line in string.split("\n"):
                f.write(f"+{line}\n".encode())
