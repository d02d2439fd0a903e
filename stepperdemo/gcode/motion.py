"""What moves, and the seam to what executes it.

*What moves* is a :class:`BlockQueue` of straight segments (:class:`~.interp.Move`:
start and target in steps per axis, a feed in units/min or rapid, a jog flag),
filled by the G-code machine as lines are parsed - Grbl's planner buffer (15 blocks
usable of 16, what ``Bf:`` reports).

*How it is executed* is a :class:`MotionExecutor`: it takes blocks from the queue
in order and turns them into each axis's FastAccelStepper queue commands, and it
answers the real-time requests a Grbl controller must honour - a feed hold that
decelerates along the path and a resume that goes on from there with no step lost,
a jog cancel, feed and rapid overrides.  Two executors read the same queue - the
machine (:mod:`.machine`) knows only this interface and picks one with
:func:`make_executor`:

* :class:`~.lookahead_exec.LookaheadExecutor` (the default): the blocks planned with
  look-ahead by ``fas.path`` (junction deviation ``$11``, blocks joining without a
  pause);
* :class:`~.exact_stop.ExactStopExecutor` (``$171=1``, or where the steppers cannot
  form a path group): every block from rest to rest (issue 24).

**Laser hook.**  :meth:`MotionExecutor.set_speed_listener` registers
``fn(tick, speed, move)``: called for every queue command of the dominant axis (the
one with the most steps) of each block, as the command is written - ahead of time,
with the tick at which it begins on the pins - with the path speed from there in
units/min (0 where the path stops) and the block (the :class:`~.interp.Move`).  A
laser's power proportional to the speed (Grbl's M4 in laser mode, ``$32``) follows
it, updated at every queue command.  Both executors have it (the look-ahead one
through ``fas.path``'s ``speed_listener``).

An executor reaches the steppers through a :class:`MotionHost` (the machine).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections import deque
from collections.abc import Callable, Iterator
from enum import Enum
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:  # pragma: no cover
    from fas.backend import Backend
    from fas.codes import AqeResult

    from .interp import Move
    from .settings import GcodeSettings

BLOCKS = 15  # usable planner blocks (Grbl's BLOCK_BUFFER_SIZE 16, one kept empty)

#: the laser hook: ``fn(tick, speed units/min, move or None)`` - see
#: :meth:`MotionExecutor.set_speed_listener`
SpeedListener = Callable[[int, float, Any], None]


class BlockQueue:
    """The blocks waiting for execution, oldest first (at most :data:`BLOCKS`)."""

    def __init__(self, size: int = BLOCKS) -> None:
        self.size = size
        self._blocks: deque[Move] = deque()
        #: the same deque, to read (hot paths take its length without a call)
        self.items = self._blocks
        #: jog moves ever pushed (while none was, no block is a jog: not looked for)
        self.jogs_pushed = 0

    def __len__(self) -> int:
        return len(self._blocks)

    def __iter__(self) -> Iterator[Move]:
        return iter(self._blocks)

    @property
    def room(self) -> int:
        return self.size - len(self._blocks)

    def push(self, block: Move) -> None:
        blocks = self._blocks
        if len(blocks) == self.size:  # (no room)
            raise OverflowError("block queue full")  # the machine checks room first
        if block.jog:
            self.jogs_pushed += 1
        blocks.append(block)

    def peek(self) -> Move | None:
        return self._blocks[0] if self._blocks else None

    def pop(self) -> Move:
        return self._blocks.popleft()

    def clear(self) -> None:
        self._blocks.clear()


class HoldState(Enum):
    NONE = 0  # executing (or idle)
    STOPPING = 1  # a hold decelerates (Grbl's Hold:1)
    HELD = 2  # stopped by a hold, waiting for a resume (Hold:0)


class MotionHost(Protocol):
    """What an executor may use of the machine."""

    backend: Backend
    steppers: list  # fas.Stepper per axis
    settings: GcodeSettings

    def enable_drivers(self) -> None:
        """The drivers are switched on (before a block starts)."""

    def motion_failed(self, result: AqeResult) -> None:
        """The library refused a queue command: the machine goes into alarm."""


class MotionExecutor(ABC):
    """Executes the blocks of a :class:`BlockQueue` (see the module text).

    The machine calls :meth:`poll` whenever time has passed (and no later than
    :meth:`wake_tick`); everything else is a request that takes effect at once or
    at the next :meth:`poll`."""

    def __init__(self, host: MotionHost, blocks: BlockQueue) -> None:
        self.host = host
        self.blocks = blocks

    # ----------------------------------------------------------- driving
    @abstractmethod
    def poll(self) -> None:
        """Start blocks, feed the queues, notice the end of blocks and holds - now."""

    @abstractmethod
    def wake_tick(self) -> int | None:
        """When :meth:`poll` next has work (None: only a new block or request)."""

    # ---------------------------------------------------------- requests
    @abstractmethod
    def hold(self) -> None:
        """Feed hold: decelerate along the path to rest, keep the rest of the path."""

    @abstractmethod
    def resume(self) -> None:
        """Cycle start after a hold: go on along the path from where it stopped."""

    @abstractmethod
    def discard(self) -> None:
        """After a hold has stopped: drop the rest of the block in execution (a jog
        cancel); the queue's blocks are the machine's to drop."""

    @abstractmethod
    def abort(self) -> None:
        """Stop every axis at once (reset, alarm): nothing of the blocks is kept."""

    @abstractmethod
    def set_overrides(self, feed_percent: int, rapid_percent: int) -> None:
        """Feed override (G1, not jogs) and rapid override (G0), from now on."""

    # -------------------------------------------------------------- state
    @abstractmethod
    def hold_state(self) -> HoldState:
        """Whether a hold is decelerating or has stopped."""

    @abstractmethod
    def current(self) -> Move | None:
        """The block in execution (also while held)."""

    @abstractmethod
    def busy(self) -> bool:
        """A block executes, is held, or waits in the queue."""

    @abstractmethod
    def moving(self) -> bool:
        """An axis is stepping or about to (a reset now loses the position)."""

    @abstractmethod
    def committed(self) -> bool:
        """Every block taken so far is in the steppers' queues, beyond any hold: a
        synchronized output handed to the library now changes after all of it."""

    @abstractmethod
    def path_rate(self) -> float:
        """The speed along the path now, units/min (``FS:``)."""

    def set_speed_listener(self, fn: SpeedListener | None, lasers_only: bool = False) -> bool:
        """The laser hook (issue 25): ``fn(tick, speed, move)`` for every queue command
        of the dominant axis (the one with the most steps) of each block, as the
        command is written - ahead of time, with the tick at which it begins on the
        pins - with the path speed from there in units/min (0 where the path stops)
        and the block (the :class:`~.interp.Move`).  Grbl's M4 laser power follows it.
        ``lasers_only``: ``fn`` does nothing for a block without a laser
        (``Move.laser`` None, or no Move): the executor may leave it untold of them.
        False: this executor has none."""
        return False


def make_executor(host: MotionHost, blocks: BlockQueue) -> MotionExecutor:
    """The executor the settings ask for (``$171``) and the steppers allow."""
    from .exact_stop import ExactStopExecutor
    from .lookahead_exec import LookaheadExecutor, lookahead_fits
    from .settings import MOTION_LOOKAHEAD

    if host.settings.motion == MOTION_LOOKAHEAD and lookahead_fits(host.steppers):
        return LookaheadExecutor(host, blocks)
    return ExactStopExecutor(host, blocks)


def wanted_kind(host: MotionHost) -> str:
    """``"lookahead"`` or ``"exact_stop"``: what :func:`make_executor` would make now."""
    from .lookahead_exec import lookahead_fits
    from .settings import MOTION_LOOKAHEAD

    if host.settings.motion == MOTION_LOOKAHEAD and lookahead_fits(host.steppers):
        return "lookahead"
    return "exact_stop"
