"""Step pulses by holder, the model beside build d's replica (docs/timing-model.md,
"forty-fourth pass").

On the ATmega328P the compare raises the step pin and the step interrupt lowers it: a
pulse is the plain path (the replica's 60 ticks on A) plus the time its interrupt waited
for the CPU.  This tool splits every pulse's ticks beyond the plain width by what held
the interrupt, on both sides, in the same rows:

* ``UART`` (the transmit interrupt, vector 19), ``timer 0`` (``millis()``'s overflow,
  16), ``step B`` / ``step A`` (the other channel's step interrupt);
* ``task entry`` / ``task exit`` (the ramp task, vector 13, from its entry to its
  ``sei`` and from its last ``cli`` to its ``reti``), ``task sections`` (its own
  sections with interrupts off in between; the replica logs them with
  ``TASK_SECTIONS=1``, ``c`` / ``s``; without them every late pulse inside a task is
  ``task (unlogged)``);
* ``loop: queueEntries()`` / ``loop: millis()`` / ``loop: serial write`` /
  ``loop: other`` (the main program's sections with interrupts off: ``1650``, ``c4a``,
  ``1064`` / ``1074``; the model's polls' sections at a pass's start / elsewhere),
  ``e block`` (StepperDemo's ``e``);
* ``-``: nothing held at the rise (the instruction running, 1-3 ticks).

The replica's side reads ``WORK/CASE-TAG.ev`` / ``.pins`` (``replica.py --build d``,
less its lead ``--lag``).  The model's side runs the input in build d (``--variant`` /
``--set`` as ``bench/d_corpus.py``) and asks the simulator itself: each time a step
interrupt waits (:meth:`fas.sim.machine.Machine.cpu_free_at` later than its request,
:meth:`~fas.sim.machine.Machine.loop_hold` non-zero) the tool names the interval that
holds it, following the chain to the entry, from the machine's own records (the ramp
task's entries, the commands' masks, the routines entered as events, timer 0's phase,
the UART's loads).  Two tables per run:

* ``first``: each held pulse counted once, under what held it at the rise, with all its
  ticks beyond the plain width (the replica's ``uart_phase.py longest`` table);
* ``chain``: the ticks split over every holder of the chain (one after another up to the
  entry; the rest - the ``reti`` and one instruction - to the last).

::

    python3 bench/replica/pulse_holders.py --work /tmp/s34rep test_sd_14_328p d02
    python3 bench/replica/pulse_holders.py --work /tmp/s34rep --variant S42 d02
    python3 bench/replica/pulse_holders.py --model-only --variant S42 \
        --text 'M1 A1000 V100 R3200 W '
"""

from __future__ import annotations

import argparse
import bisect
import collections
import contextlib
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent.parent))
sys.path.insert(0, str(HERE.parent))

from d_corpus import VARIANTS, set_build_d_from_args  # noqa: E402

STEP_VECTORS = {"A": "11", "B": "12"}
STEP_PINS = {"A": "B1", "B": "B2"}
VECTOR_NAMES = {"19": "UART", "16": "timer 0", "11": "step A", "12": "step B"}
LOOP_PCS = {"1650": "loop: queueEntries()", "c4a": "loop: millis()",
            "1064": "loop: serial write", "1074": "loop: serial write"}
NONE = "-"
ROWS = ("UART", "timer 0", "task entry", "task exit", "task sections", "task (unlogged)",
        "loop: queueEntries()", "loop: millis()", "loop: serial write", "loop: other",
        "step A", "step B", "e block", NONE)

Chain = list[tuple[str, int]]  # (holder, ticks)


# ------------------------------------------------------------------ replica's side
class ReplicaTask:
    """One run of the ramp task: entry, ``reti``, its ``sei`` after the entry, its own
    sections ``[cli, sei)`` and its last ``cli`` (None where the run logs none)."""

    __slots__ = ("entry", "reti", "sei", "sections", "last_cli")

    def __init__(self, entry: int) -> None:
        self.entry = entry
        self.reti = entry
        self.sei: int | None = None
        self.sections: list[tuple[int, int]] = []
        self.last_cli: int | None = None


