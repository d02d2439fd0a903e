"""Each console command's CPU up to its first print, replica beside model (docs/timing-model.md,
"thirty-sixth pass").

For every command of a run: the CPU from the firmware's ``process_cmd()`` entry to the
command's first character handed to the serial driver (``HardwareSerial::write``), the
interrupts taken out, read from a replica run recorded with ``loop_passes.py``'s marks;
beside it the model's CPU from the same command's parse to its first character (what
StepperDemo charges there: ``cmd_ticks``, the argument's characters, the message table's
look-up, a number's digits).  By letter: the median difference, and the ``cmd_ticks``
it reads (the model's less that median).

    python3 bench/replica/command_costs.py --work /tmp/lp --fw /tmp/fas-replica \\
        --conformance ../shared/conformance [--set FIELD=VALUE ...] d01 ... test_seq_sd_07_328p

``--work`` is a ``replica.py`` work folder (its runner; the recordings go there, a case
already recorded is read again); ``--fw`` holds the firmwares ``replica.py --build d``
built (``fw-<hash>/fw.elf``; each case's is the one whose initialised data holds the
case's input line).  ``--set`` changes build d's figures as ``bench/d_corpus.py`` does.
"""

from __future__ import annotations

import argparse
import bisect
import collections
import contextlib
import io
import re
import statistics
import subprocess
import sys
import tempfile
from collections.abc import Iterator, Sequence
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parents[1]
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(ROOT / "bench"))
sys.path.insert(0, str(ROOT))

import loop_passes  # noqa: E402
import replica  # noqa: E402

LAG = 96  # the replica's times are the firmware's + 96 ticks (twenty-seventh pass)
NOT_READ = "+-?W"  # their first character waits (the step, room in the buffer, W's wait)
TABLE_PRINT = "_print_from_table"  # StepperDemo's print of a message table's text


def first_writes(tr: loop_passes.Trace, cmd_k: int, write_k: int) -> list[tuple[int, int]]:
    """Per ``process_cmd()`` entry (mark ``cmd_k``): (the entry, the CPU without
    interrupts from it to the next write, mark ``write_k``; -1 if none)."""
    writes = tr.marks[write_k]
    out = []
    for c in tr.marks[cmd_k]:
        j = bisect.bisect_left(writes, c)
        if j == len(writes):
            out.append((c, -1))
        else:
            out.append((c, writes[j] - c - tr.irq_between(c, writes[j])))
    return out


@contextlib.contextmanager
def model_hooks() -> Iterator[dict[str, list]]:
    """While active, record the model's commands (time, text), CPU charges (time,
    ticks) and console writes (time; ``write_data``: the text, the CPU after each
    character beyond char_ticks, whether the message table printed it)."""
    from fas.sim import backend as bk
    from stepperdemo.demo import app

    log: dict[str, list] = {"cmd": [], "spend": [], "write": [], "write_len": [],
                            "write_last": [], "write_data": []}
    command_name = "_spend_command"  # StepperDemo's charge for a command, at its parse
    saved = (bk.SimBackend.app_spend, bk.SimBackend.app_spend_in,
             bk.SimBackend.console_write, getattr(app.StepperDemo, command_name),
             getattr(app.StepperDemo, TABLE_PRINT))
    spend, spend_in, write, command, from_table = saved
    in_table = [False]

    def h_spend(self, ticks):  # type: ignore[no-untyped-def]
        log["spend"].append((self.machine.now, ticks))
        return spend(self, ticks)

    def h_spend_in(self, ticks, poll):  # type: ignore[no-untyped-def]
        log["spend"].append((self.machine.now, ticks))
        return spend_in(self, ticks, poll)

    def h_write(self, data, cpu_after=None):  # type: ignore[no-untyped-def]
        log["write"].append(self.machine.now)
        log["write_len"].append(len(data))
        log["write_data"].append((bytes(data), list(cpu_after) if cpu_after else None,
                                  in_table[0]))
        # a print from a buffer: its last character's cost beyond char_ticks (P39's body);
        # a table's text keeps char_ticks (its look-ups after the character are not body)
        log["write_last"].append(0 if in_table[0] or not cpu_after else cpu_after[-1])
        return write(self, data, cpu_after)

    def h_table(self, data, scan):  # type: ignore[no-untyped-def]
        in_table[0] = True
        try:
            return from_table(self, data, scan)
        finally:
            in_table[0] = False

    def h_command(self, cmd):  # type: ignore[no-untyped-def]
        log["cmd"].append((self.backend.machine.now, cmd.decode("latin-1")))
        return command(self, cmd)

    bk.SimBackend.app_spend = h_spend  # type: ignore[method-assign]
    bk.SimBackend.app_spend_in = h_spend_in  # type: ignore[method-assign]
    bk.SimBackend.console_write = h_write  # type: ignore[method-assign]
    setattr(app.StepperDemo, command_name, h_command)
    setattr(app.StepperDemo, TABLE_PRINT, h_table)
    try:
        yield log
    finally:
        (bk.SimBackend.app_spend, bk.SimBackend.app_spend_in,
         bk.SimBackend.console_write) = saved[:3]  # type: ignore[method-assign]
        setattr(app.StepperDemo, command_name, saved[3])
        setattr(app.StepperDemo, TABLE_PRINT, saved[4])


