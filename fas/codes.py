"""Return codes and ramp-state bits, with the numeric values FastAccelStepper uses.

Besides the enums, the small helpers of upstream's ``result_codes.h``: ``move_is_ok``,
``aqe_is_ok``, ``aqe_retry``, ``move_timed_is_ok``, ``delay_is_valid``, ``tmr_from``
and ``to_string`` (one function for every code type, with upstream's texts).
"""

from __future__ import annotations

from enum import IntEnum

PIN_UNDEFINED = 255
PIN_EXTERNAL_FLAG = 128
PIN_I2S_FLAG = 0x40  # ESP32 with I2S (IDF >= 5.3): the pin is a slot of the I2S multiplexer
TICKS_FOR_STOPPED_MOTOR = 0xFFFFFFFF

LOW = 0
HIGH = 1


class MoveResult(IntEnum):
    OK = 0
    ERR_NO_DIRECTION_PIN = -1
    ERR_SPEED_IS_UNDEFINED = -2
    ERR_ACCELERATION_IS_UNDEFINED = -3


class AqeResult(IntEnum):
    """Result of ``add_queue_entry``; positive values mean "retry later"."""

    OK = 0
    QUEUE_FULL = 1
    DIR_PIN_IS_BUSY = 2
    WAIT_FOR_ENABLE_PIN_ACTIVE = 3
    DEVICE_NOT_READY = 4
    DIR_PIN_2MS_PAUSE_ADDED = 5
    ERROR_TICKS_TOO_LOW = -1
    ERROR_EMPTY_QUEUE_TO_START = -2
    ERROR_NO_DIR_PIN_TO_TOGGLE = -3

    @property
    def retry(self) -> bool:
        return self.value > 0


class MoveTimedResult(IntEnum):
    """Result of ``move_timed``: the AQE codes plus three of its own (upstream's values)."""

    OK = 0
    QUEUE_FULL = 1
    DIR_PIN_IS_BUSY = 2
    WAIT_FOR_ENABLE_PIN_ACTIVE = 3
    DEVICE_NOT_READY = 4
    DIR_PIN_2MS_PAUSE_ADDED = 5
    MOVE_BUSY = 6  # the queue has no room for this timed move now: retry later
    MOVE_EMPTY = 7  # appended, but the queue had run empty before
    ERROR_TICKS_TOO_LOW = -1
    ERROR_EMPTY_QUEUE_TO_START = -2
    ERROR_NO_DIR_PIN_TO_TOGGLE = -3
    ERROR_MOVE_TOO_LARGE = -4  # can never fit into the queue

    @property
    def retry(self) -> bool:
        return self.value > 0


class DelayResult(IntEnum):
    OK = 0
    TOO_LOW = -1
    TOO_HIGH = -2


class FasDriver(IntEnum):
    """ESP32 step generators (upstream's ``FasDriver``); DONT_CARE lets the library pick."""

    MCPWM_PCNT = 0
    RMT = 1
    I2S_DIRECT = 2
    I2S_MUX = 3
    DONT_CARE = 255


class RampState(IntEnum):
    """Values of ``ramp_state() & RAMP_STATE_MASK``."""

    IDLE = 0
    COAST = 1
    ACCELERATE = 2
    DECELERATE = 4
    REVERSE = 4 + 8


RAMP_STATE_MASK = 1 + 2 + 4 + 8 + 16
RAMP_DIRECTION_MASK = 32 + 64
RAMP_STATE_ACCELERATING_FLAG = 2
RAMP_STATE_DECELERATING_FLAG = 4
RAMP_DIRECTION_COUNT_UP = 32
RAMP_DIRECTION_COUNT_DOWN = 64

# upstream C names, for users porting sketches
MOVE_OK = MoveResult.OK
MOVE_ERR_NO_DIRECTION_PIN = MoveResult.ERR_NO_DIRECTION_PIN
MOVE_ERR_SPEED_IS_UNDEFINED = MoveResult.ERR_SPEED_IS_UNDEFINED
MOVE_ERR_ACCELERATION_IS_UNDEFINED = MoveResult.ERR_ACCELERATION_IS_UNDEFINED
AQE_OK = AqeResult.OK
AQE_QUEUE_FULL = AqeResult.QUEUE_FULL
AQE_DIR_PIN_IS_BUSY = AqeResult.DIR_PIN_IS_BUSY
AQE_WAIT_FOR_ENABLE_PIN_ACTIVE = AqeResult.WAIT_FOR_ENABLE_PIN_ACTIVE
AQE_DEVICE_NOT_READY = AqeResult.DEVICE_NOT_READY
AQE_DIR_PIN_2MS_PAUSE_ADDED = AqeResult.DIR_PIN_2MS_PAUSE_ADDED
AQE_ERROR_TICKS_TOO_LOW = AqeResult.ERROR_TICKS_TOO_LOW
AQE_ERROR_EMPTY_QUEUE_TO_START = AqeResult.ERROR_EMPTY_QUEUE_TO_START
AQE_ERROR_NO_DIR_PIN_TO_TOGGLE = AqeResult.ERROR_NO_DIR_PIN_TO_TOGGLE
MOVE_TIMED_OK = MoveTimedResult.OK
MOVE_TIMED_BUSY = MoveTimedResult.MOVE_BUSY
MOVE_TIMED_EMPTY = MoveTimedResult.MOVE_EMPTY
MOVE_TIMED_TOO_LARGE_ERROR = MoveTimedResult.ERROR_MOVE_TOO_LARGE
DRIVER_MCPWM_PCNT = FasDriver.MCPWM_PCNT
DRIVER_RMT = FasDriver.RMT
DRIVER_I2S_DIRECT = FasDriver.I2S_DIRECT
DRIVER_I2S_MUX = FasDriver.I2S_MUX
DRIVER_DONT_CARE = FasDriver.DONT_CARE
DELAY_OK = DelayResult.OK
DELAY_TOO_LOW = DelayResult.TOO_LOW
DELAY_TOO_HIGH = DelayResult.TOO_HIGH
RAMP_STATE_IDLE = RampState.IDLE
RAMP_STATE_COAST = RampState.COAST
RAMP_STATE_ACCELERATE = RampState.ACCELERATE
RAMP_STATE_DECELERATE = RampState.DECELERATE
RAMP_STATE_REVERSE = RampState.REVERSE


