"""Fuzzing the helix winder (``stepperdemo winder``) through the program interface.

Inputs (:func:`winder_case`): lines of the winder's command words (``move period accel
interlock ratio pots traverse status pot switch reset help ? w<ms>``) with valid,
boundary and malformed arguments, missing arguments and unknown words; and bytes
(noise, bytes >= 0x80, control bytes) fed as a serial line delivers them.

The winder runs on the profiles that have what it needs (two steppers on their own
direction pins, inputs A0..A5: :func:`hosting_profiles`); on every other profile
making it must fail with one clear line (:func:`check_refusal`).

Invariants (:func:`check_winder`):

* no exception;
* each stepper's position by the library equals the one counted from its pins, up to
  what the winder declared (``reset``, a stop at a limit: :class:`.common.PinTracker`);
* S2 makes no step towards a closed limit switch later than the winder's stop time
  after the switch closed (SPEC 7.2: ``figures.LIMIT_STOP_MS``);
* while the interlock follows (the gear's spans), ``|dS2 - n/m dS1| <= 1`` step at
  every step instant, by the pins (seed 002);
* the session goes on: after the input (and a console Ctrl-C if it still ran)
  ``status`` answers with both steppers.
"""

from __future__ import annotations

import random
import re

from fas.arch import PROFILES, get_profile
from fas.sim import SimBackend

from ..program import make_program
from ..winder import figures as fig
from ..winder.app import Winder, WinderError
from .common import BYTES, LINE, Case, FuzzResult, PinTracker, StepTrack, drive, noise, start

PROGRAM = "winder"

# (valid, malformed or out of range) arguments: a command mostly gets a valid one
STEPPERS = (["1", "2"], ["0", "3", "x", "-1", "01", "1.0"])
COUNTS = (["0", "1", "-1", "10", "-10", "100", "-100", "500", "-500", "2000", "-2000", "65535",
           "-65535", "300", "-300"], ["65536", "1.5", "abc", "+5", "99999999999", "-65536"])
PERIODS = (["9", "10", "25", "50", "100", "250", "1000", "2000", "65535"],
           ["8", "65536", "0", "-5", "12.5"])
ACCELS = (["1", "100", "1000", "10000", "50000", "1000000", "10000000"],
          ["10000001", "0", "-1", "1e3"])
RATIOS = (["1:1", "1:2", "3:7", "2:3", "1:65535", "65535:65535", "1:3", "7:8"],
          ["2:1", "0:1", "1:0", "a:b", "70000:70000", "1:", ":2", "5"])
POTS = (["0", "100", "300", "461", "462", "512", "562", "563", "700", "900", "1023"],
        ["1024", "-1", "x"])
SWITCHES = (["A2", "A3", "A2", "A3", "A4", "A5", "a2"], ["A1", "A6", "B2"])
BOOLS = (["0", "1"], ["2", "on", "-1"])
ENDS = (["0", "100", "-100", "500", "-500", "2000", "1000", "-1000", "50"],
        ["2147483648", "x", "1.5"])
UNKNOWN = ["foo", "MOVE", "Status", "go", "stop", "12", "-", "S1", "pot1", "w", "w-5", "wx"]
# what a winder does: sequences that drive S2 into its limits, follow S1, traverse
SCENES = [
    "move 2 {c} w{t} switch {sw} 1 w{t} status switch {sw} 0",
    "interlock 1 ratio {r} move 1 {c} w{t} switch A3 1 w{t} switch A2 1 w{t}",
    "traverse {e} {e2} w{t} switch {sw} 1 w{t} switch {sw} 0 w{t} move 2 0",
    "switch A4 1 reset pot 1 {p} pot 2 {p2} w{t} switch {sw} 1 w{t} pot 2 512 w{t}",
    "pots pot 2 {p} w{t} switch {sw} 1 w{t} pot 2 {p2} w{t} switch {sw} 0",
    "interlock 1 pots pot 1 {p} w{t} ratio {r} w{t} pot 2 {p2} w{t} pot 2 512 w{t}",
    "move 1 {c} move 2 {c2} w{t} period 1 {per} accel 2 {a} w{t} move 1 0 w{t}",
    "switch {sw} 1 move 2 {c} w{t} traverse {e} {e2} w{t} interlock 1 w{t}",
]


