"""The simulated microcontroller backend (tick-exact, deterministic)."""

from .backend import SimBackend
from .machine import Machine
from .pins import EdgeRecorder, PinBank

__all__ = ["SimBackend", "Machine", "EdgeRecorder", "PinBank"]
