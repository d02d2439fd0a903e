"""The scenario corpus with build d's ATmega328P figures changed: the landing rule's
corpus check for build d's figures (docs/timing-model.md, "thirty-third pass").

    python3 bench/d_corpus.py --variant FIT --variant D33 [--set FIELD=VALUE ...] \\
        sequences/conformance sequences/upstream sequences/gcode sequences/examples

A setting is ``FIELD=VALUE`` (or ``FIELD=+N`` / ``-N``; a tuple's figures separated by
commas) of :class:`fas.sim.timing.SimTiming` or StepperDemo's
:class:`stepperdemo.demo.build.DemoBuild`; it reaches build d's ATmega328P (the default
build's AVR figures, and its time-measurement build of upstream's timing tests;
``tm.FIELD=VALUE`` that build's table alone); the scenario files then run as
``python3 -m stepperdemo run FILES...`` runs them (its exit status).  Since the fortieth
pass, build d's figures read from its replica (D33 P30 L34 W34 C37 P39 T39) are the
default, since the fiftieth six of the eight of the forty-second to forty-seventh
passes (R47 S42 P43 L43 N44 F44) as well: those variants set what is already set; K43
and T44 (the ramp task's own sections) stay off (they cost the G-code run 11 % and 6 %
of its instructions, issue 25; docs/timing-model.md, fiftieth pass).  ``FIT`` (first)
goes back to the figures fitted before the fortieth pass, ``PRE49`` to the eight's
before the fiftieth (all off), to look at a reading alone.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))

from fas.sim import timing as sim_timing_module  # noqa: E402
from stepperdemo.demo import build as demo_build_module  # noqa: E402
from stepperdemo.front.cli import main as stepperdemo_main  # noqa: E402

# the setting that puts back build d's 328P figures fitted before the fortieth pass
# (build d; the variant FIT); a variant after it reads them piece by piece again
FITTED = "build_d=fitted"

# build d's figures read from its replica, by pass (the default since the fortieth pass
# (build d): on the default each is a no-op, after FIT it reads its piece alone).  Every
# setting is absolute: none adds to what is set, so none applies twice
VARIANTS: dict[str, list[str]] = {
    "FIT": [FITTED],
    # build d's ramp task read from its replica and both its phases (fas.sim.timing's
    # BUILD_D_REPLICA_TASK and BUILD_D_REPLICA_PHASES; the task's phase is the fitted one
    # plus the difference read)
    "D33": [f"{k}={v}" for k, v in sim_timing_module.BUILD_D_REPLICA_TASK.items()],
    "P30": [f"{k}={sim_timing_module.AVR_TIMING.task_phase_ticks + v}"
            if k == "task_phase_ticks" else f"{k}={v}"
            for k, v in sim_timing_module.BUILD_D_REPLICA_PHASES.items()],
    # build d's commands' CPU to their first print, read from its replica (StepperDemo's
    # BUILD_D_REPLICA_COMMANDS)
    "L34": [f"cmd_ticks.{k}={v}" for k, v in demo_build_module.BUILD_D_REPLICA_COMMANDS.items()],
    # ... and their tails after the print (BUILD_D_REPLICA_COMMAND_TAILS; superseded by T39)
    "T34": [f"cmd_tail_ticks.{k}={v}"
            for k, v in demo_build_module.BUILD_D_REPLICA_COMMAND_TAILS.items()],
    # ... and the pass that ends a `w<ms>` before its message (BUILD_D_REPLICA_PAUSE_END_TICKS)
    "W34": [f"pause_end_ticks={demo_build_module.BUILD_D_REPLICA_PAUSE_END_TICKS}"],
    # ... and `H` / `X` given while a stepper runs (BUILD_D_REPLICA_RUNNING_TAILS;
    # superseded by T39)
    "T37": [f"cmd_tail_ticks.{k}={v}"
            for k, v in demo_build_module.BUILD_D_REPLICA_RUNNING_TAILS.items()],
    # a coast is a command planned without a conversion (SimTiming.fill_coast_unconverted;
    # docs/timing-model.md, thirty-seventh pass)
    "C37": ["fill_coast_unconverted=1"],
    # a print's body from a buffer, read from the replica (StepperDemo's
    # BUILD_D_REPLICA_PRINT_BODY; docs/timing-model.md, thirty-ninth pass)
    "P39": [f"{k}={v}" for k, v in demo_build_module.BUILD_D_REPLICA_PRINT_BODY.items()],
    # ... and the tails read again under it (T34 and T37 in one; BUILD_D_REPLICA_TAILS_P39)
    "T39": [f"cmd_tail_ticks.{k}={v}"
            for k, v in demo_build_module.BUILD_D_REPLICA_TAILS_P39.items()],
    # the UART transmitter as the simulator has it (SimTiming.uart_tx_single_register:
    # one register, no shift register; 63 places in the ring) with the banner's first
    # character and the ramp task's phase read again under it (docs/timing-model.md,
    # forty-second pass): StepperDemo's setup() to its banner 1 461 ticks (every
    # character of the replica's start-up then to the tick), the task 257 ticks earlier
    # after engine.init() (the transmit interrupts no longer one character early)
    "U42": ["uart_tx_single_register=1", "uart_tx_buffer=63", "setup_head_ticks=1461",
            f"task_phase_ticks={sim_timing_module.AVR_D_328P_TIMING.task_phase_ticks - 257}"],
    # auto enable's enableOutputs() in a command's write charged to the ramp task
    # (SimTiming.fill_enable_ticks; forty-second pass)
    "E42": ["fill_enable_ticks=311"],
    # a held W's every pass while a stepper runs and the pass's CPU before a status line
    # (StepperDemo's DemoBuild.w_every_pass, status_lead_ticks; forty-second pass; the
    # default since the fiftieth, as P43 L43 N44 F44 R47 below: no-ops on the default;
    # K43 and T44 are not)
    "S42": ["w_every_pass=1",
            f"status_lead_ticks={demo_build_module.BUILD_D_REPLICA_STATUS_LEAD_TICKS}"],
    # build d's plain step pulse read from its replica (60 / 70 ticks; with
    # SIMAVR_TIME_MEASUREMENT 62 / 72: fas.sim.timing's BUILD_D_REPLICA_PLAIN_PULSE_TICKS;
    # forty-third pass)
    "P43": ["isr_latency_ticks=" + ",".join(
                map(str, sim_timing_module.BUILD_D_REPLICA_PLAIN_PULSE_TICKS)),
            "tm.isr_latency_ticks=" + ",".join(
                map(str, sim_timing_module.BUILD_D_TM_REPLICA_PLAIN_PULSE_TICKS))],
    # the loop's sections (the replica's figures measured with them, and the loop's
    # polls), each pass of a held W under S42 with them (DemoBuild.w_pass_millis_before_end;
    # forty-third pass)
    "L43": ["loop_section_widths=1", "loop_sections=1", "w_pass_millis_before_end="
            f"{demo_build_module.BUILD_D_REPLICA_W_PASS_MILLIS_BEFORE_END}"],
    # build d's ramp task's own sections per command, read from d02's replica
    # (BUILD_D_REPLICA_CMD_MASK_SECTIONS; forty-third pass)
    "K43": ["fill_cmd_mask_sections=" + ",".join(
        f"{b}:{t}" for b, t in sim_timing_module.BUILD_D_REPLICA_CMD_MASK_SECTIONS)],
    # a command to a stepper without a direction pin (`u`) skips the library's direction
    # checks (SimTiming.fill_no_dir_pin_saved_ticks; forty-fourth pass)
    "N44": ["fill_no_dir_pin_saved_ticks=" + ",".join(
        map(str, sim_timing_module.BUILD_D_REPLICA_NO_DIR_PIN_SAVED_TICKS))],
    # the ramp task's two sections before its exit (SimTiming.fill_tail_mask_ticks;
    # forty-fourth pass)
    "T44": ["fill_tail_mask_ticks=" + ",".join(
        map(str, sim_timing_module.BUILD_D_REPLICA_TAIL_MASK_TICKS))],
    # a continuous run's commands cost less than a move's
    # (SimTiming.fill_continuous_saved_ticks; forty-fourth pass)
    "F44": ["fill_continuous_saved_ticks=" + ",".join(
        map(str, sim_timing_module.BUILD_D_REPLICA_CONTINUOUS_SAVED_TICKS))],
    # timer 0's overflows (and a running stepper's step interrupts) nested in the ramp
    # task move its writes and queue starts as the UART's do (SimTiming.task_nested_isrs;
    # bench/replica/start_steps.py, forty-fifth pass)
    "I45": ["task_nested_isrs=2"],
    # ... in the tasks that run while no stepper runs only (the start tasks;
    # SimTiming.start_task_nested_isrs)
    "J45": ["start_task_nested_isrs=1"],
    # a start whose fill wrote the ramp's last command costs more before its first step
    # (SimTiming.fill_start_ramp_end_ticks; forty-fifth pass; build d's default since,
    # absolute: changes nothing on the default)
    "E45": [f"fill_start_ramp_end_ticks={sim_timing_module.BUILD_D_REPLICA_START_RAMP_END_TICKS}"],
    # a start's first write costs its enableOutputs() only where the outputs are off
    # (SimTiming.fill_first_write_enable_ticks; forty-fifth pass)
    "O45": ["fill_first_write_enable_ticks="
            f"{sim_timing_module.BUILD_D_REPLICA_FIRST_WRITE_ENABLE_TICKS}"],
    # the ramp config's update() with linear acceleration (`J`: s_h > 0) charged before
    # the command it planned (SimTiming.fill_cubic_update_ticks; forty-sixth pass)
    "H46": [f"fill_cubic_update_ticks={sim_timing_module.BUILD_D_REPLICA_CUBIC_UPDATE_TICKS}"],
    # a start's jump (`j`: calculate_ticks(s_jump), and calculate_ramp_steps() where it
    # is clipped) charged before its first command (SimTiming.fill_jump_start_ticks)
    "Q46": ["fill_jump_start_ticks=" + ",".join(
        str(v) for v in sim_timing_module.BUILD_D_REPLICA_JUMP_START_TICKS)],
    # a starting ramp's commands by the branches their planning took (the coast check's
    # multiplication, a coast without calculate_ticks(), ...: the pitch;
    # SimTiming.fill_start_pitch_ticks; forty-seventh pass; the default since the
    # fiftieth)
    "R47": ["fill_start_pitch_ticks=" + ",".join(
        str(v) for v in sim_timing_module.BUILD_D_REPLICA_START_PITCH_TICKS)],
}
# the variants that make build d's default (fortieth pass; E45 since the forty-fifth,
# H46 and Q46 since the forty-sixth; six of the eight of the forty-second to
# forty-seventh passes since the fiftieth: all but the ramp task's sections, K43 and T44)
DEFAULT_READ = ["D33", "P30", "L34", "W34", "C37", "P39", "T39", "E45", "H46", "Q46"]
EIGHT = ["R47", "S42", "P43", "K43", "L43", "N44", "F44", "T44"]
SIX = [v for v in EIGHT if v not in ("K43", "T44")]
DEFAULT_READ += SIX
# the eight's figures as they were before the fiftieth pass (all off, the plain pulse
# fitted): the variant PRE49, to look at the default without them, or one of them alone
# (``--variant PRE49 --variant N44``)
VARIANTS["PRE49"] = [
    "fill_start_pitch_ticks=", "w_every_pass=0", "status_lead_ticks=0",
    "isr_latency_ticks=" + ",".join(map(str, sim_timing_module.AVR_TIMING.isr_latency_ticks)),
    "tm.isr_latency_ticks=" + ",".join(
        map(str, sim_timing_module.TIME_MEASUREMENT_STEP_ISR["isr_latency_ticks"])),
    "fill_cmd_mask_sections=", "loop_section_widths=0", "loop_sections=0",
    "w_pass_millis_before_end=0", "fill_no_dir_pin_saved_ticks=",
    "fill_continuous_saved_ticks=", "fill_tail_mask_ticks="]


def set_fitted() -> None:
    """Build d's ATmega328P figures as fitted before the fortieth pass, for this
    process."""
    sim_timing_module.BY_FAMILY["avr"] = sim_timing_module.AVR_TIMING
    sim_timing_module.BY_BUILD["d_time_measurement"]["atmega328p"] = dataclasses.replace(
        sim_timing_module.AVR_TIMING, **sim_timing_module.TIME_MEASUREMENT_STEP_ISR)
    demo_build_module.BY_PROFILE["atmega328p"] = demo_build_module.ATMEGA328P_FITTED_BUILD


def set_build_d(settings: list[str]) -> None:
    """Change build d's ATmega328P figures for this process.  Raises ValueError on an
    unknown field or a value that is not a number."""
    t_fields = {f.name for f in dataclasses.fields(sim_timing_module.SimTiming)}
    d_fields = {f.name for f in dataclasses.fields(demo_build_module.DemoBuild)}
    for setting in settings:
        if setting == FITTED:
            set_fitted()
            continue
        name, sep, value = setting.partition("=")
        tm_only = name.startswith("tm.")  # the time-measurement build's table alone
        if tm_only:
            name = name[3:]
        table_name, dot, letter = name.partition(".")
        if sep and dot and table_name in ("cmd_ticks", "cmd_tail_ticks") and len(letter) == 1:
            _set_cmd_ticks(setting, table_name, letter, value)
            continue
        if not sep or name not in t_fields | d_fields:
            raise ValueError(f"--set {setting!r}: not FIELD=VALUE with a SimTiming or "
                             "DemoBuild field")
        if tm_only and name not in t_fields:
            raise ValueError(f"--set {setting!r}: tm. takes a SimTiming field")
        places = ([(sim_timing_module.BY_BUILD["d_time_measurement"], "atmega328p")]
                  if tm_only else
                  [(sim_timing_module.BY_FAMILY, "avr"),
                   (sim_timing_module.BY_BUILD["d_time_measurement"], "atmega328p")]
                  if name in t_fields else [(demo_build_module.BY_PROFILE, "atmega328p")])
        for table, key in places:
            current = getattr(table[key], name)
            if isinstance(current, bool):
                new: object = value.lower() in ("1", "true", "yes")
            elif isinstance(current, tuple):
                try:  # figures, or pairs BEFORE:TICKS (fill_cmd_mask_sections); none: off
                    new = tuple(tuple(int(x) for x in v.split(":")) if ":" in v else int(v)
                                for v in value.split(",")) if value else ()
                except ValueError:
                    raise ValueError(f"--set {setting!r}: {value!r} is not numbers "
                                     "separated by commas") from None
            elif not isinstance(current, int):
                raise ValueError(f"--set {setting!r}: {name} is not a number")
            else:
                try:
                    new = current + int(value) if value[:1] in "+-" else int(value)
                except ValueError:
                    raise ValueError(f"--set {setting!r}: {value!r} is not a number") from None
            table[key] = dataclasses.replace(table[key], **{name: new})


def _set_cmd_ticks(setting: str, table_name: str, letter: str, value: str) -> None:
    """``cmd_ticks.<letter>=VALUE`` / ``cmd_tail_ticks.<letter>=VALUE`` (or ``+N`` / ``-N``):
    one command's cost in build d's ATmega328P StepperDemo (cmd_ticks' default:
    ``cmd_default_ticks``; cmd_tail_ticks': 0)."""
    build = demo_build_module.BY_PROFILE["atmega328p"]
    table: dict[str, int] = getattr(build, table_name)
    current = table.get(letter, build.cmd_default_ticks if table_name == "cmd_ticks" else 0)
    try:
        new = current + int(value) if value[:1] in "+-" else int(value)
    except ValueError:
        raise ValueError(f"--set {setting!r}: {value!r} is not a number") from None
    demo_build_module.BY_PROFILE["atmega328p"] = dataclasses.replace(
        build, **{table_name: {**table, letter: new}})


def set_build_d_from_args(args: argparse.Namespace, prog: str) -> bool:
    """Build d's figures from a tool's ``--variant`` and ``--set`` options (shared by
    this tool and the replica tools); a bad setting is one line on stderr and False."""
    try:
        set_build_d([s for v in args.variant for s in VARIANTS[v]] + args.set)
    except ValueError as exc:
        print(f"{prog}: {exc}", file=sys.stderr)
        return False
    return True


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--variant", action="append", default=[], choices=sorted(VARIANTS),
                    help="a named set of --set; repeatable")
    ap.add_argument("--set", action="append", default=[], metavar="FIELD=VALUE",
                    help="a figure of build d's ATmega328P; repeatable")
    ap.add_argument("-v", "--verbose", action="store_true",
                    help="every check of every file (the runner's -v)")
    ap.add_argument("paths", nargs="+", help="scenario files or folders")
    args = ap.parse_args(argv)
    if not set_build_d_from_args(args, "d_corpus"):
        return 2
    return stepperdemo_main(["run", *(["-v"] if args.verbose else []), *args.paths])


if __name__ == "__main__":
    sys.exit(main())
