"""The firmware of the runs e01-e18 rebuilt and run cycle by cycle: a replica to read
the simulation model's figures from (docs/timing-model.md, "eighth pass").

The conformance runs e01-e18 come from StepperDemo and FastAccelStepper 1.2.6 built
with the Arduino AVR core and avr-gcc, run in simavr.  This script builds the same
firmware from a FastAccelStepper 1.2.6 source tree with the Arduino AVR core that
Debian packages (``arduino-core-avr``, 1.8.7) and the installed avr-gcc, with the
flags of the Arduino IDE's platform.txt and the case's input compiled in
(``SIM_TEST_INPUT``), runs it in an upstream simavr built from source (Debian's
libsimavr 1.6 drives the compare outputs' forced matches differently), and records
every step pin change, every interrupt entry and return, the library's queue writes
and the queues' contents at each ramp task.  Nothing of those sources is part of this
repository: their paths are arguments (``--fas``: e.g. ``git -C FastAccelStepper archive
1.2.6 src examples/StepperDemo | tar x -C DIR``; ``--simavr``: a checkout of simavr's
source, whose library this script makes if it is not built yet).

    python3 bench/replica/replica.py --fas FAS_1_2_6 --simavr SIMAVR steps e01 e09 e14
    python3 bench/replica/replica.py --fas ... --simavr ... tasks e01 e03 e09 e13 e14
    python3 bench/replica/replica.py --fas ... --simavr ... task e14 --at 254.6
    python3 bench/replica/replica.py --fas ... --simavr ... --profile pitches e09

``steps`` compares every step edge with the firmware's (``steps_*.tsv.gz``): the
replica's come at one constant offset (61-62 ticks on the ATmega328P, 150 on the
ATmega2560), i.e. it is the firmware to the cycle.  ``tasks`` reads the ramp task's
costs from all tasks of the runs: the CPU time of a task without commands by what its
queues hold, the time between two queue writes of one stepper by kind of command, and
the interrupts nested in tasks.  ``task`` prints one task's timeline (CPU time, ticks
of the interrupts nested so far, each queue write).  ``pitches`` prints one line per
command a ramp task writes after another of the same stepper: the CPU between the two
writes, the interrupts nested in between, both commands, and with ``--profile`` the ramp
step and log2 value the ramp's arithmetic converted and the task's own cycles by function
(docs/timing-model.md, "twenty-first pass").  Every run also records each ramp task's
fill reading its queue (``ticksInQueue()``, inlined into the task's vector: the end of
its critical section, found in the ELF) with the queue's entries then; ``fill_reads.py``
sets those beside the model's ("twenty-fourth pass").  The ATmega32U4 runs (e15, e16)
are not covered: their USB console needs a host the simulator does not have.

``--build d`` builds the firmware of the d*/test_sd_*/test_seq_sd_* runs instead: no
link-time optimisation, the input's define on every compile (as PlatformIO's build_flags
in the upstream harness), one byte more of ``.data``; every step of those runs then comes
at 96 ticks (docs/timing-model.md, "twenty-seventh pass").  A case's ``defines.txt`` joins
its build.  Other settings (``--opt``, ``--no-lto``, ``--no-sections``, ``-D``,
``--toolchain``, ``--core``, ``--input-everywhere``, ``--data-pad``) are options of their
own; a build other than the default writes ``WORK/CASE-TAG.*``.

    python3 bench/replica/replica.py --fas ... --simavr ... --build d steps d01 test_sd_07_328p
"""

from __future__ import annotations

import argparse
import bisect
import collections
import gzip
import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
CORE = Path("/usr/share/arduino/hardware/arduino/avr")
TICKS_PER_US = 16


class Board:
    def __init__(self, mcu: str, variant: str, define: str, extra: list[str],
                 pins: dict[str, str], task_vector: int, queues: int) -> None:
        self.mcu, self.variant, self.define, self.extra = mcu, variant, define, extra
        self.pins, self.task_vector, self.queues = pins, task_vector, queues


UNO = Board("atmega328p", "standard", "ARDUINO_AVR_UNO", [], {"A": "B1", "B": "B2"}, 13, 2)
MEGA_T1 = Board("atmega2560", "mega", "ARDUINO_AVR_MEGA2560", ["-DFAS_TIMER_MODULE=1"],
                {"A": "B5", "B": "B6", "C": "B7"}, 20, 3)