def _pick(rng: random.Random, values: tuple[list[str], list[str]], bad: float = 0.12) -> str:
    good, wrong = values
    return rng.choice(wrong if rng.random() < bad else good)


def _wait(rng: random.Random) -> str:
    return f"w{rng.choice([0, 1, 20, 50, 100, 200, 400, 800, 1500])}"


def winder_command(rng: random.Random) -> str:
    r = rng.random()
    if r < 0.2:
        return f"move {_pick(rng, STEPPERS)} {_pick(rng, COUNTS)}"
    if r < 0.27:
        return f"period {_pick(rng, STEPPERS)} {_pick(rng, PERIODS)}"
    if r < 0.32:
        return f"accel {_pick(rng, STEPPERS)} {_pick(rng, ACCELS)}"
    if r < 0.39:
        return f"interlock {_pick(rng, BOOLS)}"
    if r < 0.44:
        return f"ratio {_pick(rng, RATIOS)}"
    if r < 0.49:
        return "pots"
    if r < 0.55:
        return f"traverse {_pick(rng, ENDS)} {_pick(rng, ENDS)}"
    if r < 0.58:
        return rng.choice(["status", "help", "?"])
    if r < 0.68:
        return f"pot {_pick(rng, STEPPERS)} {_pick(rng, POTS)}"
    if r < 0.78:
        return f"switch {_pick(rng, SWITCHES)} {_pick(rng, BOOLS)}"
    if r < 0.8:
        return "reset"
    if r < 0.93:
        return _wait(rng)
    if r < 0.96:
        return rng.choice(UNKNOWN)
    return rng.choice(["move", "move 1", "period 2", "traverse 5", "pot", "switch A2", "ratio"])


def winder_scene(rng: random.Random) -> str:
    return rng.choice(SCENES).format(
        c=rng.choice(COUNTS[0]), c2=rng.choice(COUNTS[0]), t=rng.choice([20, 50, 100, 300]),
        sw=rng.choice(["A2", "A3"]), r=rng.choice(RATIOS[0]), e=rng.choice(ENDS[0]),
        e2=rng.choice(ENDS[0]), p=rng.choice(POTS[0]), p2=rng.choice(POTS[0]),
        per=rng.choice(PERIODS[0]), a=rng.choice(ACCELS[0]))


def winder_line(rng: random.Random, most: int = 10) -> str:
    words = [winder_command(rng) for _ in range(rng.randint(1, most))]
    if rng.random() < 0.4:
        words.insert(rng.randint(0, len(words)), winder_scene(rng))
    if rng.random() < 0.6:
        words.append(_wait(rng))
    return rng.choice([" ", " ", "  ", "\t"]).join(words)


def winder_case(rng: random.Random, arch: str = "atmega328p") -> Case:
    if rng.random() < 0.15:
        words = [w.encode() for w in ("move 1 100", "status", "pot 2 900", "switch A3 1",
                                      "w100", "interlock 1")]
        chunks = tuple((rng.choice([0, 20, 200]), noise(rng, words) + b"\n")
                       for _ in range(rng.randint(1, 3)))
        return Case(BYTES, chunks=chunks)
    return Case(LINE, winder_line(rng).encode())


def hosting_profiles() -> tuple[str, ...]:
    return tuple(name for name, p in PROFILES.items() if Winder.profile_problem(p) is None)


def refusing_profiles() -> tuple[str, ...]:
    return tuple(name for name, p in PROFILES.items() if Winder.profile_problem(p) is not None)


def check_refusal(arch: str) -> FuzzResult:
    """A profile the winder cannot run on: making it fails with one clear line."""
    res = FuzzResult(b"", arch, PROGRAM, Case(LINE))
    try:
        make_program(PROGRAM, SimBackend(arch), scripted=True)
    except WinderError as exc:
        text = str(exc)
        if not text or "\n" in text or get_profile(arch).name not in text:
            res.violations.append(f"refusal is not one line naming the profile: {text!r}")
        res.end = "refused"
        return res
    except Exception as exc:
        res.record_exception(exc)
        return res
    res.violations.append("the winder started on a profile it says it cannot run on")
    return res