def tails(tr: loop_passes.Trace, cmd_k: int, write_k: int, loop_k: int
          ) -> list[tuple[int, int]]:
    """Per ``process_cmd()`` entry but the last: (the pass's CPU before the entry, the CPU
    from the last write call before the next entry to that entry - the rest of the
    command's pass and the passes that read the next command's word -, interrupts out;
    -1 if nothing was written in between)."""
    cmds, writes, loops = tr.marks[cmd_k], tr.marks[write_k], tr.marks[loop_k]
    out = []
    for c, nxt in zip(cmds, cmds[1:], strict=False):
        s = loops[bisect.bisect_right(loops, c) - 1]
        head = c - s - tr.irq_between(s, c)
        j = bisect.bisect_left(writes, nxt) - 1
        if j < 0 or writes[j] < c:
            out.append((head, -1))
            continue
        out.append((head, nxt - writes[j] - tr.irq_between(writes[j], nxt)))
    return out


def model_tails(log: dict[str, list]) -> list[int]:
    """Per model command but the last: the CPU charged from its last console write call
    before the next command to that command (-1 if nothing was written in between); the
    write's own characters are not in it (their char_ticks: the model charges them with
    the write call), but a buffer print's last character's cost beyond char_ticks is
    (``write_last``: 0 unless a print's body is set, P39)."""
    writes = log["write"]
    spend_t = [t for t, _ in log["spend"]]
    out = []
    for (t, _), (nxt, _) in zip(log["cmd"], log["cmd"][1:], strict=False):
        j = bisect.bisect_left(writes, nxt) - 1
        if j < 0 or writes[j] < t:
            out.append(-1)
            continue
        a, b = bisect.bisect_left(spend_t, writes[j]), bisect.bisect_left(spend_t, nxt)
        last = log["write_last"][j] if len(log.get("write_last", ())) == len(writes) else 0
        out.append(sum(x for _, x in log["spend"][a:b]) + last)
    return out


WAIT_COMPLETE_LEN = 14  # "Wait complete\n", one write in the model


def pause_ends(tr: loop_passes.Trace, write_k: int, loop_k: int, log: dict[str, list],
               near: int = 5000) -> list[tuple[int, int, int]]:
    """Per `Wait complete` the model printed (a write of its 14 characters after the
    table's look-up, one charge): (the replica's CPU from the start of the pass whose
    write lies nearest - firmware time, within ``near`` - to that write, the model's
    look-up charge, model - firmware time of the first character)."""
    writes, loops = tr.marks[write_k], tr.marks[loop_k]
    spend_t = [t for t, _ in log["spend"]]
    out = []
    for t, n in zip(log["write"], log["write_len"], strict=False):
        i = bisect.bisect_left(spend_t, t) - 1
        if n != WAIT_COMPLETE_LEN or i < 0:
            continue
        lead = log["spend"][i][1]
        j = bisect.bisect_left(writes, t + LAG)
        cands = writes[max(0, j - 3):j + 3]
        if not cands:
            continue
        r = min(cands, key=lambda x: abs(x - LAG - t))
        if abs(r - LAG - t) > near:
            continue
        start = loops[bisect.bisect_right(loops, r) - 1]
        out.append((r - start - tr.irq_between(start, r), lead, t - (r - LAG)))
    return out


