"""A device that speaks the serial protocol and executes on the simulated machine.

It is what a board's firmware does, on this computer, split as the C firmware is
(``firmware/``): the session and link layer (:mod:`.session`, ``session.c``), the
queues and their messages (:mod:`.queues`, ``device.c``), the step generator
(:mod:`.stepgen`, ``stepgen.c``), limit switches (:mod:`.limits`), inputs
(:mod:`.inputs`) and user outputs (:mod:`.outputs`) on one board (:mod:`.board`).
:class:`Device` is the main loop (``main.c``): it owns the line, lets the machine's
time pass and wires the parts together.

The host's queue entries land in real command queues, and a tick-exact model of the
step timer (:class:`fas.sim.channel.SimChannel`, the AVR compare-interrupt model)
executes them.  The device reports queue progress, obeys stops and pin writes, and
stops every motion when the host has been silent longer than its watchdog time.

Time: the machine's tick counter is the device clock, advanced to ``clock`` - the
wall clock (optionally sped up) when serving a pty, or a
:class:`~fas.serial.clock.VirtualClock` in tests, where the device is a peer.
"""

from __future__ import annotations

import random
from collections.abc import Callable

from ..arch import Profile, get_profile
from ..queue import StepperQueue
from ..serial.clock import RealClock, VirtualClock, Wire
from ..serial.protocol import F_INPUTS, F_SIM_INPUTS, F_TIMED_OUTPUTS, FrameDecoder, encode_frame
from ..serial.stream import ByteStream, LinkClosed
from ..sim.machine import Machine
from ..sim.pins import EdgeRecorder
from .board import Board
from .inputs import DeviceInputs
from .limits import DeviceLimits
from .outputs import DeviceOutputs
from .queues import DeviceQueues
from .session import DEFAULT_STATUS_MS, DEFAULT_WATCHDOG_MS, Session

NS_PER_S = 1_000_000_000


