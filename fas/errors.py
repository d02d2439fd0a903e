"""The library's exception for calls the chosen platform does not have.

Upstream compiles some functions only for some platforms (the pulse counter and the
driver types on ESP32, ``task_rate`` on ESP32 and the Pico, ...).  In Python the
methods exist everywhere; on a profile whose firmware would not have them they raise
:class:`UnsupportedError` with a one-line reason, instead of pretending to work.
"""

from __future__ import annotations


class UnsupportedError(NotImplementedError):
    """The call exists in FastAccelStepper, but not in its build for this profile."""

    def __init__(self, call: str, profile_name: str, where: str) -> None:
        super().__init__(f"{call} is not available on {profile_name} "
                         f"(FastAccelStepper has it {where})")
        self.call = call
        self.profile_name = profile_name
