"""StepperDemo's QuickStep commands (issue 14): planner choice in config mode, moves
that wait for FIFO room, and the additions to status lines and the stepper table.

Config mode, for the selected stepper: ``l0``/``l1`` planner, ``q<n>`` FIFO depth,
``p<n>`` plateaus, ``b<us>`` / ``b<us,t>`` base time (shared by all QuickStep
steppers: one timer serves them).  Depth and plateaus given while the stepper runs
FastAccelStepper's ramp are kept for its next ``l1``.  Every refusal is one
``ERROR ...`` line and changes nothing.

Normal mode: ``R``/``P`` queue a move behind what is queued.  When its orders do not
all fit, the console says so and holds further input (as ``W`` does) until the last
order is in the FIFO - QuickStep's blocking enqueue - while the loop goes on.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fas.codes import MoveResult
from fas.quickstep.clock import QsConfigResult
from fas.quickstep.orders import MAX_DEPTH, MIN_DEPTH
from fas.quickstep.planner import DEFAULT_DEPTH, DEFAULT_PLATEAUS, MAX_PLATEAUS
from fas.quickstep.setup import clock_of, quickstep_of
from fas.stepper import PLANNER_FAS, PLANNER_QUICKSTEP

from .. import messages as msg
from .command_table import CommandSet, Mode
from .parsing import parse_number, parse_values

if TYPE_CHECKING:  # pragma: no cover
    from fas.stepper import Stepper

    from .app import StepperDemo

#: the config commands l q p b (registered in .command_registry)
COMMANDS = CommandSet()


def _settings(app: StepperDemo) -> dict[str, int]:
    """Depth and plateaus the console keeps for the selected stepper."""
    store = app.__dict__.setdefault("qs_settings", {})
    return store.setdefault(app.selected, {"depth": DEFAULT_DEPTH,
                                            "plateaus": DEFAULT_PLATEAUS})


def base_text(app: StepperDemo) -> str:
    clock = clock_of(app.engine)
    if clock.base_us == 0:
        tb = clock.current
        if tb is None:
            return msg.QS_BASE_AUTO
        return msg.QS_BASE_AUTO + " " + msg.QS_BASE_US.format(
            us=f"{tb.base_ticks / app.profile.ticks_per_us:g}")
    return msg.QS_BASE_US.format(us=clock.base_us)


def _error(app: StepperDemo, res: QsConfigResult, *, value: int = 0, need_depth: int = 0,
           stepper: Stepper | None = None) -> None:
    p = app.profile
    clock = clock_of(app.engine)
    if res == QsConfigResult.NOT_AVAILABLE:
        app.print(msg.QS_ERR_NOT_AVAILABLE.format(profile=p.name))
    elif res == QsConfigResult.NO_SUCH_TIMER:
        app.print(msg.QS_ERR_NO_TIMER.format(
            timer=value, timers=", ".join(str(t.number) for t in clock.figures.timers)))
    elif res == QsConfigResult.DEPTH_OUT_OF_RANGE:
        app.print(msg.QS_ERR_DEPTH.format(value=value))
    elif res == QsConfigResult.PLATEAUS_OUT_OF_RANGE:
        app.print(msg.QS_ERR_PLATEAUS.format(value=value))
    elif res == QsConfigResult.RAM:
        qs = quickstep_of(stepper) if stepper is not None else None
        need = clock.ram_used(need_depth, without=qs)
        app.print(msg.QS_ERR_RAM.format(need=need, avail=clock.figures.ram_bytes, profile=p.name))
    elif res == QsConfigResult.RUNNING:
        app.print(msg.QS_ERR_RUNNING.format(n=app.selected + 1))
    elif res == QsConfigResult.TIMER_IN_USE:  # issue 12: a user PWM output has it
        app.print(msg.QS_ERR_TIMER_PWM.format(timer=clock.timer.number))


def _value(arg: bytes) -> int | None:
    if not arg:
        return None
    return parse_number(arg)


@COMMANDS.command("l", Mode.CONFIG, hint="planner: l0 FastAccelStepper ramp, l1 QuickStep",
                  arg="<0|1>")
def cmd_planner(app: StepperDemo, arg: bytes) -> bool:
    if arg not in (b"0", b"1"):
        app.print(msg.QS_ERR_SYNTAX.format(cmd="l" + arg.decode("latin-1"),
                                           what="l0 (ramp) or l1 (QuickStep)"))
        return True
    s = app.selected_stepper
    cfg = _settings(app)
    n = app.selected + 1
    if arg == b"0":
        res = s.set_planner(PLANNER_FAS)
        if res != QsConfigResult.OK:
            _error(app, res)
            return True
        app.print(msg.QS_PLANNER_FAS.format(n=n))
        return True
    res = s.set_planner(PLANNER_QUICKSTEP, cfg["depth"], cfg["plateaus"])
    if res != QsConfigResult.OK:
        _error(app, res, value=cfg["depth"], need_depth=cfg["depth"], stepper=s)
        return True
    clock = clock_of(app.engine)
    app.print(msg.QS_PLANNER_QS.format(n=n, depth=cfg["depth"], plateaus=cfg["plateaus"],
                                       base=base_text(app), timer=clock.timer.number))
    return True


@COMMANDS.command("q", Mode.CONFIG, hint="QuickStep FIFO depth 1..255", arg="<n>")
def cmd_depth(app: StepperDemo, arg: bytes) -> bool:
    value = _value(arg)
    if value is None:
        app.print(msg.QS_ERR_SYNTAX.format(cmd="q" + arg.decode("latin-1"),
                                           what="q<orders>, 1 .. 255"))
        return True
    s = app.selected_stepper
    clock = clock_of(app.engine)
    if not MIN_DEPTH <= value <= MAX_DEPTH:
        _error(app, QsConfigResult.DEPTH_OUT_OF_RANGE, value=value)
        return True
    if quickstep_of(s) is not None:
        res = s.set_planner(PLANNER_QUICKSTEP, value, None)
        if res != QsConfigResult.OK:
            _error(app, res, value=value, need_depth=value, stepper=s)
            return True
    elif clock.timer is None:
        _error(app, QsConfigResult.NOT_AVAILABLE)
        return True
    _settings(app)["depth"] = value
    app.print(msg.QS_DEPTH.format(n=app.selected + 1, depth=value, ram=clock.ram_used(),
                                  avail=clock.figures.ram_bytes))
    return True


@COMMANDS.command("p", Mode.CONFIG, hint="QuickStep plateaus 1..255", arg="<n>")
def cmd_plateaus(app: StepperDemo, arg: bytes) -> bool:
    value = _value(arg)
    if value is None:
        app.print(msg.QS_ERR_SYNTAX.format(cmd="p" + arg.decode("latin-1"),
                                           what="p<plateaus>, 1 .. 255"))
        return True
    s = app.selected_stepper
    if not 1 <= value <= MAX_PLATEAUS:
        _error(app, QsConfigResult.PLATEAUS_OUT_OF_RANGE, value=value)
        return True
    if quickstep_of(s) is not None:
        res = s.set_planner(PLANNER_QUICKSTEP, None, value)
        if res != QsConfigResult.OK:
            _error(app, res, value=value)
            return True
    elif clock_of(app.engine).timer is None:
        _error(app, QsConfigResult.NOT_AVAILABLE)
        return True
    _settings(app)["plateaus"] = value
    app.print(msg.QS_PLATEAUS.format(n=app.selected + 1, plateaus=value))
    return True


@COMMANDS.command("b", Mode.CONFIG, hint="QuickStep base time us (0 = auto), b<us,t> timer t",
                  arg="<us[,t]>")
def cmd_base(app: StepperDemo, arg: bytes) -> bool:
    values = parse_values(arg) if arg else None
    if values is None or len(values) > 2:
        app.print(msg.QS_ERR_SYNTAX.format(cmd="b" + arg.decode("latin-1"),
                                           what="b<us> or b<us,timer>, 0 = automatic"))
        return True
    clock = clock_of(app.engine)
    timer_number = values[1] if len(values) == 2 else None
    us = values[0]
    res = clock.check_base(us, timer_number)
    if res == QsConfigResult.BASE_OUT_OF_RANGE or (res == QsConfigResult.OK and us < 0):
        timer = clock.figures.timer(timer_number) if timer_number is not None else clock.timer
        lo, hi = clock.range_us(timer)
        app.print(msg.QS_ERR_BASE.format(us=us, timer=timer.number, lo=lo, hi=hi))
        return True
    if res == QsConfigResult.RUNNING:
        app.print(msg.QS_ERR_BUSY)
        return True
    if res != QsConfigResult.OK:
        _error(app, res, value=timer_number or 0)
        return True
    clock.set_base(us, timer_number)
    lo, hi = clock.range_us()
    app.print(msg.QS_BASE_SET.format(base=base_text(app), timer=clock.timer.number,
                                     bits=clock.timer.bits, lo=lo, hi=hi))
    return True


# ------------------------------------------------------------------ normal mode
def move(s, delta: int, absolute: bool) -> MoveResult:
    """R/P: FastAccelStepper's move, or QuickStep's that may leave orders pending."""
    qs = quickstep_of(s)
    if qs is None:
        return s.move_to(delta) if absolute else s.move(delta)
    if absolute:
        return qs.move(delta - qs.target_pos(), wait=None)
    return qs.start_move(delta)


def after_move(app: StepperDemo) -> None:
    """A move that waits for FIFO room holds the input (and says so)."""
    s = app.selected_stepper
    qs = quickstep_of(s)
    if qs is not None and qs.pending_orders():
        app.qs_hold = s
        app.print(msg.QS_HOLD.format(n=app.selected + 1, pending=qs.pending_orders()))


def service_hold(app: StepperDemo) -> bool:
    """One loop pass: push waiting orders; True while the input stays held."""
    s = app.qs_hold
    if s is None:
        return False
    qs = quickstep_of(s)
    if qs is None:
        app.qs_hold = None
        return False
    qs.pump()
    if qs.pending_orders():
        return True
    app.qs_hold = None
    app.print(msg.QS_RELEASED)
    return False


def status_suffix(s: Stepper) -> str:
    qs = quickstep_of(s)
    if qs is None:
        return ""
    return msg.QS_STATUS.format(label=qs.plateau_label() or "-")


def table_suffix(app: StepperDemo, s: Stepper) -> str:
    qs = quickstep_of(s)
    if qs is None:
        return ""
    clock = clock_of(app.engine)
    tb = clock.current
    if clock.base_us:
        base = f"{clock.base_us}us"
    elif tb is not None:
        base = f"{tb.base_ticks / app.profile.ticks_per_us:g}us(auto)"
    else:
        base = "auto"
    return msg.QS_TABLE.format(used=qs.queue.queue_entries(), depth=qs.depth,
                               plateaus=qs.plateaus, base=base)
