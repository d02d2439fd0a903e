"""Where a channel's pulses run beside another channel's block of pulses: one
``bench_gcode.la_run`` of the look-ahead program, its channels' methods wrapped to count
(nothing in the run changes: the wrappers only look).

The chip runs one channel's pulses as a block at a time (``Machine.batch_channel``);
the other channel's pulses then run as single interrupts - inline while the CPU is free
and the request is the next event (``SimChannel._go_on``), else as events of their own.
Two blocks at once (the speed step docs/path-planner.md names) need the pulses beside a
block to be provably where they would be; this counts what that is up against:

- the pulses: in blocks, inline beside a block, single events beside a block, the rest;
- the single events beside a block by kind: held by the block's step interrupt (or by
  another routine), the first pulse of an entry, the last one, no pulse (a pause, a
  restart), the first after ``_go_on`` stopped - and why it stopped;
- the block's interrupts held by the routines of the pulses beside it (the other
  direction);
- the entries beside a block whose every request keeps ``--slack`` ticks (and the step
  interrupts' own time) away from every request of the block: with entries late by less
  than the slack, neither channel's interrupts would fall into the other's routine.

    python3 bench/beside_block.py [--segments 2000] [--mode blends|grbl] [--slack 512]
"""

from __future__ import annotations

import argparse
import functools
import os
import sys
from bisect import bisect_right
from collections import Counter

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))
sys.path.insert(1, HERE)

import bench_gcode as bg  # noqa: E402

from fas.sim import channel as ch  # noqa: E402
from fas.sim.machine import LATE_ENTRY  # noqa: E402

SC = ch.SimChannel


def beside(self: SC) -> SC | None:
    """The other channel whose block of pulses runs now (None: none)."""
    bc = self.m.batch_channel
    if bc is not None and bc is not self and bc.batch:
        return bc  # type: ignore[return-value]
    return None


def digest(r: dict) -> tuple:
    """What the run did, tick for tick: the machine's clock and counters, the pins'
    figures, the channels' counts, the positions."""
    m = r["backend"].machine
    p = m.pins
    return (m.now, m.events_run, m.seq, m.busy_until, m.stolen_ticks, r["motion_s"],
            tuple(r["positions"]), sorted(p.rise.items()), sorted(p.high_total.items()),
            sorted(p.high_max.items()),
            [(c.pulses, c.missed_compares, c.block_isrs_done, c.starts, c.dry)
             for c in m.block_sources])


def plain_run(segments: int, blends: bool) -> tuple:
    """The same run unwrapped (``--check``)."""
    bg.PLAIN_CORNERS = 0.125 if blends else None
    return digest(bg.la_run(bg.la_lines(segments), 0, False, blends=blends))


