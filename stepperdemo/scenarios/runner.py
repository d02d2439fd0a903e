"""``stepperdemo run``: run scenario files on virtual time and check their expectations."""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Sequence

from fas.output_figures import output_figures
from fas.sim import SimBackend

from .. import messages as msg
from ..program import EndReason, make_program
from . import transcript as transcript_cmp
from .evaluate import (
    TimingComparison,
    compare_steps,
    gaps_per_window,
    pin_activity,
    position_from_pins,
    read_reference_track,
    step_times_us,
    stepper_pins,
    wrap_gaps,
)
from .scenario import Scenario, ScenarioError, collect, load

EXIT_OK = 0
EXIT_USAGE = 2
EXIT_FAILED = 4


@dataclass
class Check:
    what: str
    expected: object
    measured: object
    deviation: float | None
    tolerance: float | None
    ok: bool
    # a known deviation (the file's [known_deviation]): ok while the check still fails;
    # ``named`` is the value the file says is measured now
    known: bool = False
    named: object = None


@dataclass
class ScenarioResult:
    path: str
    name: str
    ok: bool
    error: str | None = None
    end: str = ""
    sim_s: float = 0.0
    wall_s: float = 0.0
    checks: list[Check] = field(default_factory=list)
    timing: dict[str, dict] = field(default_factory=dict)
    long: bool = False


def _num_check(what: str, expected: float, measured: float, tol: float) -> Check:
    dev = measured - expected
    return Check(what, expected, measured, dev, tol, abs(dev) <= tol)


@dataclass
class Watch:
    """Per-scenario outputs of issue 6 for `stepperdemo run`: files named after it."""

    vcd_dir: str | None = None
    csv_dir: str | None = None
    plot_dir: str | None = None
    timing_report: bool = False
    report_lines: list[str] = field(default_factory=list)
    vcd_timescale: str | None = None  # as --vcd-timescale gives it (None: the default)

    def wanted(self) -> bool:
        return bool(self.vcd_dir or self.csv_dir or self.plot_dir or self.timing_report)


def _tolerance(tol: dict, key: str, expected: float) -> float:
    """``tol[key]``, or ``tol[key + "_pct"]`` % of the expected value if that is more."""
    return max(tol.get(key, 0), abs(expected) * tol.get(key + "_pct", 0) / 100)