BOARDS = {"e13": MEGA_T1, "e14": MEGA_T1}
MARK_NAMES = ("FastAccelStepper::addQueueEntry(", "StepperQueue::startQueue(",
              "StepperQueue::addQueueEntry(", "FastAccelStepper::enableOutputs(")
WRITE, START, QUEUE_WRITE, ENABLE = range(4)
# --profile marks these too: the ramp step the ramp's maths converts (calculate_ticks's
# argument after `this`) and the log2 value it converts back (log2_to_u32's argument)
PROFILE_MARKS = ("ramp_config_s::calculate_ticks(", "log2_to_u32(")
CALC, TO_U32 = range(4, 6)


def _conformance() -> Path:
    for p in (ROOT.parent.parent / "shared" / "conformance", Path("/work/shared/conformance")):
        if p.is_dir():
            return p
    return ROOT / "conformance"


def run(cmd: list[str], **kw: object) -> None:
    subprocess.run(cmd, check=True, **kw)  # type: ignore[call-overload]


class Flags:
    """The compile settings of a build: optimisation level, link-time optimisation,
    one section per function/datum (with the linker's garbage collection), extra
    options for every compile (``-D...``).  The defaults are the Arduino IDE's
    platform.txt: the build of the runs e01-e18."""

    def __init__(self, opt: str = "-Os", lto: bool = True, sections: bool = True,
                 extra: tuple[str, ...] = (), toolchain: str = "",
                 input_everywhere: bool = False, data_pad: int = 0, core: str = "") -> None:
        opt = opt if opt.startswith("-") else f"-{opt}"  # --opt O2 as well as --opt=-O2
        if opt not in ("-O0", "-O1", "-O2", "-O3", "-Os", "-Og"):
            raise ValueError(f"unknown optimisation level {opt!r}")
        self.opt, self.lto, self.sections, self.extra = opt, lto, sections, tuple(extra)
        self.toolchain = toolchain  # a directory with avr-gcc/avr-g++, '' for PATH's
        # the input's define on every compile, the library's and the core's too (as
        # PlatformIO's build_flags do), not only on the sketch's
        self.input_everywhere = input_everywhere
        # bytes of initialised data added to the image (a variable the start-up code
        # copies from flash, 9 cycles a byte, the section rounded up to even bytes)
        if data_pad < 0:
            raise ValueError("--data-pad counts bytes added: 0 or more")
        self.data_pad = data_pad
        self.core = core  # another Arduino AVR core (its hardware/arduino/avr folder)

    def tool(self, name: str) -> str:
        return str(Path(self.toolchain) / name) if self.toolchain else name

    def default(self) -> bool:
        return (self.opt == "-Os" and self.lto and self.sections and not self.extra
                and not self.toolchain and not self.input_everywhere and not self.data_pad
                and not self.core)

    def tag(self) -> str:
        """'' for the default build, else a short name for file names."""
        if self.default():
            return ""
        parts = [self.opt[1:]] + ([] if self.lto else ["nolto"])
        parts += [] if self.sections else ["nosec"]
        parts += ["inall"] if self.input_everywhere else []
        parts += [f"pad{self.data_pad}"] if self.data_pad else []
        if self.extra or self.toolchain or self.core:
            text = " ".join(self.extra) + "|" + self.toolchain + "|" + self.core
            parts.append(hashlib.sha1(text.encode()).hexdigest()[:6])
        return "-".join(parts)

    def cflags(self) -> list[str]:
        return ["-c", "-g", self.opt, "-w", "-std=gnu11", *self._sections(), *self._lto(True),
                *self.extra]

    def cxxflags(self) -> list[str]:
        return ["-c", "-g", self.opt, "-w", "-std=gnu++11", "-fpermissive", "-fno-exceptions",
                *self._sections(), "-fno-threadsafe-statics", "-Wno-error=narrowing",
                *self._lto(False), *self.extra]

    def asflags(self) -> list[str]:
        return ["-c", "-g", "-x", "assembler-with-cpp", *(["-flto"] if self.lto else [])]

    def ldflags(self) -> list[str]:
        lto = ["-flto", "-fuse-linker-plugin"] if self.lto else []
        gc = ["-Wl,--gc-sections"] if self.sections else []
        return ["-w", self.opt, "-g", *lto, *gc]

    def _sections(self) -> list[str]:
        return ["-ffunction-sections", "-fdata-sections"] if self.sections else []

    def _lto(self, c: bool) -> list[str]:
        if not self.lto:
            return []
        return ["-flto", "-fno-fat-lto-objects"] if c else ["-flto"]


