"""FastAccelStepper in Python: steppers with acceleration ramps on a pluggable backend.

    from fas import Engine
    from fas.sim import SimBackend

    backend = SimBackend("atmega328p")
    engine = Engine(backend)
    engine.init()
    stepper = engine.stepper_connect_to_pin(9)
    stepper.set_direction_pin(5)
    stepper.set_speed_in_us(100)
    stepper.set_acceleration(1000)
    stepper.move(3200)
    backend.wait_until(lambda: not stepper.is_running())
"""

from .arch import PROFILES, Profile, get_profile
from .codes import (
    PIN_EXTERNAL_FLAG,
    PIN_UNDEFINED,
    AqeResult,
    DelayResult,
    MoveResult,
    RampState,
)
from .engine import Engine
from .stepper import Stepper

__version__ = "0.1.0"

__all__ = ["Engine", "Stepper", "Profile", "PROFILES", "get_profile", "MoveResult",
           "AqeResult", "DelayResult", "RampState", "PIN_UNDEFINED", "PIN_EXTERNAL_FLAG"]