def run_scenario(sc: Scenario, *, watch: Watch | None = None) -> ScenarioResult:
    backend = SimBackend(sc.profile, record=True, build=sc.build)
    try:
        options = {} if sc.pin_config is None else {"pin_config": sc.pin_config}
        app = make_program(sc.program, backend, scripted=True, **options)
    except ValueError as exc:  # the profile cannot host the program
        return ScenarioResult(str(sc.path), sc.name, False, error=str(exc))
    obs = None
    if watch is not None and watch.wanted():
        from ..watch import observe

        def named(folder: str | None, suffix: str) -> str | None:
            return str(Path(folder) / f"{sc.name}{suffix}") if folder else None
        try:
            obs = observe.attach(backend, vcd=named(watch.vcd_dir, ".vcd"),
                                 csv=named(watch.csv_dir, ".csv"),
                                 analyse=bool(watch.csv_dir or watch.plot_dir
                                              or watch.timing_report),
                                 timescale=observe.vcd_unit(watch.vcd_timescale),
                                 extra_signals=app.trace_signals())
        except OSError as exc:  # (the folder was checked: a disk full, a name too long)
            return ScenarioResult(str(sc.path), sc.name, False, error=str(exc))
        app.watch(obs)
    t0 = time.perf_counter()
    reason = app.run_script(sc.input, firmware_end=(sc.end == "firmware"),
                            max_ticks=int(sc.max_time_s * backend.profile.ticks_per_s))
    wall = time.perf_counter() - t0
    res = ScenarioResult(str(sc.path), sc.name, True, end=reason.name.lower(),
                         sim_s=backend.now() / backend.profile.ticks_per_s, wall_s=wall,
                         long=sc.long)
    if reason == EndReason.MAX_TIME:
        res.checks.append(Check("end", "input consumed, all idle", "max time reached",
                                None, None, False))
    pins = {p.letter: p for p in stepper_pins(backend.profile)}
    for exp in sc.steppers:
        p = pins.get(exp.letter)
        if p is None:
            res.checks.append(Check(f"{exp.letter}", "a stepper", "profile has none",
                                    None, None, False))
            continue
        v, tol = exp.values, exp.tol
        if "position" in v:
            res.checks.append(_num_check(f"{exp.letter} position", v["position"],
                                         position_from_pins(backend, p.step, p.direction),
                                         _tolerance(tol, "position", v["position"])))
        step = pin_activity(backend, p.step)
        if "pulses" in v:
            res.checks.append(_num_check(f"{exp.letter} pulses", v["pulses"], step.rises,
                                         _tolerance(tol, "pulses", v["pulses"])))
        if "step_high_total_us" in v:
            if "step_high_total_us" in tol:  # absolute, as upstream's expect.txt states it
                total_tol = tol["step_high_total_us"]
            else:  # +1 us: the reference truncates its sum to whole microseconds
                total_tol = v["step_high_total_us"] * tol.get("step_high_total_pct", 0) / 100 + 1
            res.checks.append(_num_check(f"{exp.letter} pulse high total us",
                                         v["step_high_total_us"], int(step.high_total_us),
                                         total_tol))
        if "step_high_max_us" in v:  # "Max High": the longest pulse, whole us (%d)
            res.checks.append(_num_check(f"{exp.letter} pulse high max us",
                                         v["step_high_max_us"], int(step.high_max_us),
                                         tol.get("step_high_max_us", 0)))
        if "dir_transitions" in v:
            d = pin_activity(backend, p.direction)
            for name, e, m in (("rising", v["dir_transitions"][0], d.rises),
                               ("falling", v["dir_transitions"][1], d.falls)):
                res.checks.append(_num_check(f"{exp.letter} dir {name}", e, m, tol.get("dir", 0)))
        en = pin_activity(backend, p.enable) if (
            "enable_transitions" in v or "enable_high_max_us" in v) else None
        if "enable_transitions" in v:
            for name, e, m in (("rising", v["enable_transitions"][0], en.rises),
                               ("falling", v["enable_transitions"][1], en.falls)):
                res.checks.append(_num_check(f"{exp.letter} enable {name}", e, m,
                                             tol.get("enable", 0)))
        if "enable_high_max_us" in v:
            res.checks.append(_num_check(f"{exp.letter} enable off time us",
                                         v["enable_high_max_us"], int(en.high_max_us),
                                         tol.get("enable_high_us", 0)))
    if sc.outputs:
        res.checks.extend(_output_checks(sc, backend, app, pins))
    if sc.timing is not None and sc.reference is not None:
        for letter in sc.timing.steppers:
            ref, ref_dirs = read_reference_track(sc.reference / f"steps_{letter}.tsv.gz")
            ours = step_times_us(backend, pins[letter].step)
            cmp = compare_steps(ours, ref, sc.timing.align, ref_dirs)
            res.timing[letter] = _timing_dict(cmp)
            t = sc.timing
            if t.median_us is not None:
                res.checks.append(Check(f"{letter} step time median |dev| us", 0,
                                        round(cmp.median_abs_us, 3), cmp.median_abs_us,
                                        t.median_us, cmp.median_abs_us <= t.median_us))
            if t.max_us is not None:
                res.checks.append(Check(f"{letter} step time max |dev| us", 0,
                                        round(cmp.max_abs_us, 3), cmp.max_abs_us, t.max_us,
                                        cmp.max_abs_us <= t.max_us))
            if t.start_us is not None:
                res.checks.append(Check(f"{letter} move start |offset| us", 0,
                                        round(abs(cmp.offset_us), 3), abs(cmp.offset_us),
                                        t.start_us, abs(cmp.offset_us) <= t.start_us))
            if t.duration_ratio is not None:
                dev = cmp.duration_ratio - 1
                res.checks.append(Check(f"{letter} duration ratio", 1.0,
                                        round(cmp.duration_ratio, 6), dev, t.duration_ratio,
                                        abs(dev) <= t.duration_ratio))
    if sc.gaps is not None and sc.reference is not None:
        for letter in sc.gaps.steppers:
            res.checks.append(_gaps_check(letter, sc, backend, pins))
    transcript = app.transcript.decode("utf-8", "replace")
    for piece in sc.contains:
        res.checks.append(Check("transcript contains", piece, piece in transcript, None, None,
                                piece in transcript))
    for piece in sc.not_contains:
        res.checks.append(Check("transcript lacks", piece, piece not in transcript, None, None,
                                piece not in transcript))
    if sc.pcnt_sync is not None:
        motor, limit = sc.pcnt_sync
        problems = transcript_cmp.pcnt_sync_problems(transcript, motor, limit)
        res.checks.append(Check(f"{motor} position vs pulse counter", f"within {limit}",
                                problems[0] if problems else "in sync", None, limit,
                                not problems))
    if sc.transcript_ref is not None:
        diff = transcript_cmp.first_difference(transcript_cmp.ours_marked(app.transcript),
                                               transcript_cmp.read_reference(sc.transcript_ref))
        res.checks.append(Check("transcript matches reference", "same",
                                diff or "same", None, None, diff is None))
    _mark_known(sc, res)
    if obs is not None:
        from ..watch import plots, report

        obs.finish()
        if watch.plot_dir and plots.png_available():
            problem = plots.write_png_or_problem(
                plots.series_of(obs), str(Path(watch.plot_dir) / f"{sc.name}.png"),
                (1200, 800), title=plots.plot_title(f"{sc.name}: {sc.input}"),
                outputs=plots.outputs_of(obs))
            if problem is not None:
                res.error = problem
        if watch.timing_report:
            watch.report_lines.append(msg.RUN_TIMING_REPORT_HEAD.format(name=sc.name))
            watch.report_lines += report.report_lines(
                obs, positions=report.library_positions(app))
            watch.report_lines += app.watch_report()
    res.ok = res.error is None and all(c.ok for c in res.checks)
    return res