def build_firmware(fas: Path, case_input: str, board: Board, work: Path,
                   flags: Flags | None = None) -> Path:
    """StepperDemo with ``case_input`` compiled in; returns the ELF (cached by input)."""
    flags = flags or Flags()
    ident = f"{fas}|{case_input}|{board.mcu}|{board.extra}"
    if not flags.default():  # the default build keeps its cache key
        ident += (f"|{flags.opt}|{flags.lto}|{flags.sections}|{flags.extra}|{flags.toolchain}"
                  f"|{flags.input_everywhere}|{flags.data_pad}|{flags.core}")
    key = hashlib.sha1(ident.encode()).hexdigest()
    out = work / f"fw-{key[:12]}"
    elf = out / "fw.elf"
    if elf.exists():
        return elf
    out.mkdir(parents=True, exist_ok=True)
    root = Path(flags.core) if flags.core else CORE
    core = root / "cores" / "arduino"
    defs = [f"-mmcu={board.mcu}", "-DF_CPU=16000000L", "-DARDUINO=10807", f"-D{board.define}",
            "-DARDUINO_ARCH_AVR", *board.extra]
    inc = [f"-I{core}", f"-I{root / 'variants' / board.variant}", f"-I{fas / 'src'}",
           f"-I{fas / 'examples' / 'StepperDemo'}"]
    script = [f'-DSIM_TEST_INPUT="{case_input}"']
    cflags, cxxflags = flags.cflags(), flags.cxxflags()
    if flags.input_everywhere:
        cflags, cxxflags, script = cflags + script, cxxflags + script, []
    sketch = out / "StepperDemo.ino.cpp"
    sketch.write_text("#include <Arduino.h>\n"
                      + (fas / "examples" / "StepperDemo" / "StepperDemo.ino").read_text())
    gcc, gxx = flags.tool("avr-gcc"), flags.tool("avr-g++")
    jobs: list[tuple[list[str], Path]] = []
    for f in sorted(core.glob("*.c")):
        jobs.append(([gcc, *cflags, *defs, *inc, str(f)], out / f"core_{f.name}.o"))
    for f in sorted(core.glob("*.cpp")):
        if f.name != "WString.cpp":  # unused; Debian's copy needs DECIMAL_DIG
            jobs.append(([gxx, *cxxflags, *defs, *inc, str(f)], out / f"core_{f.name}.o"))
    for f in sorted(core.glob("*.S")):
        jobs.append(([gcc, *flags.asflags(), *defs, *inc, str(f)],
                     out / f"core_{f.name}.o"))
    skip = ("pd_esp32", "pd_pico", "pd_sam", "pd_test", "esp32_pcnt")
    for f in sorted((fas / "src").rglob("*.cpp")):
        if not any(s in str(f) for s in skip):
            name = str(f.relative_to(fas)).replace("/", "_")
            jobs.append(([gxx, *cxxflags, *defs, *inc, str(f)], out / f"fas_{name}.o"))
    for f in [*sorted((fas / "examples" / "StepperDemo").glob("*.cpp")), sketch]:
        jobs.append(([gxx, *cxxflags, *defs, *inc, *script, str(f)], out / f"sk_{f.name}.o"))
    keep = []
    if flags.data_pad:
        pad = out / "data_pad.c"
        pad.write_text(f"volatile char replica_data_pad[{flags.data_pad}] = {{1}};\n")
        jobs.append(([gcc, *cflags, *defs, str(pad)], out / "data_pad.o"))
        keep = ["-Wl,--undefined=replica_data_pad"]
    for cmd, obj in jobs:
        run([*cmd, "-o", str(obj)])
    run([gcc, *flags.ldflags(), *keep, f"-mmcu={board.mcu}", "-o", str(elf),
         *[str(o) for _, o in jobs], "-lm"])
    return elf


