"""StepperDemo's built-in test sequences 01-13.

Each sequence is a state machine called once per loop pass with the time in ms:
``step(app, stepper, slot, time_ms) -> finished``.  Its state lives in a
:class:`SeqSlot` (the firmware's ``test_seq_s``).  Setting ``slot.state`` to
:data:`TEST_STATE_ERROR` marks the test failed.

A sequence also says what it is waiting for, so that the simulated loop can skip
passes in which nothing can happen: ``slot.idle`` (only the machine or the clock can
change what it waits for) and ``slot.wake_ms`` (it waits until ``millis()`` reaches
this value).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable, Protocol

from ... import messages as msg
from ..build import demo_build
from .rand import make_rand

if TYPE_CHECKING:  # pragma: no cover
    from fas import Stepper
    from fas.arch import Profile
    from fas.backend import Backend

TEST_STATE_ERROR = 0xFFFF
PULSE_COUNTER_RAND_SEED = 135  # sequences 08 and 09 seed their random numbers with it



class SeqHost(Protocol):
    """What a sequence uses of the program that runs it (StepperDemo's app): its
    chip, its backend and its printing - the seam that keeps the sequences from
    importing the app."""

    @property
    def profile(self) -> Profile: ...
    @property
    def backend(self) -> Backend: ...
    def print(self, text: str | bytes) -> None: ...
    def println(self, text: str | bytes = "") -> None: ...
    def print_number(self, value: int) -> None: ...
    def println_number(self, value: int) -> None: ...


Sequence = Callable[["SeqHost", "Stepper", "SeqSlot", int], bool]


class SeqSlot:
    __slots__ = ("test", "state", "u32_1", "s32_1", "s16_1", "s16_2", "idle", "wake_ms",
                 "stop_only", "rng", "log")

    def __init__(self) -> None:
        self.test: Sequence | None = None
        self.state = 0
        self.u32_1 = 0
        self.s32_1 = 0
        self.s16_1 = 0
        self.s16_2 = 0
        self.idle = False
        self.wake_ms: int | None = None
        self.stop_only = False  # waiting only for the stepper to stop (wait_stop)
        self.rng: object | None = None
        self.log: list[dict] = []  # per-iteration records of the endless sequences

    def assign(self, seq: Sequence) -> None:
        """As the firmware: only the function and the state are reset."""
        self.test = seq
        self.state = 0
        self.idle = False
        self.wake_ms = None

    def wait_time(self, since_ms: int, duration_ms: int) -> None:
        self.idle = True
        self.stop_only = False
        self.wake_ms = (since_ms + duration_ms) & 0xFFFFFFFF

    def wait_machine(self) -> None:
        """Idle until something in the machine changes (a ramp state, a period): the
        loop looks after every interrupt, as the firmware's passes do."""
        self.idle = True
        self.wake_ms = None
        self.stop_only = False

    def wait_stop(self) -> None:
        """Idle until the stepper stops: only a stepper starting or stopping can end
        the wait, so the loop need not look after every interrupt."""
        self.idle = True
        self.wake_ms = None
        self.stop_only = True

    def busy(self) -> None:
        self.idle = False
        self.stop_only = False
        self.wake_ms = None


def elapsed(now_ms: int, since_ms: int) -> int:
    """``(uint32_t)(now - since)``."""
    return (now_ms - since_ms) & 0xFFFFFFFF


def start_with_pulse_counter(app: SeqHost, stepper: Stepper, slot: SeqSlot,
                             time_ms: int) -> bool:
    """First state of sequences 08 and 09: seed the random numbers, attach pulse
    counter 7 (where the chip has one) and note the time.  True when the counter
    cannot be attached: the error is printed and the test has failed."""
    slot.rng = make_rand(app.profile.name, PULSE_COUNTER_RAND_SEED)
    if app.profile.has_pulse_counter and not stepper.attach_to_pulse_counter(7):
        app.println(msg.SEQ_PULSE_COUNTER_ERROR)
        slot.state = TEST_STATE_ERROR
        return True
    slot.u32_1 = time_ms
    slot.state += 1
    return False


def _registry() -> dict[str, Sequence]:
    from . import (
        seq01,
        seq02,
        seq03,
        seq04,
        seq05,
        seq06,
        seq07,
        seq08,
        seq09,
        seq10,
        seq11,
        seq12,
        seq13,
    )

    return {
        "01": seq01.step, "02": seq02.step, "03": seq03.step, "04": seq04.step,
        "05": seq05.step, "06": seq06.step, "07": seq07.step, "08": seq08.step,
        "09": seq09.step, "10": seq10.step, "11": seq11.step, "12": seq12.step,
        "13": seq13.step,
    }


def __getattr__(name: str):
    """``SEQUENCES`` (code -> sequence) is made on first use: a console that never
    enters test mode does not load the sequences (start-up time)."""
    if name == "SEQUENCES":
        table = globals()["SEQUENCES"] = _registry()
        return table
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _finished_at_once(app, stepper, slot, time_ms: int) -> bool:
    """08 where the chip has no pulse counter: the firmware compiles it as "done"."""
    return True


def _endless_nothing(app, stepper, slot, time_ms: int) -> bool:
    """12 in the ATmega32U4 build: compiled empty, it never finishes."""
    slot.wait_machine()
    return False


def sequences_for(profile) -> dict[str, Sequence]:
    """The sequences as the firmware is compiled for ``profile``."""
    table = dict(__getattr__("SEQUENCES") if "SEQUENCES" not in globals()
                 else globals()["SEQUENCES"])
    if not profile.has_pulse_counter:
        table["08"] = _finished_at_once
    if demo_build(profile).small_build:
        table["12"] = _endless_nothing
        del table["13"]
    return table


__all__ = ["SEQUENCES", "SeqSlot", "TEST_STATE_ERROR", "elapsed", "sequences_for"]