def model_first_writes(log: dict[str, list]) -> list[tuple[str, int, int]]:
    """Per model command: (its text, its time, the CPU charged from it to the next
    console write; -1 if none)."""
    writes = log["write"]
    spend_t = [t for t, _ in log["spend"]]
    out = []
    for t, text in log["cmd"]:
        j = bisect.bisect_left(writes, t)
        if j == len(writes):
            out.append((text, t, -1))
            continue
        a, b = bisect.bisect_left(spend_t, t), bisect.bisect_left(spend_t, writes[j])
        out.append((text, t, sum(x for _, x in log["spend"][a:b])))
    return out


def run_model(case: str) -> dict[str, list]:
    """The model's log (:func:`model_hooks`) of ``sequences/conformance/<case>.toml``, as
    ``stepperdemo run`` runs it."""
    from stepperdemo.front.cli import main as stepperdemo_main

    with model_hooks() as log, contextlib.redirect_stdout(io.StringIO()):
        stepperdemo_main(["run", str(ROOT / "sequences" / "conformance" / f"{case}.toml")])
    return log


def find_elf(fw: Path, line: str) -> Path | None:
    """The build-d firmware under ``fw`` (``fw-*/`` with a data pad) whose initialised
    data holds ``line`` (None: none)."""
    for d in sorted(fw.glob("fw-*")):
        elf = d / "fw.elf"
        if not (d / "data_pad.c").exists() or not elf.exists():
            continue
        with tempfile.TemporaryDirectory() as tmp:  # (objcopy seeks: not to a pipe)
            out = Path(tmp) / "data.bin"
            subprocess.run(["avr-objcopy", "-O", "binary", "-j", ".data", str(elf), str(out)],
                           capture_output=True, check=True)
            data = out.read_bytes()
        if re.search(re.escape(line.encode()) + rb" *\0", data):  # (the line's spaces)
            return elf
    return None


def pair(rows_r: Sequence[tuple[int, int]], rows_m: Sequence[tuple[str, int, int]]
         ) -> list[tuple[str, int, int]]:
    """(text, replica CPU, model CPU) for the commands both made, in order, up to the
    first `W` (the firmware re-enters process_cmd() while `W` waits)."""
    out = []
    for (_, r), (text, _, m) in zip(rows_r, rows_m, strict=False):
        if text.startswith("W"):
            break
        out.append((text, r, m))
    return out