def build_runner(simavr: Path, work: Path) -> Path:
    """replica_run.c linked with the simavr tree's static library (built if missing)."""
    sim = simavr / "simavr"
    objs = sorted(sim.glob("obj-*/libsimavr.a"))
    if not objs:
        run(["make", "-C", str(sim), "RELEASE=1", "libsimavr"], stdout=subprocess.DEVNULL)
        objs = sorted(sim.glob("obj-*/libsimavr.a"))
    lib = objs[0]
    exe = work / "replica_run"
    src = HERE / "replica_run.c"
    if not exe.exists() or exe.stat().st_mtime < src.stat().st_mtime:
        work.mkdir(parents=True, exist_ok=True)
        run(["gcc", "-O2", f"-I{sim / 'sim'}", f"-I{lib.parent}", "-o", str(exe), str(src),
             str(lib), "-lelf", "-lm"])
    return exe


def symbols(elf: Path, names: tuple[str, ...] = MARK_NAMES) -> tuple[dict[str, int], int]:
    """Byte addresses of the marked functions, data address of the queue array."""
    text = subprocess.run(["avr-nm", "-C", str(elf)], check=True, capture_output=True,
                          text=True).stdout
    found: dict[str, int] = {}
    queues = 0
    for line in text.splitlines():
        parts = line.split(None, 2)
        if len(parts) < 3:
            continue
        for name in names:
            if parts[2].startswith(name):
                found[name] = int(parts[0], 16)
        if parts[2] == "fas_queue":
            queues = int(parts[0], 16) & 0xFFFF
    return found, queues


def functions(elf: Path) -> list[tuple[int, int, str]]:
    """(start, end, name) of every function of the ELF, by address."""
    text = subprocess.run(["avr-nm", "-C", "-S", "-n", str(elf)], check=True,
                          capture_output=True, text=True).stdout
    out = []
    for line in text.splitlines():
        parts = line.split(None, 3)
        if len(parts) == 4 and parts[2] in "tTwW" and int(parts[1], 16) > 0:
            a = int(parts[0], 16)
            if a < 0x800000:
                out.append((a, a + int(parts[1], 16), parts[3]))
    return out


def fill_read_pc(elf: Path, task_vector: int) -> int:
    """Byte address of the instruction that ends the critical section in which the ramp
    task's fill reads its queue's indices (``ticksInQueue()``, inlined into the task's
    vector: its first ``in rN, SREG; cli`` ... ``out SREG, rN``); 0 if not found."""
    start = end = 0
    for a, b, name in functions(elf):
        if name == f"__vector_{task_vector}":
            start, end = a, b
    if not start:
        return 0
    text = subprocess.run(["avr-objdump", "-d", f"--start-address={start:#x}",
                           f"--stop-address={end:#x}", str(elf)], check=True,
                          capture_output=True, text=True).stdout
    ins = []
    for line in text.splitlines():
        parts = line.split("\t")
        if len(parts) >= 3 and parts[0].strip().endswith(":"):
            ins.append((int(parts[0].strip()[:-1], 16), " ".join(parts[2:]).split(";")[0].strip()))
    for i in range(1, len(ins)):
        if ins[i][1] == "cli" and ins[i - 1][1].startswith("in") and ins[i - 1][1].endswith("0x3f"):
            reg = ins[i - 1][1].split()[1].rstrip(",")
            for a, op in ins[i + 1:i + 12]:
                if op.replace(" ", "") == f"out0x3f,{reg}":
                    return a
            return 0
    return 0


def flags_of(args: argparse.Namespace) -> Flags:
    """The build's settings from the command line: ``--build d`` is ``--no-lto
    --input-everywhere --data-pad 1`` (docs/timing-model.md, "twenty-seventh pass"), the
    rest as named."""
    d = getattr(args, "build", "e") == "d"
    return Flags(getattr(args, "opt", "-Os"), not (d or getattr(args, "no_lto", False)),
                 not getattr(args, "no_sections", False),
                 tuple(f"-D{d}" for d in getattr(args, "define", None) or ()),
                 getattr(args, "toolchain", "") or "",
                 d or getattr(args, "input_everywhere", False),
                 int(d) if getattr(args, "data_pad", None) is None else args.data_pad,
                 getattr(args, "core", "") or "")


