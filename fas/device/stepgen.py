"""The device's step generator (``firmware/stepgen.c``): the step timer on one queue.

It is the tick-exact model of the AVR compare interrupt the simulated chip uses
(:class:`fas.sim.channel.SimChannel`), plus what the firmware counts beside it: the
position its pulses amount to, which survives any stop, and the queue's underruns.
"""

from __future__ import annotations

from ..queue import StepperQueue, i32
from ..sim.channel import SimChannel
from ..sim.machine import Machine


class DeviceChannel(SimChannel):
    """The simulated step timer, plus the position its emitted pulses amount to."""

    def __init__(self, machine: Machine, queue: StepperQueue) -> None:
        super().__init__(machine, queue)
        self.pulse_pos = 0  # exact position from the pulses made (survives any stop)
        self.underruns = 0

    def _made(self, count: int) -> None:
        q = self.q
        e = q.entries[q.read_idx % q.queue_len]
        self.pulse_pos = i32(self.pulse_pos + (count if e.count_up else -count))
        super()._made(count)