def _gaps_check(letter: str, sc: Scenario, backend: SimBackend, pins) -> Check:
    """The timer-wrap gaps of `e`, per window, ours against the reference's."""
    assert sc.gaps is not None and sc.reference is not None  # (the caller asks)
    ref, _ = read_reference_track(sc.reference / f"steps_{letter}.tsv.gz")
    theirs = gaps_per_window(wrap_gaps(ref))
    ours = gaps_per_window(wrap_gaps(step_times_us(backend, pins[letter].step)))
    keys = sorted(set(theirs) | set(ours))
    worst = max((abs(ours.get(k, 0) - theirs.get(k, 0)) for k in keys), default=0)
    fmt = " ".join
    return Check(f"{letter} gaps per window", fmt(str(theirs.get(k, 0)) for k in keys),
                 fmt(str(ours.get(k, 0)) for k in keys), worst, sc.gaps.per_window,
                 worst <= sc.gaps.per_window)


def _mark_known(sc: Scenario, res: ScenarioResult) -> None:
    """The file's known deviations: such a check is ok while it still fails (strict: the
    day it meets its tolerance the scenario fails, so that the entry is removed)."""
    for what, entry in sc.known_deviations.items():
        hits = [c for c in res.checks if c.what == what]
        if not hits:
            res.checks.append(Check(f"known deviation {what}", "a check of that name",
                                    "none", None, None, False))
        for c in hits:
            c.known, c.named = True, entry["measured"]
            c.ok = not c.ok


def known_summary(res: ScenarioResult) -> str:
    """One line per known deviation: what upstream/the firmware wants, what we measure."""
    return "; ".join(f"{c.what}: measured {_fmt(c.measured)} (file: {_fmt(c.named)}), "
                     f"expected {_fmt(c.expected)} +- {_fmt(c.tolerance)}"
                     for c in res.checks if c.known)


