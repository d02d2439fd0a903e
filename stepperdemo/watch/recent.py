"""The recent motion: a bounded recording of the pins, on by default in the console.

:class:`RecentTrace` consumes the ordered edge stream of a simulated chip
(:class:`fas.sim.trace.EdgeStream`) and keeps the last :data:`MAX_EDGES` edges of the
recorded pins, in chunks of :data:`CHUNK_EDGES` made of compact arrays: per edge its
tick (8 bytes) and level (1 byte), per run of one pin the pin and where the run ends.
When a new chunk would take the recording past the bound, the oldest chunk is
dropped, so memory stays flat however long the session.  Recording copies the edges
and nothing more; the figures are made when asked: :meth:`RecentTrace.window` replays
the kept edges into the consumers a full recording feeds as it goes
(:class:`~.motion.MotionAnalysis`, :class:`~.outputs.OutputAnalysis`, a program's
own), :meth:`RecentTrace.export_vcd` writes them as VCD.

Dropping the oldest chunk carries what it did forward into the *head state*, so that
a replay from the head gives the figures a recording from the start gives over the
same window: every pin's level, every stepper's position (its rising step edges
counted with the direction pin's level at the time), its pulse number, the step
period in force, and the channel's counts (queue ran empty, missed compares, starts)
as they were when the queue entry the window starts in was taken up.
"""

from __future__ import annotations

from array import array
from collections import deque
from collections.abc import Iterator, Sequence

from fas.sim import SimBackend
from fas.sim.channel import ENTRY_START, SimChannel
from fas.sim.trace import EdgeStream, VcdWriter, pin_levels

from .. import messages as msg
from .motion import ChannelCounts, MotionAnalysis, Wiring, demo_wiring, shared_step_pins
from .observe import recorded_signals
from .outputs import OutputAnalysis

MAX_EDGES = 1 << 19  # edges kept: 524 288 (10.5 s of one stepper at 25 000 steps/s)
CHUNK_EDGES = 1 << 14  # edges per chunk: the oldest chunk is dropped as a whole
REFERENCE_EDGES_PER_S = 50_000  # one stepper at 25 kHz, for "about N s" in the texts
# run pin of a marker: ``BIND_MARK - step pin`` - a channel drives that step pin from
# here on (its rising edges count as steps from then on, as in MotionAnalysis)
BIND_MARK = -1000
_COMPACT = 4096  # entries consumed before the entry arrays are compacted

Counts = tuple[int, int, int, int]  # pulses, dry, missed compares, starts


def _counts(ch: SimChannel) -> Counts:
    return ch.pulses, ch.dry, ch.missed_compares, ch.starts


def bound_seconds(max_edges: int = MAX_EDGES) -> float:
    """How long the bound lasts for one stepper at 25 kHz (2 edges per step)."""
    return max_edges / REFERENCE_EDGES_PER_S


class _Chunk:
    __slots__ = ("times", "levels", "pins", "ends", "strays")

    def __init__(self, strays: tuple[int, int]) -> None:
        self.times = array("q")
        self.levels = bytearray()
        self.pins = array("h")  # per run: the pin (or a bind marker)
        self.ends = array("i")  # per run: index after its last edge
        self.strays = strays  # the backend's stray-read counts when the chunk began

    def runs(self) -> Iterator[tuple[int, int, int]]:
        """``(pin, start, end)`` of every run, in time order."""
        a = 0
        for pin, b in zip(self.pins, self.ends, strict=True):
            yield pin, a, b
            a = b

    def nbytes(self) -> int:
        return sum(arr.buffer_info()[1] * arr.itemsize
                   for arr in (self.times, self.pins, self.ends)) + len(self.levels)