def case_defines(folder: Path) -> tuple[str, ...]:
    """The extra defines a run was built with (its ``defines.txt``, the upstream test's
    build_flags beside the input: e.g. ``-DSIMAVR_TIME_MEASUREMENT``)."""
    path = folder / "defines.txt"
    if not path.exists():
        return ()
    return tuple(w for w in path.read_text().split() if w.startswith("-D"))


def run_name(case: str, args: argparse.Namespace) -> str:
    """The run's output name in WORK: the case, and for a build other than the default
    the command line's settings (a case's own defines do not rename it)."""
    tag = flags_of(args).tag()
    return f"{case}-{tag}" if tag else case


def replicate(case: str, args: argparse.Namespace) -> tuple[Path, Board]:
    """Build and run ``case``; returns the output prefix and the board."""
    board = BOARDS.get(case, UNO)
    text = (args.conformance / case / "input.txt").read_text().rstrip("\n")
    work = Path(args.work)
    flags = flags_of(args)
    flags.extra += case_defines(args.conformance / case)
    elf = build_firmware(Path(args.fas), text, board, work, flags)
    exe = build_runner(Path(args.simavr), work)
    names = MARK_NAMES + PROFILE_MARKS if getattr(args, "profile", False) else MARK_NAMES
    marks, queue_base = symbols(elf, names)
    prefix = work / run_name(case, args)
    info = args.conformance / case / "run_info.json"  # the firmware halts at its end
    ms = json.loads(info.read_text())["simulated_us"] / 1000 + 1 if info.exists() else 5000.0
    env = {**os.environ, "MARKS": ",".join(f"{marks[n]:x}" for n in names),
           "TASK_VECTOR": str(board.task_vector), "QUEUES": str(board.queues),
           "QUEUE_BASE": f"{queue_base:x}"}
    read_pc = fill_read_pc(elf, board.task_vector)
    if read_pc:
        env["READ_PC"] = f"{read_pc:x}"
    if getattr(args, "profile", False):
        ranges = work / f"{case}.funcs"
        ranges.write_text("".join(f"{a:x} {b:x} {name}\n" for a, b, name in functions(elf)))
        env["PROFILE"] = str(ranges)
    if getattr(args, "timer_check", False):
        env["TIMER_CHECK"] = f"{prefix}.timer"
    run([str(exe), str(elf), board.mcu, f"{ms:.0f}", str(prefix), *board.pins.values()], env=env)
    return prefix, board


def rises(prefix: Path) -> dict[str, list[int]]:
    out: dict[str, list[int]] = collections.defaultdict(list)
    level: dict[str, int] = {}
    with open(f"{prefix}.pins") as f:
        for line in f:
            c, pin, v = line.split()
            if v == "1" and level.get(pin, 0) == 0:
                out[pin].append(int(c))
            level[pin] = int(v)
    return out


def cmd_steps(args: argparse.Namespace) -> int:
    bad = 0
    for case in args.cases:
        prefix, board = replicate(case, args)
        mine = rises(prefix)
        for letter, pin in board.pins.items():
            path = args.conformance / case / f"steps_{letter}.tsv.gz"
            if not path.exists():
                continue
            with gzip.open(path, "rt") as f:
                fw = [round(float(line.split()[0]) * TICKS_PER_US) for line in f if line.strip()]
            ours = mine.get(pin, [])
            n = min(len(fw), len(ours))
            offs = [ours[i] - fw[i] for i in range(n)]
            # the firmware's times are written to 1 ns: a tick is 62.5 ns
            same = len(fw) == len(ours) and max(offs) - min(offs) <= 8
            bad += not same
            print(f"{case} {letter}: firmware {len(fw)} steps, replica {len(ours)}; replica - "
                  f"firmware {min(offs)}..{max(offs)} ticks"
                  + ("" if same else "  (not one constant offset)"))
        if getattr(args, "timer_check", False):
            from timer_check import check  # noqa: PLC0415 (a sibling script)
            rep = check(Path(f"{prefix}.timer").read_text().splitlines())
            print(f"{case} timer 1: {rep.summary()}")
            bad += bool(rep.missing)
    return 1 if bad else 0