class ReplicaLog:
    """A replica run's routines, the ramp task's sections and the main program's
    sections with interrupts off, less ``lag`` (an ``.ev`` file as lines)."""

    def __init__(self, lines: Iterator[str] | list[str], lag: int) -> None:
        self.spans: list[tuple[int, int, str]] = []  # (entry, reti, vector)
        self.tasks: list[ReplicaTask] = []
        self.sections: list[tuple[int, int, str]] = []  # main program's (cli, sei, pc)
        self.entries: dict[str, list[int]] = collections.defaultdict(list)
        stack: list[tuple[int, str, ReplicaTask | None]] = []
        cli: tuple[int, str] | None = None
        tcli: int | None = None
        for line in lines:
            p = line.split()
            if len(p) < 2:
                continue
            t = int(p[0]) - lag
            k = p[1]
            if k == "V" and len(p) >= 3:
                task = ReplicaTask(t) if p[2] == "13" else None
                if task is not None:
                    self.tasks.append(task)
                stack.append((t, p[2], task))
                self.entries[p[2]].append(t)
            elif k == "R" and stack:
                e, v, task = stack.pop()
                self.spans.append((e, t, v))
                if task is not None:
                    task.reti = t
                    if tcli is not None and task.sei is not None and tcli >= task.sei:
                        task.last_cli = tcli
                        if task.sections and task.sections[-1][0] == tcli:
                            task.sections.pop()
                    tcli = None
            elif k == "C" and len(p) >= 3:
                cli = (t, p[2])
            elif k == "S" and cli is not None:
                self.sections.append((cli[0], t, cli[1]))
                cli = None
            elif k in ("c", "s"):
                task = next((x[2] for x in reversed(stack) if x[2] is not None), None)
                if task is None:
                    continue
                if k == "s":
                    if task.sei is None:
                        task.sei = t
                    elif tcli is not None:
                        task.sections.append((tcli, t))
                    tcli = None
                else:
                    tcli = t
        self.spans.sort()
        self.span_starts = [s[0] for s in self.spans]
        self.task_starts = [x.entry for x in self.tasks]
        self.sections.sort()
        self.section_starts = [s[0] for s in self.sections]

    def holder_at(self, t: int, own: str) -> tuple[str, int] | None:
        """What holds the CPU at ``t`` against channel ``own``'s step interrupt (the
        innermost routine running then; the ramp task only where its interrupts are off;
        else a section of the main program), and until when; None: nothing."""
        j = bisect.bisect_right(self.span_starts, t)
        inner: tuple[int, int, str] | None = None
        for span in self.spans[max(0, j - 40):j]:
            e, x, v = span
            if e <= t < x and v != own and (inner is None or e >= inner[0]):
                inner = span
        if inner is not None and inner[2] != "13":
            return VECTOR_NAMES.get(inner[2], f"V{inner[2]}"), inner[1]
        if inner is not None:
            task = self.tasks[bisect.bisect_right(self.task_starts, inner[0]) - 1]
            if task.sei is None:
                return "task (unlogged)", task.reti
            if t < task.sei:
                return "task entry", task.sei
            if task.last_cli is not None and t >= task.last_cli:
                return "task exit", task.reti
            for a, b in task.sections:
                if a <= t < b:
                    return "task sections", b
            return None
        k = bisect.bisect_right(self.section_starts, t)
        for a, b, pc in self.sections[max(0, k - 3):k]:
            if a <= t < b:
                return LOOP_PCS.get(pc, "loop: other"), b
        return None

    def chain(self, rise: int, own: str) -> Chain:
        """The holders between a rise and its step interrupt's entry, with the ticks
        each held it (empty: entered at once)."""
        starts = self.entries[own]
        i = bisect.bisect_left(starts, rise)
        if i >= len(starts):
            return []
        entry = starts[i]
        out: Chain = []
        t = rise
        while t < entry:
            h = self.holder_at(t, own)
            if h is None:
                if out:  # the reti and the instruction after it
                    name, ticks = out[-1]
                    out[-1] = (name, ticks + entry - t)
                else:
                    out.append((NONE, entry - t))
                break
            end = min(h[1], entry)
            if out and out[-1][0] == h[0]:
                out[-1] = (h[0], out[-1][1] + end - t)
            else:
                out.append((h[0], end - t))
            if end <= t:
                break
            t = end
        return out


