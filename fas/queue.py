"""The per-stepper command queue and its position bookkeeping.

A command ``(ticks, steps, count_up)`` means: ``steps`` pulses ``ticks`` apart, then
one more ``ticks`` of wait; ``steps == 0`` is a pause.  The queue is a bounded ring
(16 entries on AVR, 32 on ESP32/SAM).  The library writes at ``next_write_idx``; the
backend's channel executes from ``read_idx``, counting down the steps of the entry it
is working on.  The current position at any instant is the end position of that
entry minus the steps it still has to make.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol

from .channel import QueueChannel, QueueEntry
from .codes import PIN_EXTERNAL_FLAG, PIN_UNDEFINED, AqeResult

if TYPE_CHECKING:  # pragma: no cover
    from typing_extensions import Self  # typing.Self is Python 3.11+

    from .arch import Profile

__all__ = ["AQE_OK", "QueueEntry", "QueueHost", "StepperQueue", "i32"]


class QueueHost(Protocol):
    """What a queue needs of its backend (:class:`fas.backend.Backend` has it)."""

    def allocate_channel(self, queue: StepperQueue) -> QueueChannel:
        """The executor of ``queue``."""

    def write_pin(self, pin: int, level: int) -> None:
        """Drive an output pin at once (a direction pin set before the first step)."""


# the ramp task compares results once per command: an Enum member read as a class
# attribute costs a metaclass lookup, a module constant does not
AQE_OK = AqeResult.OK


def i32(v: int) -> int:
    v &= 0xFFFFFFFF
    return v - 0x100000000 if v & 0x80000000 else v


class StepperQueue:
    """Ring buffer of commands shared by the library (writer) and a channel (reader)."""

    #: whether the channel runs: the channel's own ``is_running`` (asked very often:
    #: one call, not two)
    is_running: Callable[[], bool]

    # False: the driver cannot tell how far the running command got (ESP32 RMT, I2S);
    # get_current_position() then reports the command's start position
    position_in_command = True

    def __init__(self, index: int, profile: Profile, backend: QueueHost, step_pin: int,
                 *, length: int | None = None,
                 make_channel: Callable[[Self], QueueChannel] | None = None) -> None:
        """``length``: slots of the ring (default: the profile's queue length);
        ``make_channel``: its executor (default: the backend's ``allocate_channel``)."""
        self.index = index
        self.profile = profile
        self.backend = backend
        self.step_pin = step_pin
        self.queue_len = length = profile.queue_len if length is None else length
        self.entries = [QueueEntry() for _ in range(length)]
        # per slot: the ticks its command lasts as written (steps x ticks, or ticks for
        # one step or a pause) - what the ramp task sums over the queue every run
        # (ticks_in_queue); the channel changes only the entry it executes
        self.durations = [0] * length
        # per slot: 1 where its command makes at most one step (a pause too), as written
        # (total_steps <= 1) - what the ramp task's fill counts over the queue every run
        # on build d (fas.sim's SimChannel.queue_sum_ticks)
        self.singles = [0] * length
        self.read_idx = 0
        self.next_write_idx = 0
        self.queue_end_pos = 0
        self.queue_end_count_up = True
        self.queue_end_dir = True
        self.ignore_commands = False
        self.dir_pin = PIN_UNDEFINED
        self.dir_high_counts_up = True
        self.max_speed_in_ticks = profile.ticks_per_s // 1000
        self.last_command_ticks = 65535
        self.entries_added = 0  # statistics for invariants and reports
        self.max_fill = 0
        self.channel: QueueChannel = (backend.allocate_channel(self) if make_channel is None
                                      else make_channel(self))
        self.is_running = self.channel.is_running
        # the channel may refuse commands (a link not connected): asked only then
        self._ask_ready = (type(self.channel).ready_for_commands
                           is not QueueChannel.ready_for_commands)

    # ------------------------------------------------------------- queries
    def queue_entries(self) -> int:
        self.channel.sync()
        return (self.next_write_idx - self.read_idx) & 0xFF

    def is_queue_full(self) -> bool:
        self.channel.sync()
        return ((self.next_write_idx - self.read_idx) & 0xFF) >= self.queue_len

    def is_queue_empty(self) -> bool:
        self.channel.sync()
        return self.next_write_idx == self.read_idx

    def has_steps_in_queue(self) -> bool:
        self.channel.sync()
        rp, wp = self.read_idx, self.next_write_idx
        while rp != wp:
            if self.entries[rp % self.queue_len].steps > 0:
                return True
            rp = (rp + 1) & 0xFF
        return False

    def ticks_in_queue(self) -> int:
        """Ticks of all entries after the one being executed."""
        self.channel.sync()
        rp, wp = self.read_idx, self.next_write_idx
        if rp == wp:
            return 0
        n = self.queue_len
        first = (rp + 1) % n
        count = (wp - rp - 1) & 0xFF
        durations = self.durations
        if first + count <= n:
            return sum(durations[first:first + count])
        return sum(durations[first:]) + sum(durations[:first + count - n])

    def fill_ticks_in_queue(self) -> int:
        """``ticks_in_queue()`` as the ramp task's fill reads it."""
        ticks = self.ticks_in_queue()
        return ticks - self.channel.fill_begins()

    def has_ticks_in_queue(self, min_ticks: int) -> bool:
        self.channel.sync()
        rp, wp = self.read_idx, self.next_write_idx
        if rp == wp:
            return False
        rp = (rp + 1) & 0xFF
        while rp != wp:
            e = self.entries[rp % self.queue_len]
            tmp = e.ticks * max(e.steps, 1)
            if tmp >= min_ticks:
                return True
            min_ticks -= tmp
            rp = (rp + 1) & 0xFF
        return False

    def actual_ticks_with_direction(self) -> tuple[bool, int, bool]:
        """(valid, ticks, count_up) of the step rate being executed right now."""
        self.channel.sync()
        rp, wp = self.read_idx, self.next_write_idx
        if rp == wp:
            return True, 0, True
        e = self.entries[rp % self.queue_len]
        if e.steps > 0:
            if e.steps > 1:
                return True, e.ticks, e.count_up
            nxt = (rp + 1) & 0xFF
            if nxt != wp and self.entries[nxt % self.queue_len].steps > 0:
                return True, e.ticks, e.count_up
            return False, e.ticks, e.count_up
        return False, 0, True

    def current_position(self) -> int:
        self.channel.sync()
        rp, wp = self.read_idx, self.next_write_idx
        if rp == wp:
            return self.queue_end_pos
        e = self.entries[rp % self.queue_len]
        if e.steps == 0:
            return e.end_pos
        left = e.steps if self.position_in_command else e.total_steps
        return i32(e.end_pos - left if e.count_up else e.end_pos + left)

    # ------------------------------------------------------------- writing
    def add_queue_entry(self, ticks: int | None, steps: int = 0, count_up: bool = True,
                        start: bool = True, bare: bool = False) -> AqeResult:
        """Append one command (``ticks is None``: only start the queue).  ``bare``: the
        library writes it itself, no planner computed it (:attr:`QueueEntry.bare`)."""
        channel = self.channel
        if self._ask_ready and not channel.ready_for_commands():
            return AqeResult.DEVICE_NOT_READY
        if ticks is None:
            if start and not self.is_running():
                if self.next_write_idx == self.read_idx:
                    return AqeResult.ERROR_EMPTY_QUEUE_TO_START
                channel.start()
            return AQE_OK
        channel.sync()  # once: nothing below moves the read index
        wp = self.next_write_idx
        if ((wp - self.read_idx) & 0xFF) >= self.queue_len:
            return AqeResult.QUEUE_FULL
        command_rate_ticks = ticks * steps if steps > 1 else ticks
        if command_rate_ticks < self.profile.min_cmd_ticks:
            return AqeResult.ERROR_TICKS_TOO_LOW
        if steps > 1 and wp == self.read_idx and self._restart_loses_toggle(wp, count_up):
            # the step interrupt restarts a queue that ran dry (its channel still runs
            # out the last period) through its single-step path only: a longer entry
            # there keeps its direction toggle until its last step.  The first step
            # goes as an entry of its own, the direction changes before it.
            first = max(ticks, self.profile.min_cmd_ticks)
            res = self._append(wp, first, 1, count_up, False, first, bare)
            if res != AQE_OK:
                return res
            wp = self.next_write_idx
            steps -= 1
            command_rate_ticks = ticks * steps if steps > 1 else ticks
            if command_rate_ticks < self.profile.min_cmd_ticks:
                ticks = self.profile.min_cmd_ticks  # (one step left, too short alone)
                command_rate_ticks = ticks
            return self._append(wp, ticks, steps, count_up, start, command_rate_ticks, bare)

        return self._append(wp, ticks, steps, count_up, start, command_rate_ticks, bare)

    def _restart_loses_toggle(self, wp: int, count_up: bool) -> bool:
        """An entry written now follows a queue that ran dry while its channel runs,
        and turns the direction round."""
        return (wp == self.read_idx and not self.ignore_commands
                and self.dir_pin != PIN_UNDEFINED and (self.dir_pin & PIN_EXTERNAL_FLAG) == 0
                and (count_up == self.dir_high_counts_up) != self.queue_end_dir
                and self.channel.is_running())

    def _append(self, wp: int, ticks: int, steps: int, count_up: bool, start: bool,
                duration: int, bare: bool = False) -> AqeResult:
        """Write the command at write index ``wp`` (there is room), advance the queue's
        end unless commands are ignored, tell the channel and start it if asked."""
        slot = wp % self.queue_len
        e = self.entries[slot]
        dir_level = count_up == self.dir_high_counts_up
        toggle_dir = False
        if self.dir_pin != PIN_UNDEFINED:
            if (wp == self.read_idx and not self.is_running()
                    and (self.dir_pin & PIN_EXTERNAL_FLAG) == 0):
                # set the pin right here (needed for shared direction pins)
                self.backend.write_pin(self.dir_pin, 1 if dir_level else 0)
                self.queue_end_dir = dir_level
            else:
                toggle_dir = dir_level != self.queue_end_dir
        e.steps = steps
        e.total_steps = steps
        e.ticks = ticks
        self.durations[slot] = duration
        self.singles[slot] = 1 if steps <= 1 else 0
        e.count_up = count_up
        e.toggle_dir = toggle_dir
        e.dir_level = dir_level
        e.bare = bare
        end_pos = self.queue_end_pos + (steps if count_up else -steps)
        if not -0x80000000 <= end_pos <= 0x7FFFFFFF:  # (i32() only where it wraps: hot path)
            end_pos = i32(end_pos)
        e.end_pos = end_pos

        channel = self.channel
        if not self.ignore_commands:
            wp = (wp + 1) & 0xFF
            self.next_write_idx = wp
            self.queue_end_pos = end_pos
            self.queue_end_dir = dir_level
            self.queue_end_count_up = count_up
            self.entries_added += 1
            fill = (wp - self.read_idx) & 0xFF
            if fill > self.max_fill:
                self.max_fill = fill
            channel.entry_added()

        if start and not self.is_running():
            channel.start()
        self.last_command_ticks = ticks
        return AQE_OK

    def start_queue(self) -> None:
        self.channel.start()

    def force_stop(self) -> None:
        """Stop the channel at once and drop every queued entry."""
        self.channel.force_stop()
        self.read_idx = self.next_write_idx

    def take_over(self, previous: StepperQueue) -> None:
        """This queue becomes the stepper's instead of ``previous`` (a planner with a
        queue of its own, :meth:`fas.stepper.Stepper.use_planner`): it goes on from
        ``previous``'s end - position, direction, direction pin - and its channel
        from ``previous``'s (pulse counter, detached step pin)."""
        if previous is self:
            return
        previous.channel.sync()
        self.queue_end_pos = previous.queue_end_pos
        self.queue_end_count_up = previous.queue_end_count_up
        self.queue_end_dir = previous.queue_end_dir
        self.dir_pin = previous.dir_pin
        self.dir_high_counts_up = previous.dir_high_counts_up
        self.channel.take_over(previous.channel)
        self.channel.sync()

    def truncate(self, index: int) -> None:
        """Drop the entries from write index ``index`` on (a cut, see
        :meth:`fas.channel.QueueChannel.cut`): the queue ends where entry ``index - 1``
        ends.  ``index`` lies after the read index."""
        last = self.entries[(index - 1) % self.queue_len]
        self.next_write_idx = index & 0xFF
        self.queue_end_pos = last.end_pos
        self.queue_end_count_up = last.count_up
        self.queue_end_dir = last.dir_level

    def shift_positions(self, delta: int) -> None:
        """Renumber every queued position by ``delta`` (set position while moving)."""
        self.channel.sync()
        rp, wp = self.read_idx, self.next_write_idx
        while rp != wp:
            e = self.entries[rp % self.queue_len]
            e.end_pos = i32(e.end_pos + delta)
            rp = (rp + 1) & 0xFF
        self.queue_end_pos = i32(self.queue_end_pos + delta)
        self.channel.positions_shifted(delta)