class _Track:
    """One StepperDemo stepper: what a replay from the head needs."""

    def __init__(self, wiring: Wiring, position: int) -> None:
        self.wiring = wiring
        # head state (what the dropped edges left)
        self.position = position
        self.bound = False  # a channel drives the step pin (rises are steps)
        self.r = 0  # rising step edges before the head: the pulse number of the next
        self.cur_ticks: int | None = None  # the step period in force
        # the channels of the step pin so far: (channel, pulse base, counts at bind);
        # a channel's pulse index i is pulse number i - base
        self.chans: list[tuple[SimChannel, int, Counts]] = []
        # queue entries taken up (kind, pulse number of the first pulse, ticks, steps)
        self.kinds = array("b")
        self.firsts = array("q")
        self.ticks = array("q")
        self.steps = array("q")
        self.p0 = 0  # the first entry not before the head
        # a step pin shared with another role (motion.shared_step_pins): the pulse number
        # after the last pulse of the entries taken up by the head (None: not known, the
        # channel ran when bound) - rises beyond it are the other role's; the entries
        # taken up later: (tick, end)
        self.shared = False
        self.planned: int | None = 0
        self.pending: deque[tuple[int, int]] = deque()
        # channel counts where they changed: (pulse number, channel no, dry, missed,
        # starts) - the counts before the entry at that pulse number took effect
        self.counts: deque[tuple[int, int, int, int, int]] = deque()

    # ----------------------------------------------------------------- live
    def bind(self, channel: SimChannel) -> int:
        """A channel drives the step pin from now on; returns its number."""
        counts = _counts(channel)
        if self.chans:  # a planner switch: pulse numbers go on (as StepperMotion.bind)
            old, old_base, _ = self.chans[-1]
            base = channel.pulses + old_base - old.pulses
        else:
            base = channel.pulses
            self.counts.append((0, 0) + counts[1:])
            if channel.is_running():
                self.planned = None
        self.chans.append((channel, base, counts))
        return len(self.chans) - 1

    def note(self, no: int, kind: int, index: int, ticks: int, steps: int,
             tick: int = 0) -> None:
        """The channel took up a queue entry (at ``tick``)."""
        ch, base, _ = self.chans[no]
        r = index - base
        if self.shared:
            self.pending.append((tick, r + steps))
        self.kinds.append(kind)
        self.firsts.append(r)
        self.ticks.append(ticks)
        self.steps.append(steps)
        counts = (no, ch.dry, ch.missed_compares, ch.starts - (kind == ENTRY_START))
        if not self.counts or self.counts[-1][1:] != counts:
            self.counts.append((r,) + counts)

    # ----------------------------------------------------------------- head
    def up(self, levels: dict[int, int]) -> bool:
        w = self.wiring
        return w.direction is None or (levels.get(w.direction, 0) == 1) == w.high_counts_up

    def fold(self, max_entries: int) -> None:
        """Entries whose first pulse was dropped: their period carries on (and at most
        ``max_entries`` are kept, should a channel's pulses never reach the pins)."""
        firsts, steps, p, n = self.firsts, self.steps, self.p0, len(self.firsts)
        while p < n and (firsts[p] < self.r or n - p > max_entries):
            if steps[p]:
                self.cur_ticks = self.ticks[p]
            p += 1
        if p > _COMPACT and 2 * p > n:
            for arr in (self.kinds, self.firsts, self.ticks, self.steps):
                del arr[:p]
            p = 0
        self.p0 = p
        counts = self.counts
        while len(counts) > 1 and counts[1][0] <= self.r:
            counts.popleft()

    def resume_args(self) -> tuple:
        """Arguments of :meth:`StepperMotion.resume` for a replay from the head."""
        g = self.counts[0] if self.counts and self.counts[0][0] <= self.r else None
        first = g[1] if g is not None else 0
        chans = self.chans[first:]
        bases: list[tuple[SimChannel, dict[str, int]]] = []
        for i, (ch, base, at_bind) in enumerate(chans):
            pulses, dry, missed, starts = at_bind
            if i == 0:
                pulses = self.r + base
                if g is not None:
                    dry, missed, starts = g[2:]
            bases.append((ch, {"pulses": pulses, "dry": dry, "missed_compares": missed,
                               "starts": starts}))
        p = self.p0
        entries = list(zip(self.kinds[p:], self.firsts[p:], self.ticks[p:], self.steps[p:],
                           strict=True))
        channel, base = bases[-1]
        return (channel, base, bases[:-1], self.r, self.cur_ticks, entries, self.planned,
                list(self.pending))

    def shared_rises(self, times: Sequence[int], levels: bytearray, a: int, b: int) -> int:
        """Of the rises of a shared step pin in ``levels[a:b]``, the steps (the head
        moves over them, taking up the entries due)."""
        pending, steps = self.pending, 0
        for i in range(a, b):
            if not levels[i]:
                continue
            t = times[i]
            while pending and pending[0][0] <= t:
                end = pending.popleft()[1]
                if self.planned is None or end > self.planned:
                    self.planned = end
            if self.planned is None or self.r + steps < self.planned:
                steps += 1
        return steps

    def nbytes(self) -> int:
        return sum(a.buffer_info()[1] * a.itemsize
                   for a in (self.kinds, self.firsts, self.ticks, self.steps))