def by_letter(pairs: Sequence[tuple[str, int, int]], cmd_ticks: dict[str, int],
              default: int) -> list[tuple[str, int, float, float, int, int, int]]:
    """Per letter read (not in NOT_READ, both sides printed): (letter, count, replica
    median, median of model - replica, min, max, the cmd_ticks it reads)."""
    groups: dict[str, list[tuple[int, int]]] = collections.defaultdict(list)
    for text, r, m in pairs:
        if text[0] in NOT_READ or r < 0 or m < 0:
            continue
        groups[text[0]].append((r, m))
    out = []
    for letter in sorted(groups):
        xs = groups[letter]
        diffs = [m - r for r, m in xs]
        med = statistics.median(diffs)
        out.append((letter, len(xs), statistics.median(r for r, _ in xs), med, min(diffs),
                    max(diffs), cmd_ticks.get(letter, default) - round(med)))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("cases", nargs="+")
    ap.add_argument("--work", type=Path, required=True)
    ap.add_argument("--fw", type=Path, required=True)
    ap.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE")
    ap.add_argument("--conformance", type=Path, default=ROOT.parent / "shared" / "conformance",
                    help="the firmware runs (each case's input.txt)")
    ap.add_argument("--ms", type=float, default=12000.0)
    ap.add_argument("--pause-ends", action="store_true",
                    help="also each `Wait complete`: the CPU before it in its pass")
    ap.add_argument("--tails", action="store_true",
                    help="also each command's tail: its last print to the next command")
    args = ap.parse_args(argv)
    import d_corpus

    d_corpus.set_build_d(args.set)
    from fas.arch import get_profile
    from stepperdemo.demo.build import demo_build

    names = list(replica.MARK_NAMES) + [loop_passes.CALLS["stopMove"], *loop_passes.EXTRA]
    cmd_k, write_k = names.index("process_cmd("), names.index("HardwareSerial::write(")
    loop_k = names.index("loop")
    from fas.sim.timing import sim_timing

    char_ticks = sim_timing(get_profile("atmega328p")).char_ticks
    pairs: list[tuple[str, int, int]] = []
    tail_rows: dict[tuple[str, int], list[tuple[int, int]]] = collections.defaultdict(list)
    ends: list[tuple[int, int, int]] = []
    for case in args.cases:
        line = (args.conformance / case / "input.txt").read_text().strip()
        ev = args.work / f"{case}-loop.ev"
        if not ev.exists():
            elf = find_elf(args.fw, line)
            if elf is None:
                print(f"{case}: no build-d firmware with its input under {args.fw}, skipped")
                continue
            ev, _ = loop_passes.record(elf, args.work, case, args.ms,
                                       replica.UNO.task_vector, replica.UNO.queues,
                                       "stopMove")
        with open(ev) as fh:
            tr = loop_passes.Trace(fh, replica.UNO.task_vector)
        log = run_model(case)
        got = pair(first_writes(tr, cmd_k, write_k), model_first_writes(log))
        pairs += got
        ends += pause_ends(tr, write_k, loop_k, log)
        for (text, _, _), (head, r), m in zip(got, tails(tr, cmd_k, write_k, loop_k),
                                              model_tails(log), strict=False):
            if r >= 0 and m >= 0 and text[0] not in NOT_READ:
                tail_rows[(text[0], head)].append((r, m + char_ticks))
        print(f"{case}: " + ", ".join(f"{t} {r}/{m - r:+d}" for t, r, m in got))
    build = demo_build(get_profile("atmega328p"))
    print("letter  n  replica  model-replica [min max]  cmd_ticks read (model's)")
    for letter, n, rmed, med, lo, hi, read in by_letter(pairs, build.cmd_ticks,
                                                        build.cmd_default_ticks):
        print(f"  {letter}  {n:3d}  {rmed:7.0f}  {med:+7.0f} [{lo:+d} {hi:+d}]  {read} "
              f"({build.cmd_ticks.get(letter, build.cmd_default_ticks)})")
    if args.pause_ends and ends:
        extra = [r - lead for r, lead, _ in ends]
        print(f"pause ends: {len(ends)}; the replica's CPU from the pass's start to the first "
              f"character less the model's look-up: median {statistics.median(extra):.0f} "
              f"[{min(extra)} {max(extra)}]; the model's first character - the firmware's: "
              f"median {statistics.median(d for _, _, d in ends):.0f}")
    if args.tails:
        print("tails: last write call -> next command's process_cmd(), CPU (model: its "
              "charges + one char_ticks)")
        print("letter head  n  replica  model-replica [min max]")
        for (letter, head), xs in sorted(tail_rows.items()):
            diffs = [m - r for r, m in xs]
            print(f"  {letter}  {head:4d} {len(xs):3d}  {statistics.median(r for r, _ in xs):7.0f}"
                  f"  {statistics.median(diffs):+7.0f} [{min(diffs):+d} {max(diffs):+d}]")
    return 0


if __name__ == "__main__":
    sys.exit(main())