def _output_checks(sc: Scenario, backend: SimBackend, app, pins) -> list[Check]:
    """Expectations on the user outputs (issue 12), from the recorded pin edges."""
    from ..watch.outputs import OutputPin, OutputTrace

    tps = backend.profile.ticks_per_s
    backend.deliver_edges()  # PWM edges are made on demand
    outputs = getattr(getattr(app, "engine", None), "outputs", None)
    checks: list[Check] = []
    for exp in sc.outputs:
        analog, number = exp.name.startswith("Aout"), int(exp.name[-1])
        if outputs is not None:
            pin = (outputs.analog_pin if analog else outputs.digital_pin)(number)
        else:
            p = output_figures(backend.profile)
            pin = p.user_analog[number].pin if analog else p.user_digital_pins[number]
        times, levels = backend.recorder.pin_edges(pin)
        tr = OutputTrace(OutputPin(exp.name, pin, analog), 0)
        tr.edges(times, levels)
        tr.finish(backend.now())
        v, tol = exp.values, exp.tol
        figures = {"rises": tr.rises, "falls": tr.falls, "level": tr.level,
                   "periods": tr.periods,
                   "first_change_s": None if tr.first_edge is None else tr.first_edge / tps,
                   "frequency_hz": tps / tr.mean_period() if tr.periods else None,
                   "duty_percent": tr.last_duty, "duty_mean_percent": tr.mean_duty()}
        for key in ("rises", "falls", "level", "periods", "first_change_s", "frequency_hz",
                    "duty_percent", "duty_mean_percent"):
            if key not in v:
                continue
            measured = figures[key]
            what = f"{exp.name} {key.replace('_', ' ')}"
            if measured is None:
                checks.append(Check(what, v[key], "none", None, None, False))
            else:
                checks.append(_num_check(what, v[key], round(measured, 6), tol.get(key, 0)))
        if "duty_steps" in v:  # issue 24: every step of a sweep, its duty and its time
            checks.extend(_duty_step_checks(exp.name, v["duty_steps"], tol, times, levels,
                                            backend.now(), tps))
        if "first_change_after_step" in v:
            letter, step = v["first_change_after_step"]
            steps = backend.recorder.rising(pins[letter].step) if letter in pins else []
            first = tr.first_edge
            ok = (first is not None and (step == 0 or (step <= len(steps)
                                                        and steps[step - 1] < first))
                  and (step >= len(steps) or first < steps[step]))
            checks.append(Check(f"{exp.name} first change between steps {step} and "
                                f"{step + 1} of {letter}", "yes", "yes" if ok else "no",
                                None, None, ok))
    return checks


def _duty_step_checks(name: str, want: list, tol: dict, times, levels, end: int,
                      tps: int) -> list[Check]:
    """``duty_steps = [[duty %, seconds], ...]``: the PWM's steps of one duty, in order."""
    from ..watch.outputs import duty_steps

    got = duty_steps(times, levels, end)
    checks = [Check(f"{name} duty steps", len(want), len(got), None, None,
                    len(got) == len(want))]
    for i, ((duty, seconds), (g_duty, _n, g_ticks)) in enumerate(zip(want, got,
                                                                      strict=False)):
        checks.append(_num_check(f"{name} step {i + 1} duty %", duty, round(g_duty, 6),
                                 tol.get("duty_percent", 0)))
        checks.append(_num_check(f"{name} step {i + 1} seconds", seconds,
                                 round(g_ticks / tps, 6), tol.get("duty_steps", 0)))
    return checks


def _timing_dict(cmp: TimingComparison) -> dict:
    d = asdict(cmp)
    d["duration_ratio"] = cmp.duration_ratio
    return d


def run_file(path: Path, **kw) -> ScenarioResult:
    try:
        sc = load(path)
    except ScenarioError as exc:
        return ScenarioResult(str(path), path.stem, False, error=str(exc))
    return run_scenario(sc, **kw)


# ---------------------------------------------------------------- output
def _fmt(v: object) -> str:
    if isinstance(v, float):
        return f"{v:.3f}".rstrip("0").rstrip(".")
    return str(v)


DETAIL_COLUMNS = ("check", "expected", "measured", "dev", "tol", "")


def detail_rows(r: ScenarioResult, *, verbose: bool) -> list[list]:
    """One row per check shown: every check with ``verbose``, else the failed ones."""
    from rich.text import Text

    def verdict(c: Check) -> Text:
        if c.known:
            return (Text(msg.RUN_KNOWN, "yellow") if c.ok
                    else Text(msg.RUN_KNOWN_GONE, "bold red"))
        return Text("ok", "green") if c.ok else Text("FAIL", "bold red")

    return [[Text(c.what), Text(_fmt(c.expected)), Text(_fmt(c.measured)),
             "" if c.deviation is None else _fmt(c.deviation),
             "" if c.tolerance is None else _fmt(c.tolerance), verdict(c)]
            for c in r.checks if verbose or not c.ok or c.known]


