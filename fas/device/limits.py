"""Limit switches on the device (``firmware/limits.c``, docs/serial-protocol.md section 18).

A queue that steps towards a closed switch is stopped before a further pulse - when
the switch closes, and when an entry towards a switch already closed begins (the
step generator asks :meth:`DeviceLimits.guard`) - with the queues of the limit's stop
mask; they stay halted until the host's ForceStop, and the host hears LimitHit.
"""

from __future__ import annotations

from ..queue import QueueEntry
from ..serial.protocol import L_CLEAR, L_UP, Limit, LimitHit, Message
from .board import Board
from .queues import DeviceQueues, Handler

LimitRule = tuple[int, int, int]  # pin, level of a closed switch, stop mask


class DeviceLimits:
    """The limit switches of the queues: (stepper, up) -> rule."""

    def __init__(self, board: Board, queues: DeviceQueues) -> None:
        self.board = board
        self.queues = queues
        self.limits: dict[tuple[int, bool], LimitRule] = {}

    def handlers(self) -> dict[type[Message], Handler]:
        return {Limit: self.limit}

    def reset(self) -> None:
        """A new session: no limits."""
        self.limits.clear()

    def limit(self, m: Limit) -> None:
        queues = self.queues
        if queues.find(m.stepper) is None:
            return
        key = (m.stepper, bool(m.flags & L_UP))
        if m.flags & L_CLEAR:
            self.limits.pop(key, None)
            return
        lim = (m.pin, 1 if m.level else 0, m.stop_mask)
        self.limits[key] = lim
        ch = queues.channels[m.stepper]
        ch.entry_guard = lambda e, i=m.stepper: self.guard(i, e)
        # a switch already closed while the queue steps towards it stops it now
        if self.board.machine.pins.get(lim[0]) == lim[1] and ch.is_running() \
                and ch.moving_up() == key[1]:
            self._stop(m.stepper, lim)

    def guard(self, idx: int, entry: QueueEntry) -> bool:
        """The step generator takes up ``entry``: True stops it before its first pulse."""
        lim = self.limits.get((idx, entry.count_up))
        if lim is None or self.board.machine.pins.get(lim[0]) != lim[1]:
            return False
        self.queues.channels[idx].on_halt = lambda: self._stop(idx, lim)
        return True

    def pin_changed(self, pin: int, level: int) -> None:
        """A switch changed: stop the queues that step towards it now closed."""
        queues = self.queues
        for (idx, up), lim in list(self.limits.items()):
            if lim[0] != pin or lim[1] != level:
                continue
            if idx in queues.queues:
                ch = queues.channels[idx]
                if ch.is_running() and ch.moving_up() == up:
                    self._stop(idx, lim)

    def _stop(self, idx: int, lim: LimitRule) -> None:
        """Stop the queue and those in the limit's mask where their pulses are; tell the
        host; drop their entries and starts until the host's ForceStop (as a Halt)."""
        queues = self.queues
        now = self.board.machine.now
        for i in sorted({idx} | {j for j in queues.queues if lim[2] & (1 << j)}):
            if i != idx and not queues.channels[i].is_running():
                continue
            queues.stop_at_limit(i)
            q = queues.queues[i]
            self.board.send(LimitHit(i, lim[0], q.next_write_idx, queues.channels[i].pulse_pos,
                                     now & 0xFFFFFFFF))
        queues.queues_idle()
