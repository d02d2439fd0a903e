"""Ramp generation: pure computation from targets, speed and acceleration to commands."""

from .calculator import RampConfig, RampParameters
from .control import NextCommand, RampRw, next_command
from .generator import RampGenerator

__all__ = ["RampConfig", "RampParameters", "NextCommand", "RampRw", "next_command",
           "RampGenerator"]