# ----------------------------------------------------------------- helpers
def move_is_ok(code: MoveResult) -> bool:
    return code == MoveResult.OK


def aqe_is_ok(code: AqeResult) -> bool:
    return code == AqeResult.OK


def aqe_retry(code: AqeResult) -> bool:
    """Positive codes mean: the entry was not taken now, try again later."""
    return int(code) > 0


def move_timed_is_ok(code: MoveTimedResult) -> bool:
    return code == MoveTimedResult.OK


def delay_is_valid(code: DelayResult) -> bool:
    return code == DelayResult.OK


def tmr_from(code: AqeResult) -> MoveTimedResult:
    """The ``move_timed`` code with the same value as an ``add_queue_entry`` code."""
    return MoveTimedResult(int(code))


_UNKNOWN = "Unknown Error"
_AQE_TEXT = {
    AqeResult.OK: "OK",
    AqeResult.QUEUE_FULL: "Queue Full",
    AqeResult.DIR_PIN_2MS_PAUSE_ADDED: "Dir Pin 2ms Pause Added",
    AqeResult.DIR_PIN_IS_BUSY: "Direction Pin is Busy",
    AqeResult.WAIT_FOR_ENABLE_PIN_ACTIVE: "Waiting for Enable Pin Active",
    AqeResult.DEVICE_NOT_READY: "Device Not Ready",
    AqeResult.ERROR_TICKS_TOO_LOW: "Error: Ticks Too Low",
    AqeResult.ERROR_EMPTY_QUEUE_TO_START: "Error: Empty Queue to Start",
    AqeResult.ERROR_NO_DIR_PIN_TO_TOGGLE: "Error: No Direction Pin to Toggle",
}
_MOVE_TEXT = {
    MoveResult.OK: "OK",
    MoveResult.ERR_NO_DIRECTION_PIN: "Error: No Direction Pin",
    MoveResult.ERR_SPEED_IS_UNDEFINED: "Error: Speed is Undefined",
    MoveResult.ERR_ACCELERATION_IS_UNDEFINED: "Error: Acceleration is Undefined",
}
_MOVE_TIMED_TEXT = {
    MoveTimedResult.MOVE_BUSY: "Move still ongoing",
    MoveTimedResult.MOVE_EMPTY: "Queue has been empty",
    MoveTimedResult.ERROR_MOVE_TOO_LARGE: "Error: Move too large",
}
_DELAY_TEXT = {
    DelayResult.OK: "OK",
    DelayResult.TOO_LOW: "Delay Too Low",
    DelayResult.TOO_HIGH: "Delay Too High",
}


def to_string(code: AqeResult | MoveResult | MoveTimedResult | DelayResult) -> str:
    """Upstream's ``toString()`` for every result-code type."""
    if isinstance(code, MoveTimedResult):
        text = _MOVE_TIMED_TEXT.get(code)
        if text is not None:
            return text
        try:
            return _AQE_TEXT[AqeResult(int(code))]
        except ValueError:
            return _UNKNOWN
    if isinstance(code, MoveResult):
        return _MOVE_TEXT.get(code, _UNKNOWN)
    if isinstance(code, DelayResult):
        return _DELAY_TEXT.get(code, "Unknown Delay Status")
    if isinstance(code, AqeResult):
        return _AQE_TEXT.get(code, _UNKNOWN)
    raise TypeError(f"to_string: not a FastAccelStepper result code: {code!r}")


# the branches of _getNextCommand() a command's planning took (NextCommand.path, bits):
# the accelerating branch at a period under two MIN_CMD_TICKS (it looks at the ramp's
# coast), that look's multiplication (1..510 steps possible to coast), the period kept (a
# coast: no calculate_ticks()), the decelerating branch's calculate_ticks()
PATH_NEAR, PATH_CHECK, PATH_COAST, PATH_DEC = 1, 2, 4, 8