def print_results(results: list[ScenarioResult], console, *, verbose: bool) -> None:
    """The results, made for an 80-column terminal: a summary with whole scenario
    names, then per scenario whose checks are shown (``-v``, or failed) a table of
    its checks with only the columns that have something to say."""
    from rich import box
    from rich.table import Table
    from rich.text import Text

    summary = Table(title=msg.RUN_TABLE_TITLE, box=box.SIMPLE_HEAD, pad_edge=False)
    summary.add_column("scenario", no_wrap=True)
    summary.add_column("checks", justify="right", no_wrap=True)
    summary.add_column("result", no_wrap=True)
    for r in results:
        if r.error:
            summary.add_row(Text(r.name), "", Text(msg.RUN_BROKEN, "red"))
            continue
        failed = sum(1 for c in r.checks if not c.ok)
        known = sum(1 for c in r.checks if c.known and c.ok)
        result = (Text(msg.RUN_FAILED_CHECKS.format(n=failed), "bold red") if failed else
                  Text(msg.RUN_OK_KNOWN.format(n=known), "yellow") if known else
                  Text("ok", "green"))
        summary.add_row(Text(r.name), str(len(r.checks)), result)
    console.print(summary)
    for r in results:
        if r.error:
            console.print(Text(f"{r.name}: {r.error}", "red"))
            continue
        rows = detail_rows(r, verbose=verbose)
        if not rows:
            continue
        keep = [i for i in range(len(DETAIL_COLUMNS))
                if i in (0, 5) or any(str(row[i]) for row in rows)]
        table = Table(title=Text(r.name, "bold"), title_justify="left", box=box.SIMPLE_HEAD,
                      pad_edge=False)
        for i in keep:
            table.add_column(DETAIL_COLUMNS[i], no_wrap=i == 5, overflow="fold",
                             justify="right" if i in (3, 4) else "left")
        for row in rows:
            table.add_row(*(row[i] for i in keep))
        console.print(table)


def print_report(results: list[ScenarioResult], console) -> None:
    from rich.table import Table
    from rich.text import Text

    table = Table(title=msg.RUN_REPORT_TITLE)
    for col in ("scenario", "stepper", "steps ours/ref", "median |dev| us", "max |dev| us",
                "duration ratio", "align"):
        table.add_column(col)
    for r in results:
        for letter, t in r.timing.items():
            table.add_row(Text(r.name), letter, f"{t['steps_ours']}/{t['steps_ref']}",
                          f"{t['median_abs_us']:.2f}", f"{t['max_abs_us']:.2f}",
                          f"{t['duration_ratio']:.6f}",
                          "first step" if t["offset_us"] else "absolute")
    console.print(table)


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="stepperdemo run", description=msg.RUN_DESCRIPTION)
    ap.add_argument("paths", nargs="+", help="scenario files or folders (searched for *.toml)")
    ap.add_argument("--json", action="store_true", help="machine-readable results on stdout")
    ap.add_argument("--report", action="store_true",
                    help="conformance report: per-step timing against the reference files")
    ap.add_argument("-v", "--verbose", action="store_true", help="show every check")
    ap.add_argument("-k", metavar="TEXT", help="only scenarios whose name contains TEXT")
    ap.add_argument("--skip-long", action="store_true", help="skip scenarios marked long")
    g = ap.add_argument_group("watching the runs (one file per scenario, named after it)")
    g.add_argument("--vcd", metavar="DIR", help="write <scenario>.vcd into DIR")
    g.add_argument("--vcd-timescale", metavar="UNIT",
                   help="the VCD files' time unit (default '1 us'; 'exact': every tick "
                        "exact, see stepperdemo --help)")
    g.add_argument("--steps-csv", metavar="DIR", help="write <scenario>.csv into DIR")
    g.add_argument("--plot", metavar="DIR", help="write <scenario>.png into DIR "
                   "(needs the 'plot' extra)")
    g.add_argument("--timing-report", action="store_true",
                   help="print the timing report of every scenario")
    from .board_runner import add_arguments as add_board_arguments
    add_board_arguments(ap)  # --board DEVICE ... (issue 15)
    return ap


def output_folder_problem(option: str, folder: str) -> str | None:
    """``run --vcd/--steps-csv/--plot DIR``: DIR is made if its parent folder exists
    (never a chain of folders: a typo in the path is said, not built); a DIR that
    cannot take files is a problem (a one-line text), else None."""
    path = Path(folder)
    try:
        if path.exists() and not path.is_dir():
            return msg.RUN_BAD_FOLDER.format(option=option, folder=folder,
                                             error=msg.RUN_NOT_A_FOLDER)
        if not path.is_dir():
            if not path.parent.is_dir():
                return msg.RUN_NO_FOLDER.format(option=option, folder=folder,
                                                parent=path.parent)
            path.mkdir()
    except OSError as exc:
        return msg.RUN_BAD_FOLDER.format(option=option, folder=folder,
                                         error=exc.strerror or exc)
    try:  # can a file be made there? (root passes every permission check: try it)
        with tempfile.TemporaryFile(dir=path):
            pass
    except OSError as exc:
        return msg.RUN_BAD_FOLDER.format(option=option, folder=folder,
                                         error=exc.strerror or exc)
    return None


