"""Sessions with the device, host side (docs/serial-protocol.md, section 6).

:class:`HostSession` holds the link of the current session and what identifies it
(nonce, the device's Ident and boot id), opens it (Hello until Ident, the link sized to
the device's slots), waits for the device's answers while the link runs, ends it
(Bye) or drops it, and adds up the link's counters over all sessions.
:func:`check_ident` decides whether a device fits the host; :class:`DeviceReports`
keeps the state the device reports of itself (Status, DeviceStatus).
"""

from __future__ import annotations

import random
from collections.abc import Callable

from ..arch import SERIAL_QUEUE_MAX, SERIAL_QUEUE_MIN, Profile, get_profile
from .clock import Clock
from .link import HostLink, LinkStats
from .protocol import (
    D_ESTOP,
    D_SESSION,
    D_WATCHDOG,
    MAX_PAYLOAD,
    MAX_RX_SLOTS,
    PROTOCOL_VERSION,
    Bye,
    DeviceStatus,
    Hello,
    Ident,
    Status,
)
from .stream import ByteStream

MS = 1_000_000  # ns
HELLO_REPEAT_NS = 50 * MS
BYE_COPIES = 3  # unsequenced and unanswered: a noisy line may eat one
MIN_RTO_MS = 10.0


class SerialError(ConnectionError):
    """The device could not be reached or does not fit."""