def replica_pulses(lines: Iterator[str] | list[str], pin: str,
                   lag: int) -> list[tuple[int, int]]:
    """(rise, fall) of every pulse of ``pin`` in a ``.pins`` file's lines, less ``lag``."""
    out: list[tuple[int, int]] = []
    rise: int | None = None
    level: int | None = None
    for line in lines:
        t, p, v = line.split()
        if p != pin or int(v) == level:
            continue
        level = int(v)
        if level:
            rise = int(t) - lag
        elif rise is not None:
            out.append((rise, int(t) - lag))
            rise = None
    return out


# -------------------------------------------------------------------- model's side
class ModelHolders:
    """Names, for each step interrupt that waits in a model run, what held it (installed
    on a backend before its run; :meth:`chain` afterwards)."""

    def __init__(self, backend: Any) -> None:
        m = self.m = backend.machine
        self.task_entries: set[int] = set()
        self.step_entries: dict[int, object] = {}  # a step interrupt's entry: its channel
        self.masks: list[tuple[int, int]] = []  # the commands' sections (Machine.mask)
        self.free: dict[tuple[int, int], tuple[int, Chain]] = {}
        self.loop: dict[int, tuple[str, int]] = {}
        free_at, mask, loop_hold = m.cpu_free_at, m.mask, m.loop_hold

        def cpu_free_at(t: int, asker: object = None) -> int:
            free = free_at(t, asker)
            if free > t and asker is not None:
                self.free[(id(asker), t)] = (free, self._chain(t, free, asker))
            return free

        def mask_(start: int, end: int) -> None:
            self.masks.append((start, end))
            mask(start, end)

        def loop_hold_(c: int, step_period: int, step_cost: int) -> int:
            w = loop_hold(c, step_period, step_cost)
            if w:
                self.loop[c] = (self._loop_section(c, step_period, step_cost), w)
            return w

        m.cpu_free_at = cpu_free_at
        m.mask = mask_
        m.loop_hold = loop_hold_

    def _loop_section(self, c: int, step_period: int, step_cost: int) -> str:
        """The loop's section that holds a request at ``c`` (as Machine.loop_hold finds
        it): the pass's first (isRunning()'s queue read) or a later one (millis())."""
        m = self.m
        for start, end, period, sections in reversed(m.loop_polls):
            if start <= c < end:
                if period < 0:  # a run of passes nothing met (Machine.consume_rounds)
                    phase = (c - start) % -period
                else:
                    d = c - start
                    d -= step_cost * (d // step_period) + m._ms_cost * (d >> 14)  # noqa: SLF001
                    phase = d % period
                for offset, ticks in sections:
                    if offset <= phase < offset + ticks:
                        return "loop: queueEntries()" if offset == 0 else "loop: millis()"
        return "loop: other"

    def _holder_at(self, t: int, asker: object) -> tuple[str, int] | None:
        """What holds the CPU at ``t`` against ``asker``'s step interrupt, and until
        when (Machine.cpu_free_at's rules, in its order)."""
        m = self.m
        timing = m.timing
        blocked_end = m.irq_blocked_until + timing.sei_ticks
        if m.irq_blocked_from <= t < blocked_end:
            return "e block", blocked_end
        starts, ends = m.isr_starts, m.isr_ends
        if starts and t < ends[-1]:
            i = bisect.bisect_right(starts, t) - 1
            if i >= 0 and t < ends[i]:
                s = starts[i]
                if s in self.task_entries:
                    return "task entry", ends[i]
                ch = self.step_entries.get(s)
                return self._channel_name(ch), ends[i]
        xs, xe = m.exit_starts, m.exit_ends
        if xs and t < xe[-1]:
            i = bisect.bisect_right(xs, t) - 1
            if i >= 0 and t < xe[i]:
                for a, b in reversed(self.masks):
                    if a <= t < b:
                        return "task sections", min(b, xe[i])
                    if b < xs[i]:
                        break
                return "task exit", xe[i]
        ms_cost = timing.millis_isr_ticks if m._millis_started else 0  # noqa: SLF001
        if ms_cost and t >= m._millis_first:  # noqa: SLF001
            ov = timing.millis_overflow_ticks
            into = (t - m._millis_phase) % ov  # noqa: SLF001
            if into < ms_cost and not m.irq_blocked_from <= t - into <= m.irq_blocked_until:
                return "timer 0", t + ms_cost - into
        uart_cost = m._uart_hold if asker is not None else timing.uart_isr_ticks  # noqa: SLF001
        loads = m.uart.loads
        if uart_cost and loads and t < loads[-1] + uart_cost:
            i = bisect.bisect_right(loads, t) - 1
            if (i >= 0 and t < loads[i] + uart_cost
                    and not m.irq_blocked_from <= loads[i] <= m.irq_blocked_until):
                return "UART", loads[i] + uart_cost
        bc = m.batch_channel
        if bc is not None and bc is not asker:
            end = bc.block_isr_running_at(t)
            if end is not None and end > t:
                return self._channel_name(bc), end
        return None

    @staticmethod
    def _channel_name(ch: object) -> str:
        q = getattr(ch, "q", None)
        return f"step {'ABCDEFGH'[q.index]}" if q is not None else "step ?"

    def _chain(self, t: int, free: int, asker: object) -> Chain:
        out: Chain = []
        while t < free:
            h = self._holder_at(t, asker)
            if h is None or h[1] <= t:
                out.append(("?", free - t))
                break
            end = min(h[1], free)
            if out and out[-1][0] == h[0]:
                out[-1] = (h[0], out[-1][1] + end - t)
            else:
                out.append((h[0], end - t))
            t = end
        return out

    def chain(self, channel: object, rise: int, beyond: int) -> Chain:
        """The holders of the pulse of ``channel`` rising at ``rise`` and ``beyond``
        ticks over the plain width (the last holder takes the rest: the reti and the
        instruction after it); a pulse without a record: ``?``."""
        out: Chain = []
        t = rise
        for _ in range(16):
            rec = self.free.get((id(channel), t))
            if rec is None:
                break
            free, chain = rec
            out.extend(chain)
            t = free
        if not out and rise in self.loop:
            out.append(self.loop[rise])
        rest = beyond - sum(x for _, x in out)
        if out and rest > 0:
            out[-1] = (out[-1][0], out[-1][1] + rest)
        elif not out and beyond > 0:
            out.append(("?", beyond))
        return out


@contextlib.contextmanager
def entries_logged(holders: list[ModelHolders]) -> Iterator[None]:
    """While it lasts, the ramp task's and the step interrupts' entries go to the
    ``holders`` of their machine (the classes' routines wrapped, put back after)."""
    from fas.sim.backend import SimBackend
    from fas.sim.channel import SimChannel

    by_machine = {id(h.m): h for h in holders}
    # (class, routine, where its entries go): the ramp task's, the step interrupts'
    places = ((SimBackend, "_task", "task"), (SimChannel, "_single_isr", "step"),
              (SimChannel, "_batch_end", "step"))
    saved = [getattr(cls, name) for cls, name, _ in places]

    def logged(routine: Any, kind: str) -> Any:
        def run(self: Any, *args: Any) -> None:
            m = self.machine if kind == "task" else self.m
            h = by_machine.get(id(m))
            if h is not None:
                if kind == "task":
                    h.task_entries.add(m.now)
                else:
                    h.step_entries[m.now] = self
            routine(self, *args)
        return run

    for (cls, name, kind), routine in zip(places, saved, strict=True):
        setattr(cls, name, logged(routine, kind))
    try:
        yield
    finally:
        for (cls, name, _), routine in zip(places, saved, strict=True):
            setattr(cls, name, routine)


def model_run(text: str, letter: str = "A") -> tuple[list[tuple[int, int]], int, list[Chain]]:
    """The model's run of ``text`` in build d: stepper ``letter``'s pulses, its plain
    width (the channel's ``lat``) and each pulse's chain of holders."""
    from pulse_widths import backend_pulses

    from fas.sim import SimBackend
    from stepperdemo.program import make_program

    backend = SimBackend("atmega328p", record=True, build="d")
    holders = ModelHolders(backend)
    with entries_logged([holders]):
        app = make_program("demo", backend, scripted=True)
        app.run_script(text, firmware_end=True)
    pulses = backend_pulses(backend)[letter]
    index = "ABCDEFGH".index(letter)
    channel = next(ch for ch in backend.channels if ch.q.index == index)
    plain = channel.lat
    chains = [holders.chain(channel, a, (b - a) - plain) if b - a > plain else []
              for a, b in pulses]
    return pulses, plain, chains


# ----------------------------------------------------------------------- tables
def tables(widths: list[int], plain: int, chains: list[Chain]) -> tuple[
        dict[str, list[int]], dict[str, list[int]]]:
    """By holder: (pulses, ticks beyond ``plain``) under the first holder, and (pulses,
    ticks) split over each chain."""
    first: dict[str, list[int]] = collections.defaultdict(lambda: [0, 0])
    split: dict[str, list[int]] = collections.defaultdict(lambda: [0, 0])
    for w, chain in zip(widths, chains, strict=True):
        if w <= plain:
            continue
        name = chain[0][0] if chain else NONE
        first[name][0] += 1
        first[name][1] += w - plain
        rest = w - plain
        for h, ticks in chain:
            split[h][0] += 1
            split[h][1] += ticks
            rest -= ticks
        if rest > 0 or not chain:
            last = chain[-1][0] if chain else NONE
            split[last][1] += max(rest, 0)
            if not chain:
                split[last][0] += 1
    return first, split


def print_tables(rows: list[tuple[str, dict[str, list[int]], dict[str, list[int]]]],
                 kind: str) -> None:
    """One markdown table per kind (``first`` / ``chain``), a column pair per run."""
    names = [r for r in ROWS if any(r in (t[1] if kind == "first" else t[2]) for t in rows)]
    names += sorted({n for t in rows for n in (t[1] if kind == "first" else t[2])} - set(names))
    head = " | ".join(f"{label}: pulses / ticks" for label, _, _ in rows)
    print(f"| {kind} holder | {head} |")
    print("| --- |" + " --- |" * len(rows))
    totals = [[0, 0] for _ in rows]
    for n in names:
        cells = []
        for k, (_, first, split) in enumerate(rows):
            pt = (first if kind == "first" else split).get(n, [0, 0])
            totals[k][0] += pt[0]
            totals[k][1] += pt[1]
            cells.append(f"{pt[0]} / {pt[1]}")
        print(f"| {n} | " + " | ".join(cells) + " |")
    if kind == "first":
        print("| **total** | " + " | ".join(f"{p} / {t}" for p, t in totals) + " |")


def chain_text(chain: Chain) -> str:
    """A chain as ``holder ticks + holder ticks``."""
    return " + ".join(f"{h} {t}" for h, t in chain) or NONE


def print_longest(side: str, pulses: list[tuple[int, int]], chains: list[Chain],
                  count: int) -> None:
    """The ``count`` longest pulses of one side: index, width, rise, chain."""
    if count <= 0:
        return
    print(f"| {side} pulse | ticks | rise | held by |")
    print("| --- | --- | --- | --- |")
    for i in sorted(range(len(pulses)), key=lambda i: pulses[i][0] - pulses[i][1])[:count]:
        a, b = pulses[i]
        print(f"| {i} | {b - a} | {a} | {chain_text(chains[i])} |")


def add_run_args(ap: argparse.ArgumentParser) -> None:
    """The options of a model run beside a build-d replica run, shared by the replica
    tools (uart_phase.py): the replica's folder, tag and lag, the conformance data, and
    the model's variants and settings."""
    ap.add_argument("--work", type=Path, default=Path("/tmp/fas-replica"))
    ap.add_argument("--tag", default="Os-nolto-inall-pad1")
    ap.add_argument("--lag", type=int, default=96, help="replica minus firmware, ticks")
    ap.add_argument("--conformance", type=Path, default=Path("/work/shared/conformance"))
    ap.add_argument("--variant", action="append", default=[], choices=sorted(VARIANTS))
    ap.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE")


def run_files(args: argparse.Namespace, case: str, prog: str) -> tuple[Path, Path, str] | None:
    """A case's replica run under ``add_run_args``' options: its event and pin logs and
    the conformance input; None (one line on stderr) where the run was not made."""
    prefix = args.work / (f"{case}-{args.tag}" if args.tag else case)
    ev, pins = prefix.with_name(prefix.name + ".ev"), prefix.with_name(prefix.name + ".pins")
    if not ev.exists():
        print(f"{prog}: no replica run {ev}", file=sys.stderr)
        return None
    return ev, pins, (args.conformance / case / "input.txt").read_text().strip()


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    add_run_args(ap)
    ap.add_argument("--stepper", default="A", choices=("A", "B"))
    ap.add_argument("--model-only", action="store_true", help="no replica run")
    ap.add_argument("--text", help="the input (instead of CASE/input.txt)")
    ap.add_argument("--longest", type=int, default=0, metavar="N",
                    help="also the N longest pulses of each side with their chains")
    ap.add_argument("cases", nargs="*")
    args = ap.parse_args(argv)
    if not set_build_d_from_args(args, "pulse_holders"):
        return 2
    cases = args.cases or ([args.text] if args.text else [])
    if not cases:
        print("pulse_holders: no case (CASE ... or --text)", file=sys.stderr)
        return 2
    label = " ".join(args.variant + args.set) or "default"
    for case in cases:
        if args.text:
            text = args.text.strip()
        else:
            folder = args.conformance / case / "input.txt"
            if not folder.exists():
                print(f"pulse_holders: no input {folder}", file=sys.stderr)
                return 2
            text = folder.read_text().strip()
        rows = []
        print(f"## {case if not args.text else repr(text)}")
        if not args.model_only:
            prefix = args.work / (f"{case}-{args.tag}" if args.tag else case)
            ev, pins = Path(f"{prefix}.ev"), Path(f"{prefix}.pins")
            if not ev.exists():
                print(f"pulse_holders: no replica run {ev}", file=sys.stderr)
                return 2
            with ev.open() as f:
                log = ReplicaLog(f, args.lag)
            with pins.open() as f:
                rep = replica_pulses(f, STEP_PINS[args.stepper], args.lag)
            widths = [b - a for a, b in rep]
            rplain = collections.Counter(widths).most_common(1)[0][0]
            own = STEP_VECTORS[args.stepper]
            chains = [log.chain(a, own) if b - a > rplain else [] for a, b in rep]
            first, split = tables(widths, rplain, chains)
            print(f"replica: {len(rep)} pulses, plain {rplain}, high {sum(widths)} ticks, "
                  f"beyond plain {sum(w - rplain for w in widths if w > rplain)}, "
                  f"longest {max(widths)}")
            rows.append(("replica", first, split))
            print_longest("replica", rep, chains, args.longest)
        pulses, plain, chains = model_run(text, args.stepper)
        widths = [b - a for a, b in pulses]
        first, split = tables(widths, plain, chains)
        print(f"model ({label}): {len(pulses)} pulses, plain {plain}, high {sum(widths)} "
              f"ticks, beyond plain {sum(w - plain for w in widths if w > plain)}, "
              f"longest {max(widths) if widths else 0}")
        rows.append((f"model {label}", first, split))
        print_longest("model", pulses, chains, args.longest)
        if not args.model_only and rep and pulses:
            print(f"first rise: replica {rep[0][0]}, model {pulses[0][0]} "
                  f"({pulses[0][0] - rep[0][0]:+d}); last: replica {rep[-1][0]}, model "
                  f"{pulses[-1][0]} ({pulses[-1][0] - rep[-1][0]:+d})")
        print_tables(rows, "first")
        print()
        print_tables(rows, "chain")
    return 0


if __name__ == "__main__":
    sys.exit(main())
