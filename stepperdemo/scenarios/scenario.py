"""Scenario files (``sequences/*.toml``): one StepperDemo input line and its expected result.

A broken file raises :class:`ScenarioError` naming the file, the key and the problem;
the format is documented in the README ("Scenario files").
"""

from __future__ import annotations

import re
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from fas.arch import PROFILES
from fas.sim.builds import check_build

from ..demo.build import pin_config_problem
from ..program import programs

if sys.version_info >= (3, 11):
    import tomllib
else:  # Python 3.10: the same parser as a package (a dependency there, pyproject.toml)
    import tomli as tomllib

STEPPER_KEYS = {
    "position": int, "pulses": int, "dir_transitions": list, "enable_transitions": list,
    "enable_high_max_us": (int, float), "step_high_total_us": (int, float),
    "step_high_max_us": (int, float),
}
TOLERANCE_KEYS = {
    "position": int, "pulses": int, "dir": int, "enable": int,
    "enable_high_us": (int, float), "step_high_total_pct": (int, float),
    "step_high_total_us": (int, float), "step_high_max_us": (int, float),
    "position_pct": (int, float), "pulses_pct": (int, float),
}
GAPS_KEYS = {"steppers": list, "per_window": int}
KNOWN_DEVIATION_KEYS = {"measured": (int, float, str), "reason": str}
TIMING_KEYS = {
    "steppers": list, "align": str, "median_us": (int, float), "max_us": (int, float),
    "duration_ratio": (int, float), "start_us": (int, float),
}
TOP_KEYS = {
    "name": str, "description": str, "program": str, "profile": str, "input": str,
    "input_file": str, "end": str,
    "max_time_s": (int, float), "long": bool, "reference": str, "justification": str,
    "steppers": dict, "timing": dict, "transcript": dict, "outputs": dict, "build": str,
    "gaps": dict, "pin_config": int, "known_deviation": dict,
}
# user outputs (issue 12): [outputs.Dout0] ... [outputs.Aout3]
OUTPUT_KEYS = {
    "rises": int, "falls": int, "level": int, "first_change_s": (int, float),
    "first_change_after_step": list, "periods": int, "frequency_hz": (int, float),
    "duty_percent": (int, float), "duty_mean_percent": (int, float),
    "duty_steps": list,
}
OUTPUT_TOLERANCE_KEYS = {
    "rises": int, "falls": int, "first_change_s": (int, float), "periods": int,
    "frequency_hz": (int, float), "duty_percent": (int, float),
    "duty_mean_percent": (int, float), "duty_steps": (int, float),
}
OUTPUT_NAMES = tuple(f"Dout{i}" for i in range(4)) + tuple(f"Aout{i}" for i in range(4))


class ScenarioError(Exception):
    def __init__(self, path: Path | str, key: str, problem: str) -> None:
        super().__init__(f"{path}: {key}: {problem}")
        self.path = str(path)
        self.key = key
        self.problem = problem


@dataclass
class StepperExpectation:
    letter: str
    values: dict[str, Any]
    tol: dict[str, Any]


@dataclass
class OutputExpectation:
    """What a user output (``Dout0`` .. ``Aout3``) must show (issue 12)."""

    name: str
    values: dict[str, Any]
    tol: dict[str, Any]


@dataclass
class TimingExpectation:
    steppers: list[str]
    align: str = "absolute"
    median_us: float | None = None
    max_us: float | None = None
    duration_ratio: float | None = None
    start_us: float | None = None  # bound on the removed start offset(s)


@dataclass
class GapsExpectation:
    """The timer-wrap gaps of `e` per window, against the reference's step files."""

    steppers: list[str]
    per_window: int = 1  # tolerance on each window's count


@dataclass
class Scenario:
    path: Path
    name: str
    input: str
    description: str = ""
    program: str = "demo"  # the program the input is for (stepperdemo.program.programs)
    profile: str = "atmega328p"
    build: str | None = None  # the firmware build (fas.sim.builds; None: the default)
    end: str = "idle"
    max_time_s: float = 600.0
    long: bool = False
    reference: Path | None = None
    justification: str = ""
    steppers: list[StepperExpectation] = field(default_factory=list)
    outputs: list[OutputExpectation] = field(default_factory=list)
    timing: TimingExpectation | None = None
    contains: list[str] = field(default_factory=list)
    not_contains: list[str] = field(default_factory=list)
    transcript_ref: Path | None = None  # whole transcript to match (scenarios.transcript)
    gaps: GapsExpectation | None = None
    pin_config: int | None = None  # StepperDemo's start-up prompt answered with this digit
    pcnt_sync: tuple[str, int] | None = None  # (motor, tolerance): status lines vs counter
    # checks not met yet, by check name: {"measured": value named by the file, "reason"}
    known_deviations: dict[str, dict[str, Any]] = field(default_factory=dict)