def check_ident(ident: Ident, current: Profile | None) -> Profile:
    """The profile the device names, with its queue ring as deep as it says (raises
    :class:`SerialError` for a device that does not fit, or - ``current``: the profile
    of the sessions so far - is another one)."""
    if ident.version != PROTOCOL_VERSION:
        raise SerialError(f"device speaks protocol {ident.version}, host {PROTOCOL_VERSION}")
    try:
        p = get_profile(ident.name)
    except ValueError as exc:
        raise SerialError(f"device profile {ident.name!r} unknown") from exc
    if (p.ticks_per_s != ident.ticks_per_s or p.max_steppers != ident.max_steppers
            or p.ticks_per_s // p.min_cmd_ticks != ident.min_cmd_ticks_div):
        raise SerialError(f"device figures differ from profile {p.name}")
    n = ident.queue_len
    if not SERIAL_QUEUE_MIN <= n <= SERIAL_QUEUE_MAX or n & (n - 1):
        raise SerialError(f"device queue of {n} entries (a power of two "
                          f"{SERIAL_QUEUE_MIN}..{SERIAL_QUEUE_MAX} is needed)")
    if ident.rx_slots > MAX_RX_SLOTS or not 12 <= ident.slot_payload <= MAX_PAYLOAD:
        raise SerialError(f"device receive figures out of range ({ident.rx_slots} "
                          f"slots of {ident.slot_payload} bytes)")
    if current is not None:
        if p.name != current.name:
            raise SerialError(f"device is {p.name}, this session runs {current.name}")
        if n != current.queue_len:
            raise SerialError(f"device queue of {n} entries, this session has "
                              f"{current.queue_len}")
    return p.with_queue_len(n)


class DeviceReports:
    """What the device reports of itself: every queue's Status, its DeviceStatus, and
    whether that says the session is gone (reset, watchdog, emergency stop)."""

    def __init__(self) -> None:
        self.statuses: dict[int, Status] = {}  # by stepper, this session
        self.device_status: DeviceStatus | None = None
        self.status_count = 0  # DeviceStatus messages so far
        self.status_seen: set[int] = set()  # steppers with a Status since the last ask

    def status(self, m: Status) -> None:
        self.statuses[m.stepper] = m
        self.status_seen.add(m.stepper)

    def device(self, m: DeviceStatus) -> str | None:
        """Take a DeviceStatus; the problem it shows for an open session, if any."""
        self.device_status = m
        self.status_count += 1
        if not m.state & D_SESSION:
            return "device was reset"
        if m.state & D_WATCHDOG:
            return "device watchdog stopped the motion"
        if m.state & D_ESTOP:
            return "device in emergency stop"
        return None

    def estopped(self) -> bool:
        """The last DeviceStatus shows the emergency stop."""
        return self.device_status is not None and bool(self.device_status.state & D_ESTOP)


class HostSession:
    """The current session's link and identity, and the accounting over all sessions."""

    def __init__(self, clock: Clock, *, baud: int, window: int, max_payload: int,
                 watchdog_ms: int, report_ms: int) -> None:
        self.clock = clock
        self.baud = baud
        self.window = window
        self.max_payload = max_payload
        self.watchdog_ms = watchdog_ms
        self.report_ms = report_ms
        self.link: HostLink | None = None
        self.connected = False
        self.ident: Ident | None = None
        self.nonce = 0
        self.ident_wanted: int | None = None
        self.boot_id: int | None = None  # the device of the last session
        self.lost_reason: str | None = None
        self.problem: str | None = None  # the device says the session is gone
        self.sessions = 0
        self.closed_stats = LinkStats()  # the links of the sessions that ended

    def new_link(self, stream: ByteStream) -> HostLink:
        """A link on ``stream`` for a new session (not connected until :meth:`opened`)."""
        link = HostLink(stream, self.clock, window=self.window,
                        max_payload=self.max_payload, min_rto_ms=MIN_RTO_MS, baud=self.baud)
        self.link = link
        self.connected = False
        return link

    def hello(self) -> Hello:
        """A Hello with a new nonce; its Ident is awaited (:meth:`take_ident`)."""
        self.nonce = (self.nonce + 1 + random.getrandbits(15)) & 0xFFFF or 1
        self.ident_wanted = self.nonce
        self.ident = None
        return Hello(PROTOCOL_VERSION, self.nonce, self.watchdog_ms, self.report_ms)

    def take_ident(self, m: Ident) -> None:
        if m.nonce == self.ident_wanted:
            self.ident = m

    def fit_link(self, ident: Ident) -> None:
        """Send no more frames than the device has slots, none larger than a slot."""
        assert self.link is not None
        self.link.set_limits(min(self.window, ident.rx_slots + 1),
                             min(self.max_payload, ident.slot_payload))

    def same_device(self, ident: Ident) -> bool:
        """The device of the last session, not rebooted (its positions are the axes')."""
        return self.boot_id == ident.boot_id

    def opened(self, ident: Ident) -> None:
        """The session is open."""
        self.boot_id = ident.boot_id
        self.connected = True
        self.lost_reason = None
        self.problem = None
        self.sessions += 1

    def wait_for(self, cond: Callable[[], bool], timeout_ns: int,
                 resend: Callable[[], None] | None = None, resend_ns: int = 200 * MS) -> bool:
        """Run the link until ``cond()`` holds (True) or ``timeout_ns`` passed (False);
        ``resend()`` every ``resend_ns`` meanwhile."""
        link = self.link
        clock = self.clock
        end = clock.now_ns() + timeout_ns
        next_resend = clock.now_ns()
        while True:
            if cond():
                return True
            now = clock.now_ns()
            if now >= end or link is None or link.closed:
                return False
            if resend is not None and now >= next_resend:
                resend()
                next_resend = now + resend_ns
            link.service()
            if cond():
                return True
            link.wait(min(end, next_resend) if resend is not None else end)

    def bye(self) -> None:
        """End the session politely (the device stops without a watchdog trip)."""
        if self.link is not None and self.connected:
            self.link.flush()
            for _ in range(BYE_COPIES):
                self.link.send_unsequenced(Bye(self.nonce))

    def drop(self, reason: str) -> None:
        """Close the link (if any): the session is over."""
        if self.link is not None:
            self.account(self.link)
            self.link.close(reason)
            self.link = None
        self.connected = False

    def account(self, link: HostLink) -> None:
        """Add a link's counters to those of the sessions that ended (its round trip
        stays as the last one measured)."""
        total = self.closed_stats
        for name, value in link.stats.as_dict().items():
            if name != "rtt_us":
                setattr(total, name, getattr(total, name) + value)
            elif value:
                total.rtt_us = value

    def link_stats(self) -> dict[str, int]:
        """Link counters over every session so far (rtt: the current one's, without a
        session the last one measured)."""
        total = LinkStats(**self.closed_stats.as_dict())
        if self.link is not None:
            for name, value in self.link.stats.as_dict().items():
                if name != "rtt_us":
                    setattr(total, name, getattr(total, name) + value)
            total.rtt_us = self.link.stats.rtt_us
        out = total.as_dict()
        out["sessions"] = self.sessions
        return out