class Task:
    def __init__(self, t: int, queues: list[list[int]]) -> None:
        self.t, self.queues = t, queues
        self.cpu = self.wall = 0
        self.nested: collections.Counter[int] = collections.Counter()
        # cpu, mark, this, ticks, steps, cycle
        self.marks: list[tuple[int, int, int, int, int, int]] = []
        # the fill's reads of a queue (Q lines): cpu, queue, cycle, entries from the
        # read index on as (ticks, steps), the running entry first
        self.reads: list[tuple[int, int, int, list[tuple[int, int]]]] = []


def tasks_of(prefix: Path, task_vector: int) -> tuple[list[Task], dict[int, list[int]]]:
    """Every run of the ramp task (CPU time its own, interrupts nested by vector) and the
    durations of every other interrupt (vector -> ticks entry to reti)."""
    tasks: list[Task] = []
    isr: dict[int, list[int]] = collections.defaultdict(list)
    stack: list[tuple[int, int]] = []
    cur: Task | None = None
    last = 0
    with open(f"{prefix}.ev") as f:
        for line in f:
            p = line.split()
            c = int(p[0])
            if cur is not None and stack:
                top = stack[-1][0]
                if top == task_vector:
                    cur.cpu += c - last
                else:
                    cur.nested[top] += c - last
            last = c
            if p[1] == "V":
                v = int(p[2])
                stack.append((v, c))
                if v == task_vector:
                    qs = " ".join(p[3:]).split("|")[1:]
                    cur = Task(c, [[int(s) for s in q.split()] for q in qs])
            elif p[1] == "R" and stack:
                v, c0 = stack.pop()
                if v == task_vector and cur is not None:
                    cur.wall = c - cur.t
                    tasks.append(cur)
                    cur = None
                elif v != task_vector:
                    isr[v].append(c - c0)
            elif p[1] == "M" and cur is not None:
                cur.marks.append((cur.cpu, int(p[2]), int(p[3]), int(p[4]), int(p[5]), c))
            elif p[1] == "Q" and cur is not None:
                ents = [(int(a), int(b)) for a, b in (x.split(":") for x in p[5:])]
                cur.reads.append((cur.cpu, int(p[2]), c, ents))
    return tasks, isr


def ticks_in_queue(entries: list[tuple[int, int]]) -> int:
    """The library's ticksInQueue() of a queue holding ``entries`` (the running one
    first): ticks x steps of every entry after it, a pause's ticks once."""
    return sum(t * max(s, 1) for t, s in entries[1:])


def _writes(t: Task) -> list[tuple[int, int, int, int, int, int]]:
    """The task's command writes (a call with a command; the start call has none)."""
    return [m for m in t.marks if m[1] == WRITE and m[4] < 256 and m[3] > 0]