# ------------------------------------------------------------------- checks
_STATUS_AXIS = re.compile(r"^S([12]) \S+ +@(-?\d+) ", re.MULTILINE)


def _check_limits(backend, winder, tracks, res: FuzzResult) -> None:
    """No S2 step towards a closed limit later than the stop time after it closed."""
    grace = fig.LIMIT_STOP_MS * backend.profile.ticks_per_ms
    track = tracks[1]
    for a, up in ((fig.LIMIT_LOW, False), (fig.LIMIT_HIGH, True)):
        times, levels = backend.recorder.pin_edges(winder.pin(a))
        closed_since = None
        k = 0
        for t, going_up in zip(track.rises, track.up, strict=True):
            while k < len(times) and times[k] <= t:
                closed = levels[k] == fig.SWITCH_CLOSED_LEVEL
                if closed and closed_since is None:
                    closed_since = times[k]
                elif not closed:
                    closed_since = None
                k += 1
            if going_up == up and closed_since is not None and t - closed_since > grace:
                res.violations.append(
                    f"S2 stepped {'up' if up else 'down'} at tick {t}, "
                    f"{(t - closed_since) / backend.profile.ticks_per_ms:.2f} ms after its "
                    f"{'upper' if up else 'lower'} limit A{a} closed")
                return


def _check_interlock(backend, winder, tracker: PinTracker, tracks, res: FuzzResult) -> None:
    """While the gear follows: |dS2 - n/m dS1| <= 1 step at every step instant."""
    s1, s2 = tracks
    for span in winder.spans:
        end = span.end if span.end is not None else backend.now()
        instants = sorted({t for tr in (s1, s2) for t in tr.rises if span.start <= t <= end})
        for t in instants:
            x = s1.at(t) + tracker.offset_at(0, t)
            y = s2.at(t) + tracker.offset_at(1, t)
            err = abs((y - span.y0) - span.n * (x - span.x0) / span.m)
            if err > 1 + 1e-9:
                res.violations.append(
                    f"interlock {span.n}:{span.m}: |S2 - ratio x S1| = {err:.3f} steps at tick "
                    f"{t} (S1 @{x}, S2 @{y}, from S1 @{span.x0}, S2 @{span.y0})")
                return


def check_winder(case: Case, arch: str = "atmega328p", max_time_s: float = 4.0,
                 probe_session: bool = True) -> FuzzResult:
    """Run one case on a fresh simulated chip and return what it broke."""
    res = FuzzResult(case.data, arch, PROGRAM, case)
    backend = SimBackend(arch, record=True)
    tps = backend.profile.ticks_per_s
    try:
        winder, tracker = start(PROGRAM, backend, res)
        limit = backend.now() + int(max_time_s * tps)
        if case.kind == LINE:
            end = winder.run_script(case.text, max_ticks=limit - backend.now())
            res.end = end.name.lower()
            done = res.end == "idle"
        else:
            done = drive(winder, case.chunks, limit, res)
            res.end = "idle" if done else "max_time"
        if not done:
            winder.force_stop_all()  # the console's Ctrl-C
        if probe_session:
            mark = len(winder.transcript)
            winder.run_script("status", max_ticks=tps // 2)  # (pots may drive on)
            new = bytes(winder.transcript[mark:]).decode("utf-8", "replace")
            said = sorted(int(n) for n, _ in _STATUS_AXIS.findall(new))
            if said != [1, 2]:
                res.violations.append(f"probe: status answered {new[:200]!r}")
            winder.force_stop_all()  # the pots may drive on: stop for the checks
        tracker.check()
        s1, s2 = winder.steppers[:2]
        tracks = [StepTrack(backend, s.get_step_pin(), s.get_direction_pin(),
                            s.direction_pin_high_counts_up()) for s in (s1, s2)]
        _check_limits(backend, winder, tracks, res)
        _check_interlock(backend, winder, tracker, tracks, res)
    except Exception as exc:  # the whole point: nothing may raise
        res.record_exception(exc)
    return res
