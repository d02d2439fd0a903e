"""The link's delays, as the host plans with them (docs/serial-protocol.md, sections 8-10).

How far beyond the library's own forward planning the host fills a device queue, how
far ahead a Start names its tick, how far ahead of the last report a cut must lie, how
often an unanswered stop is repeated - all from what the link measures: round trips
(clock samples, acknowledgements), the share of frames lost, the wire time of what is
queued.  Every figure is computed for the link of the current session (``link``;
None between sessions).
"""

from __future__ import annotations

import math

from ..arch import Profile
from .clocksync import NS_PER_S, ClockSync
from .link import HostLink
from .protocol import MAX_FRAME

MS = 1_000_000  # ns
HOST_MARGIN_MS = 50  # planned beyond the link's delays: host stalls (scheduling, GC)
LOSS_TARGET = 0.001  # retransmission rounds allowed for: more are needed this rarely
MAX_ROUNDS = 8
CUT_BYTES = 48  # a Truncate (3) and a frame of entries after it (up to 40 + 5)
START_BYTES = 16  # the Start's own frame (a 6-byte message, 5 of framing, rounded up)
MIN_REPEAT_NS = 5 * MS


class LinkMargins:
    """The host's margins for the link's delays (see module text)."""

    def __init__(self, sync: ClockSync, *, baud: int, report_ms: int, start_lead_us: int,
                 host_margin_ms: int = HOST_MARGIN_MS,
                 link_planning_ms: int | None = None) -> None:
        self.sync = sync
        self.baud = baud
        self.report_ms = report_ms
        self.start_lead_us = start_lead_us
        self.host_margin_ms = host_margin_ms
        self.link_planning_ms = link_planning_ms  # None: derived from the link

    def round_trip_ticks(self, link: HostLink | None, rank: int = 1) -> int:
        """A high estimate of the line's round trip: the longest of the recent clock
        samples (the device answers them at once) - ``rank=2``: the second longest, so
        that one sample that waited behind a burst does not count - or, before there
        are any, the smoothed round trip of acknowledged frames plus four deviations."""
        high = self.sync.high_round_trip(rank)
        if high is not None:
            return high
        if link is not None and link.srtt_ns is not None:
            return self.sync.ns_ticks(link.srtt_ns + 4 * link.rttvar_ns)
        return 0

    def retry_rounds(self, link: HostLink | None) -> int:
        """Retransmission rounds to allow for: so many that a frame needs more only once
        in a thousand times, from the share of frames the link had to send again."""
        loss = link.loss if link is not None else 0.0
        if loss <= LOSS_TARGET:
            return 1
        return min(MAX_ROUNDS, math.ceil(math.log(LOSS_TARGET) / math.log(loss)))

    def retry_round_ticks(self, link: HostLink | None) -> int:
        """One retransmission round: a lost frame shows a round trip after it went out
        (a NAK, or the clock sample sent after it as a probe); its repeat follows."""
        return self.round_trip_ticks(link) + self.wire_ticks(MAX_FRAME)

    @staticmethod
    def lossy(link: HostLink | None) -> bool:
        return link is not None and link.loss > LOSS_TARGET

    def wire_ticks(self, n_bytes: int) -> int:
        """The time ``n_bytes`` take on the line (10 bits a byte)."""
        return n_bytes * 10 * self.sync.clock_hz // self.baud if self.baud else 0

    def _ms_ticks(self, ms: int) -> int:
        return ms * self.sync.clock_hz // 1000

    def planning_ticks(self, link: HostLink | None, profile: Profile | None) -> int | None:
        """Forward planning beyond the library's own, once a queue runs: what the host
        may be late (host margin) plus a round trip plus the retransmission rounds -
        or what the user set (``link_planning_ms``).  None: not known yet."""
        if self.link_planning_ms is not None:
            return self._ms_ticks(self.link_planning_ms)
        if profile is None:
            return None
        return (self._ms_ticks(self.host_margin_ms) + self.round_trip_ticks(link)
                + self.retry_rounds(link) * self.retry_round_ticks(link)
                + self._ms_ticks(self.report_ms))

    def start_lead_ticks(self, link: HostLink | None) -> int:
        """How far ahead a start is scheduled: the way there and the time the bytes
        queued before it take - on the wire, or a round trip and a report period per
        window when more frames are queued than the window holds, more when frames are
        lost - and its retransmission rounds (one on a clean line)."""
        hz = self.sync.clock_hz
        lead = self.start_lead_us * hz // 1_000_000
        if link is None:
            return lead
        backlog = START_BYTES + link.backlog_bytes()
        rtt = self.round_trip_ticks(link)
        frame = link.payload + 5
        windows = -(-backlog // (frame * link.window))
        turn = rtt + self.report_ms * hz // 1000
        deliver = max(self.wire_ticks(backlog), (windows - 1) * turn)
        # a clean line may lose a frame too, before any loss has been seen: one round
        lead += rtt + int(deliver / (1.0 - min(link.loss, 0.5)))
        return lead + self.retry_rounds(link) * self.retry_round_ticks(link)

    def cut_margin_ticks(self, link: HostLink | None, report_age_ns: int,
                         fill_period_ticks: int) -> int:
        """How far ahead of the last report (``report_age_ns`` old) a cut must lie so
        that the device has not begun it when the Truncate and the entries that follow
        it arrive: the report's way here and the Truncate's way there (a round trip),
        the next ramp task (``fill_period_ticks``), the bytes queued before, and - on a
        line that loses frames - its retransmission rounds: the entries after the cut
        must be there before the motor reaches it."""
        age = self.sync.ns_ticks(max(0, report_age_ns))
        # before the first entries after the cut: what is queued, the Truncate's frame,
        # a frame of entries
        backlog = (link.backlog_bytes() if link is not None else 0) + CUT_BYTES
        rtt = self.round_trip_ticks(link, rank=2)  # a refused cut is safe, only later
        margin = age + rtt + fill_period_ticks + self.wire_ticks(backlog)
        if self.lossy(link):  # the Truncate and the entries after it may need repeats
            margin += self.retry_rounds(link) * (rtt + self.wire_ticks(MAX_FRAME))
        return margin

    def repeat_ns(self, link: HostLink | None) -> int:
        """How often an unanswered unsequenced stop is sent again: a round trip of the
        line and the stop's wire time (at least 5 ms)."""
        return max(MIN_REPEAT_NS, (self.round_trip_ticks(link) + self.wire_ticks(16)) * NS_PER_S
                   // self.sync.clock_hz)