def _median(v: list[int]) -> int:
    v = sorted(v)
    return v[len(v) // 2] if v else 0


def cmd_tasks(args: argparse.Namespace) -> int:
    Run = tuple[list[Task], dict[int, list[int]]]
    by_chip: dict[str, list[Run]] = collections.defaultdict(list)
    for case in args.cases:
        prefix, board = replicate(case, args)
        by_chip[board.mcu].append(tasks_of(prefix, board.task_vector))
    for chip, runs in by_chip.items():
        idle: list[int] = []
        plain: dict[tuple[int, int], list[int]] = collections.defaultdict(list)
        done: list[int] = []
        cost: dict[str, list[int]] = collections.defaultdict(list)
        isr: dict[int, list[int]] = collections.defaultdict(list)
        for tasks, isrs in runs:
            for v, d in isrs.items():
                isr[v] += d
            for t in tasks:
                running = [q for q in t.queues if q]
                w = _writes(t)
                if not running and not w:
                    idle.append(t.cpu)
                elif len(running) == 1 and not t.marks:
                    q = running[0][1:]
                    ones = sum(1 for s in q if s <= 1)
                    if ones and ones == len(q):
                        done.append(t.cpu)
                    elif not ones:
                        plain[(0, len(q))].append(t.cpu)
                for a, b in zip(w, w[1:], strict=False):
                    if a[2] == b[2]:
                        kind = ("pause" if b[4] == 0 else "one step" if b[4] == 1
                                else "coast" if b[3] == a[3] else "several steps")
                        cost[kind].append(b[0] - a[0])
        print(f"== {chip}")
        print(f"idle task (no stepper running): median {_median(idle)} ticks "
              f"({min(idle, default=0)}..{max(idle, default=0)}, {len(idle)} tasks)")
        print(f"a running stepper whose ramp is done (one-step entries left): median "
              f"{_median(done)} ({len(done)} tasks)")
        for (_, n), v in sorted(plain.items()):
            print(f"no command, {n} queued entries of several steps: median {_median(v)} "
                  f"({len(v)} tasks)")
        for kind, v in sorted(cost.items()):
            print(f"command of {kind}: {_median(v)} ticks between two queue writes "
                  f"({len(v)} commands)")
        for v, d in sorted(isr.items()):
            print(f"interrupt vector {v}: median {_median(d)} ticks entry to reti ({len(d)})")
    return 0


def cmd_task(args: argparse.Namespace) -> int:
    case = args.cases[0]
    prefix, board = replicate(case, args)
    tasks, _ = tasks_of(prefix, board.task_vector)
    at = round(args.at * 1000 * TICKS_PER_US)
    i = min(max(bisect.bisect_left([t.t for t in tasks], at), 0), len(tasks) - 1)
    t = tasks[i]
    print(f"task at cycle {t.t} ({t.t / TICKS_PER_US / 1000:.3f} ms): CPU {t.cpu}, wall {t.wall}, "
          f"nested by vector {dict(t.nested)}; queued steps at entry {t.queues}")
    names = ("write", "start", "queue write", "enable", "ramp step", "log2 back")
    for cpu, mark, this, ticks, steps, _ in t.marks:
        extra = f" stepper@{this:#x} ticks {ticks} steps {steps}" if mark == WRITE else ""
        print(f"  CPU {cpu:6d}  {names[mark]}{extra}")
    return 0


def pitches_of(prefix: Path, task_vector: int) -> list[dict[str, object]]:
    """Every command a ramp task writes after another of the same stepper: the CPU
    between the two writes (``pitch``, nested interrupts left out), the interrupts
    nested in that span, the two commands, and - with ``--profile`` - the task's own
    cycles by function in the span (the P lines of the run)."""
    names: dict[int, str] = {-1: "(none)"}
    funcs = Path(f"{prefix}.funcs")
    if funcs.exists():
        for i, line in enumerate(funcs.read_text().splitlines()):
            names[i] = line.split(None, 2)[2]
    out: list[dict[str, object]] = []
    stack: list[int] = []
    cpu = nested = 0
    last = 0
    marks: list[tuple[int, int, int, int, int, collections.Counter[str]]] = []
    prof: collections.Counter[str] = collections.Counter()
    running = 0
    with open(f"{prefix}.ev") as f:
        for line in f:
            p = line.split()
            c = int(p[0])
            if stack and stack[-1] == task_vector:
                cpu += c - last
            last = c
            if p[1] == "V":
                v = int(p[2])
                stack.append(v)
                if v == task_vector:
                    cpu = nested = 0
                    marks = []
                    prof = collections.Counter()
                    qs = " ".join(p[3:]).split("|")[1:]
                    running = sum(1 for q in qs if q.split())
                elif task_vector in stack:
                    nested += 1
            elif p[1] == "P" and task_vector in stack:
                for item in p[2:]:
                    k, n = item.split(":")
                    prof[names.get(int(k), k)] += int(n)
            elif p[1] == "M" and task_vector in stack:
                marks.append((cpu, int(p[2]), int(p[3]), int(p[4]), int(p[5]), nested,
                              prof, int(p[6]) if len(p) > 7 else 0,
                              int(p[7]) if len(p) > 7 else 0))
                prof = collections.Counter()
            elif p[1] == "R" and stack and stack.pop() == task_vector:
                _pitches(marks, running, c, out)
    return out


def _pitches(marks: list, running: int, t: int, out: list[dict[str, object]]) -> None:
    pending: collections.Counter[str] = collections.Counter()
    prev = None
    ramp_step = log2_back = -1
    for m in marks:
        if prev is not None:
            pending.update(m[6])
        if m[1] == CALC and ramp_step < 0:
            ramp_step = m[7]
        elif m[1] == TO_U32 and log2_back < 0 and ramp_step >= 0:
            log2_back = m[8] - 0x10000 if m[8] & 0x8000 else m[8]
        if m[1] != WRITE or m[4] >= 256 or m[3] == 0:
            continue
        if prev is not None and prev[2] == m[2]:
            a, b = prev, m
            kind = ("short" if a[4] <= 1 or b[4] <= 1 else "coast" if b[3] == a[3]
                    else "acc" if b[3] < a[3] else "dec")
            out.append({"t": t, "stepper": b[2], "running": running, "kind": kind,
                        "ticks0": a[3], "steps0": a[4], "ticks": b[3], "steps": b[4],
                        "pitch": b[0] - a[0], "nested": b[5] - a[5],
                        "ramp_step": ramp_step, "log2_back": log2_back,
                        "by_function": dict(pending)})
        prev = m
        pending = collections.Counter()
        ramp_step = log2_back = -1


def cmd_pitches(args: argparse.Namespace) -> int:
    """One line per command: its pitch and (with --profile) the cycles by function."""
    for case in args.cases:
        prefix, board = replicate(case, args)
        for r in pitches_of(prefix, board.task_vector):
            fn = r["by_function"]
            assert isinstance(fn, dict)
            top = " ".join(f"{k.split('(')[0]}={v}" for k, v in
                           sorted(fn.items(), key=lambda kv: -kv[1]))
            print(f"{case} {r['t']} {r['stepper']:#x} {r['running']} {r['kind']} "
                  f"{r['ticks0']} {r['steps0']} {r['ticks']} {r['steps']} {r['pitch']} "
                  f"{r['nested']} {r['ramp_step']} {r['log2_back']}  {top}")
    return 0


def parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--fas", required=True, help="FastAccelStepper 1.2.6 source tree")
    ap.add_argument("--simavr", required=True, help="simavr source tree (upstream)")
    ap.add_argument("--conformance", type=Path, default=_conformance())
    ap.add_argument("--work", default="/tmp/fas-replica")
    ap.add_argument("--at", type=float, default=0.0, help="task: its time in ms")
    ap.add_argument("--profile", action="store_true",
                    help="record the ramp task's cycles by function (pitches)")
    ap.add_argument("--timer-check", action="store_true",
                    help="write WORK/CASE.timer: timer 1's events (timer_check.py)")
    ap.add_argument("--build", choices=("e", "d"), default="e",
                    help="e: the build of e01-e18 (default); d: the build of the d*/test_sd_* "
                    "runs (--no-lto --input-everywhere --data-pad 1)")
    ap.add_argument("--opt", default="-Os",
                    help="optimisation level of every compile and the link: Os (default), O2, "
                    "O1, ...")
    ap.add_argument("--no-lto", action="store_true", help="build without -flto")
    ap.add_argument("--no-sections", action="store_true",
                    help="build without -ffunction-sections/-fdata-sections/--gc-sections")
    ap.add_argument("-D", "--define", action="append", metavar="NAME[=VALUE]",
                    help="a define added to every compile (repeatable)")
    ap.add_argument("--toolchain", default="",
                    help="directory of another avr-gcc/avr-g++ (default: those on PATH)")
    ap.add_argument("--input-everywhere", action="store_true",
                    help="SIM_TEST_INPUT on every compile (library, core), as PlatformIO's "
                    "build_flags, not only on the sketch's")
    ap.add_argument("--data-pad", type=int, default=None, metavar="BYTES",
                    help="add BYTES of initialised data (the start-up copy: 9 cycles a byte; "
                    "default 0, 1 with --build d)")
    ap.add_argument("--core", default="",
                    help="another Arduino AVR core: the folder holding cores/ and variants/ "
                    f"(default {CORE})")
    ap.add_argument("what", choices=("steps", "tasks", "task", "pitches"))
    ap.add_argument("cases", nargs="+")
    return ap


def main(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    return {"steps": cmd_steps, "tasks": cmd_tasks, "task": cmd_task,
            "pitches": cmd_pitches}[args.what](args)


if __name__ == "__main__":
    sys.exit(main())