class Device:
    """The protocol's device side on a simulated machine (see module text)."""

    def __init__(self, stream: ByteStream | None, profile: Profile | str | None = None,
                 clock: RealClock | VirtualClock | None = None, *,
                 watchdog_ms: int = DEFAULT_WATCHDOG_MS, status_ms: int = DEFAULT_STATUS_MS,
                 record: bool = False, boot_id: int | None = None,
                 queue_len: int | None = None, rx_slots: int | None = None) -> None:
        self.profile = p = get_profile(profile)
        self.clock = clock or RealClock()
        self.board = board = Board(p, record)
        self.tps = p.ticks_per_s
        self.boot_ns = self.clock.now_ns()
        # the queue rings as deep as the firmware's RAM allows (or as a test asks)
        ring_profile = p.with_queue_len(queue_len or p.serial_queue_len)
        self.decoder = FrameDecoder()
        self.steppers = DeviceQueues(board, ring_profile)
        self.limits = DeviceLimits(board, self.steppers)
        self.inputs = DeviceInputs(board, self.limits)
        self.outputs = DeviceOutputs(board)
        self.session = Session(
            board, self.steppers, self.limits, self.inputs, self.outputs, self.decoder,
            boot_id=random.getrandbits(16) if boot_id is None else boot_id & 0xFFFF,
            clock_hz=int(self.tps * self.clock.scale), queue_len=ring_profile.queue_len,
            rx_slots=p.serial_rx_slots if rx_slots is None else rx_slots,
            slot_payload=p.serial_slot_payload, watchdog_ms=watchdog_ms, status_ms=status_ms)
        # optional message families (Ident): inputs, limits and Started (section 18);
        # the inputs are this simulation's, so the host may set them (SetInput); timed
        # output changes (OutputAt, section 16)
        board.features = F_INPUTS | F_SIM_INPUTS | F_TIMED_OUTPUTS
        self.stream: ByteStream | None = None
        self.in_wires: list[Wire] = []
        self.attach(stream)

    # ------------------------------------------------- the parts, at a glance
    @property
    def machine(self) -> Machine:
        return self.board.machine

    @property
    def recorder(self) -> EdgeRecorder | None:
        return self.board.recorder

    @property
    def counters(self) -> dict[str, int]:
        """DeviceStatus's counters (since the session opened)."""
        return self.board.counters

    @property
    def queues(self) -> dict[int, StepperQueue]:
        """The configured queues by stepper."""
        return self.steppers.queues

    @property
    def features(self) -> int:
        """Ident's optional message families (a test may take some away)."""
        return self.board.features

    @features.setter
    def features(self, value: int) -> None:
        self.board.features = value

    @property
    def listeners(self) -> list[Callable[[str], None]]:
        """Called with each session event (opened, closed, watchdog, emergency stop)."""
        return self.session.listeners

    @property
    def default_watchdog_ms(self) -> int:
        return self.session.default_watchdog_ms

    # ---------------------------------------------------------------- clock
    def tick_at(self, now_ns: int) -> int:
        return (now_ns - self.boot_ns) * self.tps // NS_PER_S

    def ns_at(self, tick: int) -> int:
        return self.boot_ns + -(-tick * NS_PER_S // self.tps)

    @property
    def now(self) -> int:
        return self.board.machine.now

    @property
    def clock_hz(self) -> int:
        """The rate of the tick counter per second of the host's clock (Ident)."""
        return self.session.clock_hz

    # ----------------------------------------------------------- the line
    def attach(self, stream: ByteStream | None) -> None:
        """Plug a line in (``None``: unplugged; the machine keeps running)."""
        self.stream = stream
        self.decoder.reset()
        self.in_wires = [stream.rx_wire] if stream is not None and stream.rx_wire else []

    def unplug(self) -> None:
        if self.stream is not None:
            if self.stream.rx_wire is not None:
                self.stream.rx_wire.drain()
            self.stream.close()
        self.attach(None)

    def poll(self) -> None:
        """Take every byte that arrived and act on the frames in it."""
        on_frame = self.session.on_frame
        for seq, payload in self._receive():
            on_frame(seq, payload)

    def _receive(self) -> list[tuple[int, bytes]]:
        if self.stream is None:
            return []
        try:
            data = self.stream.read_available()
        except LinkClosed:
            self.attach(None)
            return []
        frames = self.decoder.feed(data) if data else []
        counters = self.board.counters
        counters["crc_errors"] = self.decoder.crc_errors
        counters["framing_errors"] = self.decoder.framing_errors
        return frames

    def flush(self) -> bool:
        """Send what is queued (and a bare acknowledgement if one is due)."""
        payloads = self.session.take_frames()
        if payloads is None or self.stream is None:
            return False
        wrote = False
        seq = self.session.expected
        for payload in payloads:
            try:
                n = self.stream.write(encode_frame(seq, payload))
            except LinkClosed:
                self.attach(None)
                return wrote
            wrote = wrote or n > 0
        self.board.counters["tx_dropped"] = getattr(self.stream, "tx_dropped", 0)
        return wrote

    # --------------------------------------------------------------- time
    def advance(self, now_ns: int) -> None:
        """Run the machine up to ``now_ns``; stop on host silence; queue due reports."""
        t = self.tick_at(now_ns)
        board = self.board
        m = board.machine
        session = self.session
        deadline = session.watchdog_deadline()
        if deadline is not None and deadline <= t:
            if deadline > m.now:
                m.run_until(deadline)
            session.trip_watchdog()
        if t > m.now:
            m.run_until(t)
        if board.session_open:
            if self.inputs.watches:
                self.inputs.sample()
            session.report(t)

    def next_ns(self) -> int | None:
        m = self.board.machine
        times = []
        t = m.next_event_time()
        if t is not None:
            times.append(t)
        if self.board.session_open:
            times += self.session.wake_ticks()
            times += self.inputs.wake_ticks()
        if not times:
            return None
        return self.ns_at(max(min(times), m.now + 1))

    def serve(self, stop: Callable[[], bool] = lambda: False,
              each: Callable[[], None] | None = None) -> None:
        """Run in real time until ``stop()`` (the device's main loop on a pty);
        ``each()`` runs once per turn of the loop (e.g. inputs typed at the terminal)."""
        clock = self.clock
        session = self.session
        while not stop():
            if each is not None:
                each()
            self.advance(clock.now_ns())
            self.flush()
            nxt = self.next_ns()
            limit = clock.now_ns() + int(0.2 * NS_PER_S * clock.scale)  # look at stop()
            nxt = limit if nxt is None else min(nxt, limit)
            clock.wait(nxt, self.stream)
            # frames that waited in the buffer while this process was busy arrived before
            # now: they count for the watchdog before time is caught up (a UART interrupt
            # would have taken them on arrival)
            now = clock.now_ns()
            frames = self._receive()
            if frames and self.board.session_open:
                session.last_rx_tick = max(session.last_rx_tick, self.tick_at(now))
            self.advance(now)
            for seq, payload in frames:
                session.on_frame(seq, payload)
            self.flush()

    # ---------------------------------------------------------- the world
    def set_input(self, pin: int, value: int, analog: bool | None = None) -> None:
        """The world outside the board: a switch pulls ``pin`` to ``value`` (0/1) or a
        pot turns analog input ``pin`` to ``value`` (0..1023).  ``analog`` None: as the
        host watches the pin (digital if it does not)."""
        self.inputs.set_input(pin, value, analog)

    def schedule_input(self, tick: int, pin: int, value: int,
                       analog: bool | None = None) -> None:
        """``set_input`` at device tick ``tick`` (a switch that closes at a known time)."""
        self.inputs.schedule_input(tick, pin, value, analog)

    # ---------------------------------------------------------- inspection
    def position(self, stepper: int) -> int:
        return self.steppers.queues[stepper].current_position()

    def pulses(self, stepper: int) -> int:
        return self.steppers.channels[stepper].pulses

    def step_edges(self, stepper: int) -> int:
        """Rising edges seen on the stepper's step pin."""
        return self.board.machine.pins.rising(self.steppers.queues[stepper].step_pin)

    def running(self) -> bool:
        return self.steppers.running()