class _ReplayStream:
    """What a replay offers in place of the live stream (``stream.add`` for a
    program's own consumers, the window's start for the report)."""

    def __init__(self, start_tick: int, late_edges: int) -> None:
        self.start_tick = start_tick
        self.late_edges = late_edges
        self.consumers: list = []

    def add(self, consumer) -> None:
        self.consumers.append(consumer)


class RecordedWindow:
    """The kept edges replayed: what ``/plot`` and ``/report`` read (the interface of
    a finished :class:`~.observe.Observers`), over the window of the recording."""

    def __init__(self, trace: RecentTrace, end_tick: int) -> None:
        self.backend = trace.backend
        self.profile = trace.profile
        self.wiring = trace.wiring
        self.stream = _ReplayStream(trace.head_tick, trace.stream.late_edges)
        self.end_tick = end_tick
        self.start_positions = [t.position for t in trace.tracks]  # at the window start
        self.start_levels = dict(trace.head_levels)
        self.analysis: MotionAnalysis | None = None
        self.outputs: OutputAnalysis | None = None

    def flush(self) -> None:
        """Nothing to bring up to date: the replay is complete."""

    def now_tick(self) -> int:
        return self.end_tick


class RecentTrace:
    """The last ``max_edges`` edges of the recorded pins (see the module text)."""

    def __init__(self, backend: SimBackend, *, positions: Sequence[int | None] | None = None,
                 extra_signals: dict[int, list[str]] | None = None,
                 max_edges: int = MAX_EDGES, chunk_edges: int | None = None) -> None:
        if chunk_edges is None:  # at least 8 chunks: at most an eighth is dropped at once
            chunk_edges = max(1, min(CHUNK_EDGES, max_edges // 8))
        if chunk_edges < 1 or max_edges < chunk_edges:
            raise ValueError("max_edges must hold at least one chunk of edges")
        self.backend = backend
        self.profile = backend.profile
        self.wiring = demo_wiring(self.profile)
        self.signals = recorded_signals(self.wiring, self.profile, extra_signals)
        self.max_edges = max_edges
        self.chunk_edges = chunk_edges
        self.max_chunks = max_edges // chunk_edges  # held <= max_chunks * chunk <= max_edges
        self.stream = EdgeStream(backend)
        positions = list(positions or [])
        self.tracks = [_Track(w, positions[i] if i < len(positions) and positions[i] is not None
                              else 0) for i, w in enumerate(self.wiring)]
        self._by_step = {t.wiring.step: t for t in self.tracks}
        for pin in shared_step_pins(self.wiring):
            self._by_step[pin].shared = True
        self.chunks: deque[_Chunk] = deque()
        self._chunk: _Chunk | None = None
        self.held = 0  # edges kept
        self.dropped = 0  # edges dropped from the head so far
        self.peak_held = 0
        self.head_tick = 0  # the window starts here: the state after the dropped edges
        self.head_levels: dict[int, int] = {}
        self.stray_head = (0, 0)
        self.end_tick: int | None = None
        self._listeners: list[tuple[SimChannel, object]] = []
        self._started = False

    # ------------------------------------------------------------ lifecycle
    def start(self) -> RecentTrace:
        b = self.backend
        self.head_tick = self.stream.start()
        self.head_levels = pin_levels(b, self.signals)
        self.stray_head = (b.stray_reads, b.stray_reads_during_pulse)
        self._new_chunk()
        for ch in b.channels:
            self._bind(ch, at_start=True)
        b.channel_listeners.append(self._bind)
        self.stream.add(self)
        self._started = True
        return self

    @property
    def active(self) -> bool:
        return self._started and self.end_tick is None

    @property
    def start_tick(self) -> int:
        """Where the window starts (moves on as the oldest edges are dropped)."""
        return self.head_tick

    def flush(self) -> None:
        """Take every edge that can no longer change (the pulses of running blocks)."""
        if self.active:
            self.stream.flush(settle=True)

    def finish(self) -> None:
        """Stop recording; what is kept stays for :meth:`window` and :meth:`export_vcd`."""
        if not self.active:
            return
        self.end_tick = self.stream.stop()
        for ch, fn in self._listeners:
            if fn in ch.entry_listeners:
                ch.entry_listeners.remove(fn)
        self._listeners.clear()
        if self._bind in self.backend.channel_listeners:
            self.backend.channel_listeners.remove(self._bind)
        for tr in self.tracks:  # what the channels did afterwards is not recorded
            tr.chans = [(ChannelCounts(ch), base, counts) for ch, base, counts in tr.chans]

    def discard(self) -> None:
        """Stop recording and let go of the edges."""
        self.finish()
        self.chunks.clear()
        self._chunk = None
        self.held = 0

    def now_tick(self) -> int:
        if self.end_tick is not None:
            return self.end_tick
        return max(self.stream.last_tick, self.backend.now())

    def edges(self) -> int:
        """Edges held now."""
        return self.held

    def nbytes(self) -> int:
        """Bytes of the arrays that hold the edges and the queue entries."""
        return (sum(c.nbytes() for c in self.chunks)
                + sum(t.nbytes() for t in self.tracks))

    # ------------------------------------------------------------- channels
    def _bind(self, channel: SimChannel, at_start: bool = False) -> None:
        tr = self._by_step.get(channel.step_pin)
        if tr is None or (tr.chans and tr.chans[-1][0] is channel):
            return
        first = not tr.chans
        no = tr.bind(channel)

        now = self.backend.now

        def note(kind: int, index: int, ticks: int, steps: int) -> None:
            tr.note(no, kind, index, ticks, steps, now())

        channel.entry_listeners.append(note)
        self._listeners.append((channel, note))
        if first:
            if at_start:
                tr.bound = True
            else:  # rises count as steps from here on in the replay
                c = self._chunk
                c.pins.append(BIND_MARK - channel.step_pin)
                c.ends.append(len(c.times))

    # ---------------------------------------------------------- edge stream
    def edge_run(self, pin: int, times: Sequence[int], levels: bytes) -> None:
        if pin not in self.signals:
            return
        c = self._chunk
        n = len(times)
        if n > self.chunk_edges - len(c.times):
            self._split(pin, times, levels)
            return
        c.times.extend(times)
        c.levels += levels
        c.pins.append(pin)
        c.ends.append(len(c.times))
        self.held += n
        if self.held > self.peak_held:
            self.peak_held = self.held

    def _split(self, pin: int, times: Sequence[int], levels: bytes) -> None:
        i, n = 0, len(times)
        while i < n:
            c = self._chunk
            room = self.chunk_edges - len(c.times)
            if room == 0:
                c = self._new_chunk()
                room = self.chunk_edges
            k = min(room, n - i)
            c.times.extend(times[i:i + k])
            c.levels += levels[i:i + k]
            c.pins.append(pin)
            c.ends.append(len(c.times))
            self.held += k
            i += k
        self.peak_held = max(self.peak_held, self.held)

    def _new_chunk(self) -> _Chunk:
        while len(self.chunks) >= self.max_chunks:
            self._drop()
        b = self.backend
        c = self._chunk = _Chunk((b.stray_reads, b.stray_reads_during_pulse))
        self.chunks.append(c)
        return c

    def _drop(self) -> None:
        """Drop the oldest chunk; carry what its edges did into the head state."""
        c = self.chunks.popleft()
        levels = self.head_levels
        by_step = self._by_step
        lv = c.levels
        for pin, a, b in c.runs():
            if pin <= BIND_MARK:
                tr = by_step.get(BIND_MARK - pin)
                if tr is not None:
                    tr.bound = True
                continue
            if a == b:
                continue
            tr = by_step.get(pin)
            if tr is not None and tr.bound:
                rises = (tr.shared_rises(c.times, lv, a, b) if tr.shared
                         else lv.count(1, a, b))
                tr.r += rises
                tr.position += rises if tr.up(levels) else -rises
            levels[pin] = lv[b - 1]
        if c.times:
            self.head_tick = c.times[-1]
        self.held -= len(c.times)
        self.dropped += len(c.times)
        self.stray_head = self.chunks[0].strays if self.chunks else c.strays
        for tr in self.tracks:
            tr.fold(self.max_edges)

    # --------------------------------------------------------------- replay
    def _replay(self, consumers: list, on_bind) -> None:
        for c in self.chunks:
            times, levels = c.times, c.levels
            for pin, a, b in c.runs():
                if pin <= BIND_MARK:
                    on_bind(BIND_MARK - pin)
                elif a < b:
                    run_t, run_l = times[a:b], bytes(levels[a:b])
                    for con in consumers:
                        con.edge_run(pin, run_t, run_l)

    def window(self, app=None) -> RecordedWindow:
        """Replay the kept edges: motion and output figures of the window (and the
        consumers ``app.watch`` adds, a program's own figures)."""
        self.flush()
        view = RecordedWindow(self, self.now_tick())
        analysis = MotionAnalysis(self.backend, self.wiring, positions=view.start_positions,
                                  initial=self.head_levels, live=False)
        analysis.stray_base = self.stray_head
        motions = {t.wiring.step: m for t, m in zip(self.tracks, analysis.steppers, strict=True)}
        for tr, m in zip(self.tracks, analysis.steppers, strict=True):
            if tr.bound:
                m.resume(*tr.resume_args())
        outputs = OutputAnalysis(self.profile, initial=self.head_levels)
        view.analysis, view.outputs = analysis, outputs
        view.stream.add(analysis)
        view.stream.add(outputs)
        if app is not None:
            app.watch(view)  # the program's own consumers (the winder's interlock)

        def on_bind(step_pin: int) -> None:
            tr, m = self._by_step.get(step_pin), motions.get(step_pin)
            if tr is not None and m is not None and m.channel is None and tr.chans:
                m.resume(*tr.resume_args())

        self._replay(view.stream.consumers, on_bind)
        analysis.finish(view.end_tick)
        outputs.finish(view.end_tick)
        return view

    def export_vcd(self, path: str, timescale: str | None = None) -> tuple[int, int]:
        """Write the kept edges as a VCD file in ``timescale`` (None: exact); returns the
        number of edges in it and how many of them have no width at that unit
        (``VcdWriter.zero_width``; OSError if the file cannot be written)."""
        self.flush()
        end = self.now_tick()
        with open(path, "w", encoding="ascii", newline="\n", buffering=1 << 20) as f:
            writer = VcdWriter(f, self.signals, self.profile.ticks_per_s,
                               start_tick=self.head_tick, initial=self.head_levels,
                               timescale=timescale,
                               comment=msg.VCD_COMMENT.format(profile=self.profile.name))
            self._replay([writer], lambda _pin: None)
            writer.close(end)
        return writer.changes, writer.zero_width


__all__ = ["RecentTrace", "RecordedWindow", "MAX_EDGES", "CHUNK_EDGES", "bound_seconds"]