REPORT_WIDTH_PIPED = 1000  # columns of the results when they go to a file or a pipe


def report_console(console_class):
    """A rich console for the results on stdout: on a terminal its width; written to
    a file or a pipe (where rich assumes 80 columns and squeezes the tables) wide
    enough for every table - unless COLUMNS says otherwise."""
    out = console_class(soft_wrap=False)
    if not out.is_terminal and not os.environ.get("COLUMNS"):
        out.width = REPORT_WIDTH_PIPED
    return out


def _pipe_aware_console():
    from rich.console import Console

    class PipeAware(Console):
        """A closed pipe (``| head``) ends the program the way the CLI handles it
        (quietly, exit 141) instead of rich's own exit code 1."""

        def on_broken_pipe(self) -> None:
            self.quiet = True
            raise BrokenPipeError

    return PipeAware


def main(argv: Sequence[str]) -> int:
    from rich.console import Console
    from rich.progress import Progress
    from rich.text import Text

    args = build_parser().parse_args(list(argv))
    PipeAwareConsole = _pipe_aware_console()
    files = collect(args.paths)
    missing = [f for f in files if not f.exists()]
    for f in missing:
        print(msg.RUN_NO_FILE.format(path=f), file=sys.stderr)
    files = [f for f in files if f.exists()]
    if not files:
        print(msg.RUN_NOTHING, file=sys.stderr)
        return EXIT_USAGE
    if args.board:  # issue 15: on a board running StepperDemo, with the twin check
        from .board_runner import main as board_main
        return board_main(args, files, bool(missing))
    watch = Watch(args.vcd, args.steps_csv, args.plot, args.timing_report,
                  vcd_timescale=args.vcd_timescale)
    if args.vcd_timescale is not None:
        from ..watch.options import is_vcd_unit
        if not is_vcd_unit(args.vcd_timescale):
            print(msg.CLI_ERROR.format(problem=msg.OBSERVE_BAD_TIMESCALE.format(
                timescale=args.vcd_timescale)), file=sys.stderr)
            return EXIT_USAGE
    if args.plot:
        from ..watch import plots
        if not plots.png_available():
            print(msg.PLOT_EXTRA_MISSING, file=sys.stderr)
            return EXIT_USAGE
    for option, folder in (("--vcd", args.vcd), ("--steps-csv", args.steps_csv),
                           ("--plot", args.plot)):
        problem = output_folder_problem(option, folder) if folder else None
        if problem is not None:
            print(msg.CLI_ERROR.format(problem=problem), file=sys.stderr)
            return EXIT_USAGE
    err = Console(stderr=True)
    out = report_console(PipeAwareConsole) if not args.json else None
    results: list[ScenarioResult] = []
    with Progress(console=err, transient=True, disable=args.json or not err.is_terminal) as bar:
        task = bar.add_task(msg.RUN_PROGRESS, total=len(files))
        for f in files:
            bar.update(task, description=f.stem)
            try:
                sc = load(f)
            except ScenarioError as exc:
                results.append(ScenarioResult(str(f), f.stem, False, error=str(exc)))
                bar.advance(task)
                continue
            if (args.k and args.k not in sc.name) or (args.skip_long and sc.long):
                bar.advance(task)
                continue
            results.append(run_scenario(sc, watch=watch))
            bar.advance(task)
    failed = [r for r in results if not r.ok]
    if args.json:
        json.dump([asdict(r) for r in results], sys.stdout, indent=1, default=str)
        sys.stdout.write("\n")
    else:
        print_results(results, out, verbose=args.verbose)
        if args.report:
            print_report(results, out)
        for line in watch.report_lines:
            out.print(Text(line))
        out.print(msg.RUN_SUMMARY.format(total=len(results), failed=len(failed)))
    return EXIT_FAILED if failed or missing else EXIT_OK
