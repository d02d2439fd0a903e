"""Tick-exactness guard for speed work: digests of transcripts and pin edges.

    python bench/fingerprint.py [--fuzz N] [--seed S] [--sequences] [--against DIR] [--show]

Runs a fixed set of console lines (the speed benchmark's line, test sequences, a
QuickStep move, ESP32 and SAM Due lines, interrupt blocking, stops) and N seeded fuzz
lines on the simulated chip and prints, per run, a digest of everything a change in
timing would move: the transcript, every recorded pin edge (tick and level), the final
tick, pin statistics and each stepper's position.  Each line runs twice, with and
without the edge recorder: the recorder must not change the transcript either.

Two G-code runs (``gcode:`` cases) take bench_path's CAM program (``GCODE_SEGMENTS``
short segments around circles and a raster, as ``bench/bench_gcode.py --lookahead-only``
runs it) through the look-ahead, once with Grbl's junctions (``$172=0``) and once with
the corner blends (``$172=1``).

``--sequences`` adds every scenario file of ``sequences/`` (its program, profile and input
as ``stepperdemo run`` runs it, with the edge recorder on).

``--against DIR`` runs the same lines in another source tree (e.g. ``git archive
<commit> | tar x -C /tmp/before``) and reports every run whose digest differs; exit
code 1 if any does.  A speed change must leave every digest as it was.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import random
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

LINES = [
    ("atmega328p", "M1 A100000 V40 R1000000 W"),
    ("atmega328p", "t M1 01 02 03 R W"),
    ("atmega328p", "c M1 l1 q20 p8 x M1 A1000 V100 R3200 W"),
    ("atmega328p", "M1 A10000 V100 R5000 M2 A5000 V200 R-3000 W M1 W"),
    ("atmega328p", "M1 A1000 V100 e R3200 w500 e r w200 r U W"),
    ("atmega328p", "M1 A20000 H10000 f w300 H4000 U w200 S W b w100 X W"),
    ("atmega328p", "M1 A1000 J300 V50 R10000 W j50 R-2000 W"),
    ("atmega2560", "M1 A10000 V60 R20000 M2 R-500 M3 R700 W"),
    ("atmega32u4", "M1 A5000 V100 R4000 W"),
    ("esp32", "M1 A100000 V40 R200000 W"),
    ("esp32", "W1 t 06 w500 09 00 M2 01 06 R x"),
    ("sam_due", "M1 A50000 V20 R100000 M2 R-5000 W"),
    ("rp2040", "M1 A20000 V50 R30000 W"),
]

#: segments of bench_path's CAM program in each ``gcode:`` case
GCODE_SEGMENTS = 1500


def gcode_cases() -> list[tuple[str, str]]:
    """bench_gcode's look-ahead program (its settings first), in both corner modes, as
    ("gcode:<arch>", the program's text)."""
    import bench_path as bp

    moves = [f"G1 X{p[0]:.4f} Y{p[1]:.4f} F{f:g}" for p, f in bp.cam_program(GCODE_SEGMENTS)]
    setup = ([f"$10{i}={bp.SPU}" for i in range(2)]
             + [f"$11{i}={bp.MAX_RATE}" for i in range(2)]
             + [f"$12{i}={bp.ACCEL}" for i in range(2)] + [f"$11={bp.JUNCTION}", "$171=0"])
    return [("gcode:atmega328p", "\n".join([f"$172={blends}"] + setup + moves) + "\n")
            for blends in (0, 1)]


def fuzz_lines(n: int, seed: int) -> list[tuple[str, str]]:
    """N lines of the fuzz generator (the current tree's), as (arch, latin-1 text)."""
    sys.path.insert(0, str(ROOT))
    from stepperdemo.fuzz import grammar_line, raw_line

    rng = random.Random(seed)
    archs = ("atmega328p", "atmega2560", "esp32", "sam_due")
    out = []
    for _ in range(n):
        arch = rng.choice(archs)
        line = raw_line(rng) if rng.random() < 0.2 else grammar_line(rng, arch=arch).encode()
        out.append((arch, line.decode("latin-1")))
    return out


def digest(arch: str, line: bytes) -> str:
    """Run one line (recorded and unrecorded) and digest what it did."""
    from fas.sim import SimBackend
    from stepperdemo.demo.app import StepperDemo

    h = hashlib.sha256()
    transcripts = []
    for record in (True, False):
        b = SimBackend(arch, record=record)
        app = StepperDemo(b, scripted=True, test_mode_wait=True)
        try:
            reason = app.run_script(line, max_ticks=20 * b.profile.ticks_per_s).name
        except Exception as exc:  # noqa: BLE001 - a failure is part of the fingerprint
            reason = f"{type(exc).__name__}: {exc}"
        transcripts.append(bytes(app.transcript))
        h.update(f"{record} {reason} {b.now()} ".encode())
        h.update(bytes(app.transcript))
        _digest_backend(h, b, app.steppers)
    if transcripts[0] != transcripts[1]:
        return "recorder-changes-transcript"
    return h.hexdigest()[:16]


def _digest_backend(h, b, steppers) -> None:
    """Pin tables, recorded edges and positions of a finished run into the hash."""
    # the backend's declared pins (issue 22); a tree from before has only the machine's
    pins = getattr(b, "pin_states", None) or b.machine.pins
    for table in (pins.level, pins.rise, pins.fall, pins.high_max, pins.high_total):
        h.update(repr(sorted(table.items())).encode())
    h.update(repr([None if s is None else s.get_current_position() for s in steppers]).encode())
    rec = b.recorder
    if rec is not None:
        for pin in sorted(rec.times):
            h.update(f"pin {pin} ".encode())
            h.update(rec.times[pin].tobytes())
            h.update(bytes(rec.levels[pin]))


def scenario_digest(path: str) -> str:
    """Run one scenario file as ``stepperdemo run`` does and digest what it did."""
    from fas.sim import SimBackend
    from stepperdemo.program import make_program
    from stepperdemo.scenarios.scenario import load

    sc = load(path)
    h = hashlib.sha256()
    b = SimBackend(sc.profile, record=True)
    try:
        app = make_program(sc.program, b, scripted=True)
    except ValueError as exc:
        return f"refused: {exc}"[:40]
    try:
        reason = app.run_script(sc.input, firmware_end=(sc.end == "firmware"),
                                max_ticks=int(sc.max_time_s * b.profile.ticks_per_s)).name
    except Exception as exc:  # noqa: BLE001 - a failure is part of the fingerprint
        reason = f"{type(exc).__name__}: {exc}"
    return _digest_run(h, b, app, reason)


def _digest_run(h: "hashlib._Hash", b: object, app: object, reason: str) -> str:
    """The digest of a finished run: how it ended, at which tick, its transcript, its pins."""
    h.update(f"{reason} {b.now()} ".encode())  # type: ignore[attr-defined]
    h.update(bytes(app.transcript))  # type: ignore[attr-defined]
    _digest_backend(h, b, getattr(app, "steppers", []))
    return h.hexdigest()[:16]


def gcode_digest(arch: str, text: str) -> str:
    """Run a G-code program on two axes (recorded) and digest what it did."""
    from fas.sim import SimBackend
    from stepperdemo.program import make_program

    h = hashlib.sha256()
    b = SimBackend(arch, record=True)
    app = make_program("gcode", b, scripted=True, output=lambda d: None, axes=2)
    try:
        reason = app.run_script(text, max_ticks=600 * b.profile.ticks_per_s).name
    except Exception as exc:  # noqa: BLE001 - a failure is part of the fingerprint
        reason = f"{type(exc).__name__}: {exc}"
    return _digest_run(h, b, app, reason)


def run_here(cases: list[tuple[str, str]]) -> list[str]:
    out = []
    for arch, text in cases:
        if arch == "scenario":
            out.append(scenario_digest(text))
        elif arch.startswith("gcode:"):
            out.append(gcode_digest(arch[len("gcode:"):], text))
        else:
            out.append(digest(arch, text.encode("latin-1")))
    return out


def scenario_cases() -> list[tuple[str, str]]:
    """Every scenario file of sequences/, as ("scenario", path relative to the root)."""
    return [("scenario", str(p.relative_to(ROOT)))
            for p in sorted((ROOT / "sequences").rglob("*.toml"))]


def run_tree(tree: Path, cases: list[tuple[str, str]]) -> list[str]:
    """The digests of the same cases computed by another source tree."""
    code = ("import json, sys\n"
            f"sys.path.insert(0, {str(tree)!r})\n"
            f"sys.path.insert(1, {str(ROOT / 'bench')!r})\n"
            "import fingerprint\n"
            "print(json.dumps(fingerprint.run_here(json.load(sys.stdin))))\n")
    env = dict(os.environ, PYTHONPATH=str(tree))
    out = subprocess.run([sys.executable, "-c", code], input=json.dumps(cases), text=True,
                         capture_output=True, env=env, check=True, cwd=str(tree)).stdout
    return json.loads(out)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--fuzz", type=int, default=100, help="fuzz lines besides the fixed ones")
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--sequences", action="store_true",
                    help="add every scenario file of sequences/")
    ap.add_argument("--against", metavar="DIR", help="another source tree to compare with")
    ap.add_argument("--show", action="store_true", help="print every digest")
    args = ap.parse_args()
    os.chdir(ROOT)  # scenario paths are relative to the tree that runs them
    cases = LINES + gcode_cases() + fuzz_lines(args.fuzz, args.seed)
    if args.sequences:
        cases += scenario_cases()
    sys.path.insert(0, str(ROOT))
    mine = run_here(cases)
    if args.show or not args.against:
        for (arch, text), d in zip(cases, mine, strict=True):
            print(f"{d} [{arch}] {text[:70]!r}")
    if not args.against:
        return 0
    theirs = run_tree(Path(args.against).resolve(), cases)
    differ = [(c, a, b) for c, a, b in zip(cases, mine, theirs, strict=True) if a != b]
    for (arch, text), a, b in differ:
        print(f"DIFFERS [{arch}] {text[:70]!r}: {a} here, {b} there")
    print(f"{len(cases)} runs, {len(differ)} differ from {args.against}")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