def run(segments: int, blends: bool, slack: int) -> tuple[dict[str, Counter], tuple]:
    kinds: Counter = Counter()
    stops: Counter = Counter()
    pulses: Counter = Counter()
    held: Counter = Counter()
    # requests beside a block, grouped by (channel, entry, block): [(request, block)]
    groups: list[tuple[tuple[int, int, int, int], list[int], tuple[int, int, int, int, int]]] = []
    single_starts: set[int] = set()  # routines of the pulses beside a block (entries)
    state = {"in_go_on": 0, "isr_in_go_on": False}
    orig_single = SC._single_isr  # noqa: SLF001 - wrapped to count
    orig_go_on = SC._go_on  # noqa: SLF001 - wrapped to count
    orig_isr = SC._isr  # noqa: SLF001 - wrapped to count
    orig_end = SC._batch_end  # noqa: SLF001 - wrapped to count

    def note(self: SC, c: int, e: object, bc: SC) -> None:
        key = (id(self), id(e), id(bc), bc.b_c0)
        block = (bc.b_c0, bc.b_t, bc.b_n, bc.isr_ticks, self.isr_ticks)
        if groups and groups[-1][0] == key:
            groups[-1][1].append(c)
        else:
            groups.append((key, [c], block))

    def single(self: SC) -> None:
        bc = beside(self)
        if bc is not None:
            m = self.m
            c = self.pending_compare
            q = self.q
            e = q.entries[q.read_idx % q.queue_len] if q.read_idx != q.next_write_idx else None
            if m.now > c:
                keep = bc.entry_req, bc.entry_tick  # (the block's cache: left as it was)
                end = bc.block_isr_running_at(c)
                bc.entry_req, bc.entry_tick = keep
                kinds["held by the block's interrupt" if end is not None and end > c
                      else "held by another routine"] += 1
            elif e is None or not self.pending_pulse:
                kinds["no pulse (a pause, a restart)"] += 1
            elif e.steps == e.total_steps:
                kinds["first pulse of an entry"] += 1
            elif e.steps <= 1:
                kinds["last pulse of an entry"] += 1
            else:
                kinds["first after _go_on stopped"] += 1
            if self.pending_pulse:
                pulses["single events beside a block"] += 1
                single_starts.add(m.now)
                if e is not None:
                    note(self, c, e, bc)
        elif self.pending_pulse:
            pulses["single events, no block beside"] += 1
        orig_single(self)

    def go_on(self: SC, ev: object, e: object, compare: int, cost: int) -> None:
        m = self.m
        n0 = self.pulses
        act = m.run_activity
        bc = beside(self)
        state["isr_in_go_on"] = False
        state["in_go_on"] += 1
        orig_go_on(self, ev, e, compare, cost)  # type: ignore[arg-type]
        state["in_go_on"] -= 1
        made = self.pulses - n0
        pulses["inline beside a block (_go_on)"] += made
        ticks = e.ticks  # type: ignore[attr-defined]
        for i in range(made):
            single_starts.add(compare + i * ticks)
            if bc is not None:
                note(self, compare + i * ticks, e, bc)
        if state["isr_in_go_on"]:
            stops["the entry's last pulse (or a missed compare)"] += 1
            return
        at = self.pending_compare
        if act is not None and m.activity != act:
            stops["run_until stops on activity"] += 1
        elif at > m.run_limit:
            stops["past run_until's limit"] += 1
        else:
            first = [x for x in m.events if x[3] is not ev and not x[3].cancelled and x[0] <= at]
            if first:
                fn = min(first)[3].fn
                stops["an event first: " + getattr(fn, "__name__", "?")] += 1
            else:
                stops["the CPU is not free (the block's interrupt, a routine, UART, "
                      "timer 0)"] += 1

    def isr(self: SC, c: int, now: int) -> None:
        if state["in_go_on"]:
            state["isr_in_go_on"] = True
        orig_isr(self, c, now)

    def batch_end(self: SC) -> None:
        m = self.m
        c0, t, n = self.b_c0, self.b_t, self.b_n
        pulses["in blocks"] += n
        if self.contention:
            for j in m.held_requests(c0, t, 0, n - 1):
                c = c0 + j * t
                if m.cpu_free_at(c, self) > c:
                    i = bisect_right(m.isr_starts, c) - 1
                    by = (i >= 0 and c < m.isr_ends[i] and m.isr_starts[i] in single_starts)
                    held["a block's interrupt held by a pulse beside it" if by
                         else "a block's interrupt held by another routine"] += 1
        orig_end(self)

    for wrapper, orig in ((single, orig_single), (go_on, orig_go_on), (isr, orig_isr),
                          (batch_end, orig_end)):
        functools.update_wrapper(wrapper, orig)  # (an event's function keeps its name)
    SC._single_isr = single  # type: ignore[method-assign]  # noqa: SLF001 - wrapped to count
    SC._go_on = go_on  # type: ignore[method-assign,assignment]  # noqa: SLF001 - wrapped to count
    SC._isr = isr  # type: ignore[method-assign]  # noqa: SLF001 - wrapped to count
    SC._batch_end = batch_end  # type: ignore[method-assign]  # noqa: SLF001 - wrapped to count
    try:
        bg.PLAIN_CORNERS = 0.125 if blends else None
        r = bg.la_run(bg.la_lines(segments), 0, False, blends=blends)
        if r["errors"]:
            raise SystemExit(f"beside_block: the program answered {r['errors']} errors")
        seen = digest(r)
    finally:
        SC._single_isr = orig_single  # type: ignore[method-assign]  # noqa: SLF001 - restored
        SC._go_on = orig_go_on  # type: ignore[method-assign]  # noqa: SLF001 - restored
        SC._isr = orig_isr  # type: ignore[method-assign]  # noqa: SLF001 - restored
        SC._batch_end = orig_end  # type: ignore[method-assign]  # noqa: SLF001 - restored
    clear: Counter = Counter()
    for _, reqs, (c0, t, n, cost_a, cost_b) in groups:
        ok = True
        for c in reqs:
            j = (c - c0) // t
            for k in (j - 1, j, j + 1):
                if 0 <= k < n:
                    ca = c0 + k * t
                    if not (c >= ca + slack + cost_a or ca >= c + slack + cost_b):
                        ok = False
        clear["entries beside a block"] += 1
        clear["their pulses"] += len(reqs)
        if ok:
            clear[f"entries clear of the block by {slack} ticks"] += 1
            clear["the clear entries' pulses"] += len(reqs)
    return {"pulses": pulses, "single events beside a block": kinds,
            "_go_on stopped": stops, "the block's interrupts": held,
            "entries": clear}, seen


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--segments", type=int, default=2000)
    ap.add_argument("--mode", choices=["blends", "grbl"], default="blends")
    ap.add_argument("--slack", type=int, default=LATE_ENTRY,
                    help="ticks an interrupt may enter late (default LATE_ENTRY)")
    ap.add_argument("--check", action="store_true",
                    help="run it unwrapped too: the counting moved nothing")
    a = ap.parse_args(argv)
    out, seen = run(a.segments, a.mode == "blends", a.slack)
    for title, counts in out.items():
        print(f"{title}:")
        for k, v in sorted(counts.items(), key=lambda kv: -kv[1]):
            print(f"  {v:7d}  {k}")
    if a.check:
        same = plain_run(a.segments, a.mode == "blends") == seen
        print("unwrapped run:", "the same" if same else "DIFFERS")
        return 0 if same else 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