def _check_types(path: Path, prefix: str, table: dict, schema: dict) -> None:
    for key, value in table.items():
        if key not in schema:
            raise ScenarioError(path, prefix + key,
                                f"unknown key (known: {', '.join(sorted(schema))})")
        want = schema[key]
        if isinstance(value, bool) and want is not bool and bool not in (
                want if isinstance(want, tuple) else (want,)):
            raise ScenarioError(path, prefix + key, "expected a number, not true/false")
        if not isinstance(value, want):
            names = "/".join(t.__name__ for t in (want if isinstance(want, tuple) else (want,)))
            raise ScenarioError(path, prefix + key, f"expected {names}, got {value!r}")


def load(path: Path | str) -> Scenario:
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ScenarioError(path, "-", f"cannot read: {exc.strerror or exc}") from None
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(path, "-", f"not valid TOML: {exc}") from None
    _check_types(path, "", data, TOP_KEYS)
    if "name" not in data:
        raise ScenarioError(path, "name", "missing (required)")
    if "input" not in data and "input_file" not in data:
        raise ScenarioError(path, "input", "missing (required; or input_file)")
    if "input" in data and "input_file" in data:
        raise ScenarioError(path, "input", "give either input or input_file, not both")
    if "input_file" in data:  # the input in a file of its own (a G-code program)
        source = path.parent / data["input_file"]
        try:
            data["input"] = source.read_text(encoding="utf-8")
        except OSError as exc:
            raise ScenarioError(path, "input_file",
                                f"cannot read {source}: {exc.strerror or exc}") from None
    profile = data.get("profile", "atmega328p")
    if profile not in PROFILES:
        raise ScenarioError(path, "profile", f"unknown profile {profile!r}")
    program = data.get("program", "demo")
    known = programs()
    if program not in known:
        raise ScenarioError(path, "program",
                            f"unknown program {program!r} (known: {', '.join(sorted(known))})")
    end = data.get("end", "idle")
    if end not in ("idle", "firmware"):
        raise ScenarioError(path, "end", "must be 'idle' or 'firmware'")
    if data.get("max_time_s", 1) <= 0:
        raise ScenarioError(path, "max_time_s", "must be positive")
    build = data.get("build")
    try:
        check_build(build)
    except ValueError as exc:
        raise ScenarioError(path, "build", str(exc)) from None
    pin_config = data.get("pin_config")
    if pin_config is not None:
        if program != "demo":
            raise ScenarioError(path, "pin_config", "only StepperDemo (program = \"demo\") "
                                "has pin configurations")
        problem = pin_config_problem(PROFILES[profile], pin_config)
        if problem is not None:
            raise ScenarioError(path, "pin_config", problem.split(": ", 1)[1])
    sc = Scenario(path=path, name=data["name"], input=data["input"],
                  description=data.get("description", ""), program=program,
                  profile=profile, build=build, end=end,
                  max_time_s=float(data.get("max_time_s", 600.0)), long=data.get("long", False),
                  justification=data.get("justification", ""), pin_config=pin_config)
    for what, entry in data.get("known_deviation", {}).items():
        if not isinstance(entry, dict):
            raise ScenarioError(path, f"known_deviation.{what}",
                                "expected a table { measured = ..., reason = \"...\" }")
        _check_types(path, f"known_deviation.{what}.", entry, KNOWN_DEVIATION_KEYS)
        if "measured" not in entry:
            raise ScenarioError(path, f"known_deviation.{what}.measured",
                                "missing: name the value measured now")
        sc.known_deviations[what] = dict(entry)
    if "reference" in data:
        ref = (path.parent / data["reference"]).resolve()
        if not ref.is_dir():
            raise ScenarioError(path, "reference", f"no such folder: {ref}")
        sc.reference = ref
    for letter, table in data.get("steppers", {}).items():
        prefix = f"steppers.{letter}."
        if letter not in "ABCDEF" or len(letter) != 1:
            raise ScenarioError(path, f"steppers.{letter}", "stepper names are A..F")
        if not isinstance(table, dict):
            raise ScenarioError(path, f"steppers.{letter}", "expected a table")
        tol = table.get("tol", {})
        values = {k: v for k, v in table.items() if k != "tol"}
        _check_types(path, prefix, values, STEPPER_KEYS)
        if not isinstance(tol, dict):
            raise ScenarioError(path, prefix + "tol", "expected a table")
        _check_types(path, prefix + "tol.", tol, TOLERANCE_KEYS)
        for key in ("dir_transitions", "enable_transitions"):
            if key in values and (len(values[key]) != 2
                                  or not all(isinstance(x, int) for x in values[key])):
                raise ScenarioError(path, prefix + key, "expected [rising, falling] integers")
        sc.steppers.append(StepperExpectation(letter, values, tol))
    for name, table in data.get("outputs", {}).items():
        prefix = f"outputs.{name}."
        if name not in OUTPUT_NAMES:
            raise ScenarioError(path, f"outputs.{name}", "outputs are Dout0..Dout3, Aout0..Aout3")
        if not isinstance(table, dict):
            raise ScenarioError(path, f"outputs.{name}", "expected a table")
        tol = table.get("tol", {})
        values = {k: v for k, v in table.items() if k != "tol"}
        _check_types(path, prefix, values, OUTPUT_KEYS)
        if not isinstance(tol, dict):
            raise ScenarioError(path, prefix + "tol", "expected a table")
        _check_types(path, prefix + "tol.", tol, OUTPUT_TOLERANCE_KEYS)
        after = values.get("first_change_after_step")
        if after is not None and (len(after) != 2 or not isinstance(after[0], str)
                                  or after[0] not in "ABCDEF" or len(after[0]) != 1
                                  or not isinstance(after[1], int) or after[1] < 0):
            raise ScenarioError(path, prefix + "first_change_after_step",
                                'expected ["A".."F", step number]')
        steps = values.get("duty_steps")
        if steps is not None and not all(
                isinstance(st, list) and len(st) == 2 and all(
                    isinstance(x, (int, float)) and not isinstance(x, bool) for x in st)
                for st in steps):
            raise ScenarioError(path, prefix + "duty_steps",
                                "expected [[duty percent, seconds], ...]")
        if values.get("level", 0) not in (0, 1):
            raise ScenarioError(path, prefix + "level", "expected 0 or 1")
        sc.outputs.append(OutputExpectation(name, values, tol))
    if "timing" in data:
        t = data["timing"]
        _check_types(path, "timing.", t, TIMING_KEYS)
        if sc.reference is None:
            raise ScenarioError(path, "timing", "needs 'reference' (the folder of steps files)")
        align = t.get("align", "absolute")
        if align not in ("absolute", "first_step", "each_move"):
            raise ScenarioError(path, "timing.align",
                                "must be 'absolute', 'first_step' or 'each_move'")
        steppers = t.get("steppers", ["A"])
        for letter in steppers:
            if not (sc.reference / f"steps_{letter}.tsv.gz").exists():
                raise ScenarioError(path, "timing.steppers",
                                    f"no steps_{letter}.tsv.gz in {sc.reference}")
        sc.timing = TimingExpectation(steppers, align, t.get("median_us"), t.get("max_us"),
                                      t.get("duration_ratio"), t.get("start_us"))
    if "gaps" in data:
        g = data["gaps"]
        _check_types(path, "gaps.", g, GAPS_KEYS)
        if sc.reference is None:
            raise ScenarioError(path, "gaps", "needs 'reference' (the folder of steps files)")
        letters = g.get("steppers", ["A"])
        for letter in letters:
            if not (sc.reference / f"steps_{letter}.tsv.gz").exists():
                raise ScenarioError(path, "gaps.steppers",
                                    f"no steps_{letter}.tsv.gz in {sc.reference}")
        if g.get("per_window", 1) < 0:
            raise ScenarioError(path, "gaps.per_window", "must not be negative")
        sc.gaps = GapsExpectation(letters, g.get("per_window", 1))
    if "transcript" in data:
        tr = data["transcript"]
        for key, value in tr.items():
            if key == "matches":
                if not isinstance(value, str):
                    raise ScenarioError(path, "transcript.matches", "expected a file name")
                ref = (path.parent / value).resolve()
                if not ref.is_file():
                    raise ScenarioError(path, "transcript.matches", f"no such file: {ref}")
                sc.transcript_ref = ref
                continue
            if key == "pcnt_sync":  # upstream's check_pcnt_sync (ESP32 hardware tests)
                if (not isinstance(value, dict) or set(value) != {"motor", "tolerance"}
                        or not isinstance(value["motor"], str)
                        or not re.fullmatch(r"M\d+", value["motor"])
                        or not isinstance(value["tolerance"], int)
                        or isinstance(value["tolerance"], bool)):
                    raise ScenarioError(path, "transcript.pcnt_sync",
                                        'expected { motor = "M1", tolerance = 66 }')
                sc.pcnt_sync = (value["motor"], value["tolerance"])
                continue
            if key not in ("contains", "not_contains"):
                raise ScenarioError(path, f"transcript.{key}", "unknown key (known: "
                                    "contains, not_contains, matches, pcnt_sync)")
            if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
                raise ScenarioError(path, f"transcript.{key}", "expected a list of strings")
        sc.contains = list(tr.get("contains", []))
        sc.not_contains = list(tr.get("not_contains", []))
    return sc


def collect(paths: list[str | Path]) -> list[Path]:
    """Scenario files named directly or found (recursively) in folders, sorted."""
    files: list[Path] = []
    for p in paths:
        p = Path(p)
        if p.is_dir():
            files.extend(sorted(p.rglob("*.toml")))
        else:
            files.append(p)
    return files
