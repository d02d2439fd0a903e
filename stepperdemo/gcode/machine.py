"""The G-code machine: Grbl 1.1's controller on the ``fas`` library, byte by byte.

Shared by the ``stepperdemo gcode`` program (file, console, the ``--pty``/``--tcp``
endpoint) and StepperDemo's ``g`` mode.  It owns no clock: its host hands it the
bytes a sender sent (:meth:`GcodeMachine.receive`, at the tick they arrive), calls
:meth:`GcodeMachine.poll` whenever time has passed and sleeps until
:meth:`GcodeMachine.wake_tick`.  Everything it prints goes to ``write`` a line at a
time (the host adds the line end).

Grbl's structure, kept because senders depend on it:

* **Receive path** (:mod:`.grbl_rx`): real-time bytes act on arrival, wherever they
  are in a line; the rest goes into the 128-byte ring; lines are assembled from it
  only while the parser is free.
* **One line at a time.**  A line is parsed into actions (:mod:`.interp`) and
  executed in order; it is answered ``ok`` when its last action is done - a move
  when the block queue (15 blocks) had room for it, a synchronized output (M62, M63,
  M67) when it has changed after all motion before it, a dwell (G4) when it has
  passed after all motion before it, G92/M2 when the motion before them is done.
  Until then no further line is read (the parser is "held", as in Grbl_ESP32), so
  an immediate output (M64, M65, M68) can never overtake an earlier synchronized one.
* **States** Idle, Run, Hold:0/1, Jog, Alarm, Check, Door:0/2, Sleep; feed hold,
  resume, jog cancel and overrides go to the motion executor (:mod:`.motion`).
* **Answers**: ``ok``; ``error:N`` and ``ALARM:N`` with Grbl's numbers
  (:mod:`.codes`), the reason in a ``[MSG:...]`` line before them.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable

from fas.codes import PIN_UNDEFINED, AqeResult
from fas.output_figures import output_figures
from fas.outputs import OutputResult
from fas.pwm import PwmSetting, count_percent, duty_count, frequency_range
from fas.quickstep.setup import quickstep_of

from .. import messages as msg
from . import dollar as dollar_commands
from . import reports
from .codes import Alarm, Err
from .grbl_rx import (
    DOOR,
    FEED_100,
    FEED_MINUS_1,
    FEED_MINUS_10,
    FEED_PLUS_1,
    FEED_PLUS_10,
    FLOOD_TOGGLE,
    HOLD,
    JOG_CANCEL,
    MIST_TOGGLE,
    RAPID_25,
    RAPID_50,
    RAPID_100,
    RESET,
    RESUME,
    SPINDLE_100,
    SPINDLE_MINUS_1,
    SPINDLE_MINUS_10,
    SPINDLE_PLUS_1,
    SPINDLE_PLUS_10,
    STATUS,
    GrblReceiver,
    RxLine,
)
from .interp import (
    Action,
    Dwell,
    End,
    Interpreter,
    Move,
    Pause,
    Probe,
    SetCoolant,
    SetOffset,
    SetOutput,
    SetSpindle,
)
from .motion import BlockQueue, HoldState, MotionExecutor, make_executor, wanted_kind
from .parser import AXES, GcodeError, parse_line
from .probe import ProbeCycle
from .settings import KEEP_ENABLED, GcodeSettings
from .tooling import Tooling

OVERRIDE_MIN, OVERRIDE_MAX = 10, 200  # feed and spindle override, percent
_FEED_STEPS = {FEED_PLUS_10: 10, FEED_MINUS_10: -10, FEED_PLUS_1: 1, FEED_MINUS_1: -1}
_SPINDLE_STEPS = {SPINDLE_PLUS_10: 10, SPINDLE_MINUS_10: -10, SPINDLE_PLUS_1: 1,
                  SPINDLE_MINUS_1: -1}
_RAPID = {RAPID_100: 100, RAPID_50: 50, RAPID_25: 25}


class LineRun:
    """A line in execution: its actions, done in order; answered after the last."""

    __slots__ = ("text", "actions", "index", "echo", "handed", "dwell_until", "dwell_left")

    def __init__(self, text: str, actions: list[Action], echo: bool = False) -> None:
        self.text = text
        self.actions = actions
        self.index = 0
        self.echo = echo  # a startup line: answered '>LINE:ok'
        self.handed = False  # the synchronized output of the current action is with fas
        self.dwell_until: int | None = None
        self.dwell_left: int | None = None  # a dwell paused by a feed hold


class GcodeMachine:
    """Grbl's controller on the library's steppers (see the module text)."""

    def __init__(self, engine, steppers: list, write: Callable[[str], None],
                 settings: GcodeSettings | None = None, *, identity: str = "") -> None:
        self.engine = engine
        self.backend = engine.backend
        self.steppers = steppers
        self.axes = len(steppers)
        self.write = write
        self.settings = settings or GcodeSettings()
        self.identity = identity or f"stepperdemo {msg.VERSION} {self.backend.profile.name}"
        self.rx = GrblReceiver()
        self.blocks = BlockQueue()
        self.executor: MotionExecutor = make_executor(self, self.blocks)
        self.interp = Interpreter(self.axes, self.settings, check=self._check)
        self.tooling = Tooling(self)  # spindle/laser and coolant outputs (issue 25)
        self.executor.set_speed_listener(self.tooling.on_speed, lasers_only=True)  # laser mode
        self.probe = ProbeCycle(self, self.tooling.map.probe)  # G38.x (issue 25)
        self.schedule = reports.ReportSchedule()
        self.alarm: int | None = None
        self.check_mode = False
        self.sleeping = False
        self.hold = False  # a feed hold (or M0) is in effect
        self.paused = False  # ... made by M0
        self.door = False
        self.jog_cancel = False
        self.pending: LineRun | None = None
        self.startup_queue: deque[str] = deque()
        self.feed_override = self.rapid_override = self.spindle_override = 100
        self.wco: tuple[float, ...] = (0.0,) * self.axes
        self.drivers_on = False
        self.idle_since: int | None = None
        #: a host's own lines (StepperDemo's ``x``): called with the filtered line,
        #: True when it took it
        self.intercept: Callable[[str], bool] | None = None
        self.input_held = False  # the host reads no more lines (leaving the g mode)
        self.lines = 0
        self.errors = 0
        self.alarms = 0
        self.resets = 0
        self.ends = 0
        self.last_error = ""
        outputs = engine.outputs
        self._output_defaults = ([outputs.digital_pin(n) for n in range(4)],
                                 [outputs.analog_pin(n) for n in range(4)],
                                 [outputs.frequency_hz(n) for n in range(4)])
        self.interp.sync_position(self.positions())

    # ----------------------------------------------------------------- facts
    def positions(self) -> list[int]:
        return [s.get_current_position() for s in self.steppers]

    def machine_position(self) -> list[float]:
        return [p / self.settings.steps_per_unit[i] for i, p in enumerate(self.positions())]

    @property
    def queue(self) -> BlockQueue:
        return self.blocks

    @property
    def motion_log(self) -> list[tuple[int, int]]:
        """(start tick, lead ticks) of every run of the executor."""
        return getattr(self.executor, "runs", [])

    def jogging(self) -> bool:
        cur = self.executor.current()
        if cur is not None and cur.jog:
            return True
        if self.blocks.jogs_pushed:  # (none ever pushed: none queued - asked before every line)
            for b in self.blocks.items:
                if b.jog:
                    return True
        if self.pending is not None:
            for a in self.pending.actions:
                if isinstance(a, Move) and a.jog:
                    return True
        return False

    def state_name(self) -> str:
        if self.sleeping:
            return "Sleep"
        if self.alarm is not None:
            return "Alarm"
        held = self.executor.hold_state() == HoldState.HELD
        if self.door:
            return "Door:0" if held else "Door:2"
        if self.jog_cancel:
            return "Jog"
        if self.hold:
            return "Hold:0" if held else "Hold:1"
        if self.jogging():
            return "Jog"
        if self.check_mode:
            return "Check"
        if self.executor.busy():
            return "Run"
        return "Idle"

    def idle(self) -> bool:
        """Nothing to do: no line in execution or waiting, nothing moving or queued."""
        return (self.pending is None and not self.executor.busy()
                and (self.input_held or not self.rx.ring) and not self.startup_queue
                and not self.engine.sync.active() and not self.executor.moving())

    def can_take_line(self) -> bool:
        """Would the parser read a line now (a file is fed a line at a time)?"""
        return self.pending is None and self._reading() and not self.rx.ring

    def can_read(self) -> bool:
        """Would the parser read a line now (not held, no line in execution)?"""
        return self.pending is None and self._reading()

    def _reading(self) -> bool:
        return not (self.hold or self.door or self.sleeping or self.jog_cancel
                    or self.input_held)

    # ----------------------------------------------------------------- input
    def receive(self, data: bytes) -> None:
        """Bytes from the host, arriving now: real-time commands act at once (one
        status report for any number of ``?`` among them), the rest is buffered."""
        reported = False
        for byte in self.rx.receive(data):
            if byte == STATUS:
                if not reported:
                    self.write(reports.status_report(self))
                    reported = True
            else:
                self.realtime(byte)

    def realtime(self, byte: int) -> None:
        """One real-time command (Grbl 1.1's table)."""
        if byte == STATUS:
            self.write(reports.status_report(self))
        elif byte == RESET:
            self.soft_reset()
        elif byte == HOLD:
            self.feed_hold()
        elif byte == RESUME:
            self.cycle_start()
        elif byte == DOOR:
            self.safety_door()
        elif byte == JOG_CANCEL:
            if self.state_name() == "Jog" and not self.jog_cancel:
                self._cancel_jog()
        elif byte == FEED_100 or byte in _FEED_STEPS:
            value = 100 if byte == FEED_100 else self.feed_override + _FEED_STEPS[byte]
            self._set_overrides(feed=min(OVERRIDE_MAX, max(OVERRIDE_MIN, value)))
        elif byte in _RAPID:
            self._set_overrides(rapid=_RAPID[byte])
        elif byte == SPINDLE_100 or byte in _SPINDLE_STEPS:
            value = 100 if byte == SPINDLE_100 else (self.spindle_override
                                                      + _SPINDLE_STEPS[byte])
            self._set_overrides(spindle=min(OVERRIDE_MAX, max(OVERRIDE_MIN, value)))
        elif byte in (FLOOD_TOGGLE, MIST_TOGGLE):
            self._toggle_coolant(byte == MIST_TOGGLE)
        # 0x9E spindle stop (only in a hold, for a door's parking): not here

    def _toggle_coolant(self, mist: bool) -> None:
        """0xA0 / 0xA1: flood / mist coolant toggled at once (Idle, Run, Hold), the
        modal state with it (as Grbl)."""
        if self.state_name().split(":")[0] not in ("Idle", "Run", "Hold"):
            return
        it = self.interp
        if mist:
            it.mist = not it.mist
        else:
            it.flood = not it.flood
        self.tooling.set_coolant(it.mist, it.flood)

    def feed_hold(self) -> None:
        """``!``: decelerate along the path and stop (Hold:1 -> Hold:0); a jog is
        cancelled instead."""
        state = self.state_name()
        if state == "Jog":
            if not self.jog_cancel:
                self._cancel_jog()
            return
        if state not in ("Idle", "Run"):
            return
        self.hold = True
        self.executor.hold()
        self._pause_dwell()

    def cycle_start(self) -> None:
        """``~``: resume from Hold:0 or Door:0 (a ``~`` while still decelerating is
        lost, as in Grbl)."""
        if not (self.hold or self.door) or self.executor.hold_state() != HoldState.HELD:
            return
        self.hold = self.paused = self.door = False
        self.executor.resume()
        run = self.pending
        if run is not None and run.dwell_left is not None:
            run.dwell_until = self.backend.now() + run.dwell_left
            run.dwell_left = None

    def safety_door(self) -> None:
        """0x84: as a feed hold, until ``~`` (this machine has no door switch: the door
        reads closed once the motion has stopped)."""
        state = self.state_name()
        if state not in ("Idle", "Run", "Jog") and not state.startswith("Hold"):
            return
        self.write(msg.GRBL_CHECK_DOOR)
        if state == "Jog":
            self._cancel_jog()
        else:
            self.executor.hold()
            self._pause_dwell()
        self.hold = self.paused = False
        self.door = True

    def _pause_dwell(self) -> None:
        run = self.pending
        if run is not None and run.dwell_until is not None:
            run.dwell_left = max(0, run.dwell_until - self.backend.now())
            run.dwell_until = None

    def _cancel_jog(self) -> None:
        self.jog_cancel = True
        self.executor.hold()

    def _finish_jog_cancel(self) -> None:
        """The jog has stopped: drop the rest of it and every jog queued after it."""
        self.jog_cancel = False
        self.executor.discard()
        self.blocks.clear()
        self.executor.resume()
        if self.pending is not None and any(isinstance(a, Move) and a.jog
                                            for a in self.pending.actions):
            self.pending = None  # a jog line waiting for room: flushed with the rest
            self.write(msg.GCODE_OK)
        self.interp.sync_position(self.positions())
        if self.door:  # the door came during the jog: resuming means Idle
            self.executor.hold()

    def _set_overrides(self, feed: int | None = None, rapid: int | None = None,
                       spindle: int | None = None) -> None:
        old = (self.feed_override, self.rapid_override, self.spindle_override)
        self.feed_override = old[0] if feed is None else feed
        self.rapid_override = old[1] if rapid is None else rapid
        self.spindle_override = old[2] if spindle is None else spindle
        if (self.feed_override, self.rapid_override, self.spindle_override) != old:
            self.schedule.overrides_changed()
            self.executor.set_overrides(self.feed_override, self.rapid_override)
            if self.spindle_override != old[2]:
                self.tooling.override_changed()

    # ----------------------------------------------------------------- lines
    def poll(self) -> None:
        """Everything that is due now: motion, the line in execution, new lines."""
        now = self.backend.now()
        if not self.blocks.items:  # (with blocks queued the executor is busy: kept)
            self._pick_executor()
        self.executor.poll()
        self.tooling.poll(now)
        if (self.hold or self.door) and self.executor.hold_state() == HoldState.HELD:
            self.tooling.hold_off()  # laser mode: no laser while held (Grbl)
        if self.jog_cancel and self.executor.hold_state() == HoldState.HELD:
            self._finish_jog_cancel()
        rx = self.rx
        blocks = self.blocks
        while True:
            run = self.pending
            if run is not None:
                # (_advance's commonest wait first: the line's next action a move and
                # no room for it in the block queue - nothing to do, nothing changes)
                if (len(blocks.items) == blocks.size and run.index < len(run.actions)
                        and isinstance(run.actions[run.index], Move)
                        and not self.check_mode):
                    break
                if not self._advance(run, now):
                    break
                self.pending = None
            if (self.hold or self.door or self.sleeping or self.jog_cancel
                    or self.input_held):  # (not _reading())
                break
            if self.startup_queue:
                self._startup(self.startup_queue.popleft())
                continue
            if not rx.ring:  # (take_line() would find nothing: no line, nothing to assemble)
                break
            line = rx.take_line()
            if line is None:
                break
            self._line(line, now)
        self._idle_drivers(now)

    def _pick_executor(self) -> None:
        """``$171`` (or the steppers) asks for the other executor: changed while
        nothing is queued, moving or held."""
        ex = self.executor
        if (ex.busy() or ex.moving() or ex.hold_state() != HoldState.NONE
                or getattr(ex, "kind", "") == wanted_kind(self)):
            return
        self.executor = make_executor(self, self.blocks)
        self.executor.set_overrides(self.feed_override, self.rapid_override)
        self.executor.set_speed_listener(self.tooling.on_speed, lasers_only=True)  # laser mode

    def line(self, text: str) -> None:
        """A whole line as if received (tests, ``--set``): fed through the receive path."""
        self.receive(text.encode("utf-8", "replace") + b"\n")
        self.poll()

    def _line(self, line: RxLine, now: int) -> None:
        self.lines += 1
        text = line.text
        try:
            if line.overflow:
                raise GcodeError(Err.OVERFLOW, msg.GCODE_ERR_LONG.format(n=self.rx.line_max))
            if self.intercept is not None and self.intercept(text):
                return
            if text == "":
                self.write(msg.GCODE_OK)
                return
            if text[0] == "$":
                outcome = dollar_commands.dollar(self, text)
                if isinstance(outcome, list):
                    self._begin(LineRun(text, outcome), now)
                    return
                self.write(msg.GCODE_OK)
                if outcome is not None:
                    outcome()
                return
            self._begin(LineRun(text, self._gcode(text, filtered=True)), now)
        except GcodeError as exc:
            self._refuse(exc)

    def _gcode(self, text: str, filtered: bool = False) -> list[Action]:
        if not self.sleeping:  # (state_name()'s Alarm and Jog, without the rest)
            if self.alarm is not None:
                raise GcodeError(Err.SYSTEM_GC_LOCK, msg.GCODE_ERR_ALARM)
            if not self.door and (self.jog_cancel or (not self.hold and self.jogging())):
                raise GcodeError(Err.SYSTEM_GC_LOCK, msg.GCODE_ERR_JOGGING)
        return self.interp.interpret(parse_line(text, filtered))

    def check_line(self, text: str) -> None:
        """Raise the error a G-code line would get, changing nothing (``$Nx=``)."""
        saved = self.interp.snapshot()
        try:
            if text.startswith("$"):
                raise GcodeError(Err.INVALID_STATEMENT, msg.GCODE_ERR_STARTUP_DOLLAR)
            self.interp.interpret(parse_line(text))
        finally:
            self.interp.restore(saved)

    def _startup(self, text: str) -> None:
        """A ``$N`` line after a reset, answered ``>LINE:ok`` (not counted as an ack)."""
        try:
            self._begin(LineRun(text, self._gcode(text), echo=True), self.backend.now())
        except GcodeError as exc:
            self._refuse(exc, echo=text)

    def _begin(self, run: LineRun, now: int) -> None:
        self.pending = run
        if self._advance(run, now):
            self.pending = None

    def _advance(self, run: LineRun, now: int) -> bool:
        """Do what is due of the line's actions; True when it is answered."""
        if self.hold or self.door or self.sleeping:
            return False  # a hold holds the line being executed too
        try:
            while run.index < len(run.actions):
                if not self._execute(run.actions[run.index], run, now):
                    return False
                run.index += 1
                run.handed = False
        except GcodeError as exc:
            self._refuse(exc, echo=run.text if run.echo else None)
            return True
        self.write(f">{run.text}:{msg.GCODE_OK}" if run.echo else msg.GCODE_OK)
        return True

    def _execute(self, action: Action, run: LineRun, now: int) -> bool:
        """One action; False while it waits (for queue room, the motion before it, time)."""
        ex = self.executor
        if self.check_mode:  # parsed and answered; only the parser's state moves on
            if isinstance(action, SetOffset):
                self._apply_offset(action)
            elif isinstance(action, End):
                self._program_end(action, outputs=False)
            return True
        if isinstance(action, Move):
            blocks = self.blocks
            if len(blocks.items) == blocks.size:  # (no room)
                return False
            blocks.push(action)
            self.idle_since = None
            ex.poll()
            return True
        if isinstance(action, SetOutput):
            if not action.synchronized:
                self._output(action)
                return True
            if not run.handed:
                if not ex.committed():
                    return False  # the motion before it is not all in the queues yet
                self._output(action)  # the library makes it when the queues run dry
                run.handed = True
            return not self.engine.sync.active()
        if isinstance(action, Probe):
            return self.probe.execute(action)
        if isinstance(action, Dwell):
            if run.dwell_until is None and run.dwell_left is None:
                if ex.busy() or ex.moving():
                    return False
                run.dwell_until = now + int(action.seconds * self.backend.profile.ticks_per_s)
            return run.dwell_until is not None and now >= run.dwell_until
        if ex.busy() or ex.moving():  # G92, M0, M2, M3..M9: after the motion before them
            return False
        if isinstance(action, SetOffset):
            self._apply_offset(action)
        elif isinstance(action, SetSpindle):
            self.tooling.poll(now)  # the laser's last changes first
            self.tooling.set_spindle(action.state, action.speed)
        elif isinstance(action, SetCoolant):
            self.tooling.set_coolant(action.mist, action.flood)
        elif isinstance(action, Pause):
            self.hold = self.paused = True
            ex.hold()
        elif isinstance(action, End):
            self.tooling.poll(now)
            self._program_end(action)
        return True

    def _apply_offset(self, action: SetOffset | End) -> None:
        if action.offset and action.offset != self.wco:
            self.wco = action.offset
            self.schedule.offsets_changed()

    def _program_end(self, action: End, outputs: bool = True) -> None:
        """M2/M30: G54's offset, spindle and coolant off (Grbl), overrides at 100 %."""
        self._apply_offset(action)
        if outputs:
            self.tooling.all_off()
        self.ends += 1
        self._set_overrides(100, 100, 100)
        self.write(msg.GRBL_PGM_END)

    def _refuse(self, exc: GcodeError, echo: str | None = None) -> None:
        self.errors += 1
        self.last_error = str(exc)
        if str(exc):
            self.write(msg.GRBL_MSG.format(text=exc))
        if echo is not None:
            self.write(f">{echo}:" + msg.GRBL_ERROR.format(code=exc.code))
        else:
            self.write(msg.GRBL_ERROR.format(code=exc.code))

    # ------------------------------------------------------------- checks
    def _check(self, action: Action) -> None:
        """Refuse a block before it changes anything (called by the interpreter)."""
        if isinstance(action, Move):  # (the common case; a Move is no Probe or SetOutput)
            self._check_directions(action)
            return
        if isinstance(action, Probe):
            if not self.probe.available():
                raise GcodeError(Err.UNSUPPORTED_COMMAND, msg.GCODE_ERR_NO_PROBE.format(
                    code=f"G{action.code:g}", profile=self.backend.profile.name))
            self._check_directions(action.move)
        if isinstance(action, SetOutput):
            outputs = self.engine.outputs
            name = f"{'Aout' if action.analog else 'Dout'}{action.number}"
            pin = (outputs.analog_pin if action.analog else outputs.digital_pin)(action.number)
            if pin == PIN_UNDEFINED:
                raise GcodeError(Err.PARAMETER_OUT_OF_RANGE, msg.GCODE_ERR_NO_OUTPUT_PIN.format(
                    name=name, profile=self.backend.profile.name,
                    setting=(160 if action.analog else 150) + action.number))
            used = outputs.pin_user(pin)
            if used is not None and used != name:
                raise GcodeError(Err.PARAMETER_OUT_OF_RANGE, msg.GCODE_ERR_OUTPUT_PIN_USED.format(
                    name=name, pin=pin, user=used))

    def _check_directions(self, move: Move) -> None:
        """Two axes of one move on one direction pin must go the same way (and every
        moving axis must use FastAccelStepper's queue, not QuickStep's FIFO)."""
        seen: dict[int, tuple[int, bool]] = {}
        target, start = move.target, move.start
        steppers = self.steppers
        for i in range(len(target)):  # (one per axis: target and start alike)
            t, s = target[i], start[i]
            if t == s:
                continue
            stepper = steppers[i]
            if quickstep_of(stepper) is not None:
                raise GcodeError(Err.INVALID_TARGET,
                                 msg.GCODE_ERR_QUICKSTEP_AXIS.format(letter=AXES[i]))
            pin = stepper.get_direction_pin()
            if pin == PIN_UNDEFINED:
                if t < s:
                    raise GcodeError(Err.INVALID_TARGET,
                                     msg.GCODE_ERR_NO_DIR_PIN.format(letter=AXES[i]))
                continue
            level = (t > s) == stepper.direction_pin_high_counts_up()
            other = seen.get(pin)
            if other is not None and other[1] != level:
                raise GcodeError(Err.INVALID_TARGET, msg.GCODE_ERR_SHARED_DIR.format(
                    a=AXES[other[0]], b=AXES[i], pin=pin))
            seen[pin] = (i, level)

    # ------------------------------------------------------------ outputs
    def _output(self, action: SetOutput) -> None:
        outputs = self.engine.outputs
        if action.analog:
            res = outputs.analog(action.number, action.value, action.synchronized)
        else:
            res = outputs.digital(action.number, bool(action.value), action.synchronized)
        if res != OutputResult.OK:
            raise GcodeError(Err.PARAMETER_OUT_OF_RANGE,
                             self.output_problem(res, action.analog, action.number))
        if action.analog:
            self._report_duty(action)

    def _report_duty(self, action: SetOutput) -> None:
        """M67/M68: the duty the timer really makes (the nearest count)."""
        setting = self.engine.outputs.frequency_setting(action.number)
        if not isinstance(setting, PwmSetting):  # pragma: no cover - checked before
            return
        count = duty_count(setting.counts, action.value)
        self.write(msg.GCODE_DUTY.format(
            number=action.number, duty=count_percent(count, setting.counts), count=count,
            counts=setting.counts, hz=setting.frequency_hz))

    def output_problem(self, res: OutputResult, analog: bool, number: int,
                       hz: float | None = None, pin: int | None = None) -> str:
        outputs = self.engine.outputs
        name = f"{'Aout' if analog else 'Dout'}{number}"
        if pin is None:
            pin = (outputs.analog_pin if analog else outputs.digital_pin)(number)
        profile = self.backend.profile
        if res == OutputResult.ERR_NO_PIN:
            return msg.GCODE_ERR_NO_OUTPUT_PIN.format(name=name, profile=profile.name,
                                                      setting=(160 if analog else 150) + number)
        if res == OutputResult.ERR_PIN_IN_USE:
            return msg.GCODE_ERR_OUTPUT_PIN_USED.format(name=name, pin=pin,
                                                        user=outputs.pin_user(pin))
        if res == OutputResult.ERR_NOT_PWM_PIN:
            return msg.GCODE_ERR_NOT_PWM_PIN.format(pin=pin, profile=profile.name)
        if res == OutputResult.ERR_FREQUENCY:
            timer = output_figures(profile).pwm_timer(outputs.timer_name(number) or "")
            low, high = frequency_range(timer) if timer else (0, 0)
            return msg.GCODE_ERR_FREQUENCY.format(
                timer=timer.name if timer else "?", hz=f"{hz:g}" if hz is not None else "?",
                low=f"{low:.4g}", high=f"{high:.4g}")
        if res == OutputResult.ERR_BUSY:
            return msg.GCODE_ERR_OUTPUT_BUSY.format(name=name)
        if res == OutputResult.ERR_TIMER_IN_USE:
            return msg.GCODE_ERR_TIMER_QUICKSTEP.format(name=name, timer=outputs.timer_name(number))
        return msg.GCODE_ERR_OUTPUT.format(name=name, code=res.name)

    def restore_settings(self, startup: bool) -> None:
        """``$RST=$`` / ``$RST=*``: the settings and the output pins as at the start."""
        dollar_commands.restore_defaults(self.settings, startup)
        outputs = self.engine.outputs
        digital, analog, hz = self._output_defaults
        for n in range(4):
            outputs.set_digital_pin(n, digital[n])
            outputs.set_analog_pin(n, analog[n])
            outputs.set_frequency(n, hz[n])
        self.interp.sync_position(self.positions())

    # ------------------------------------------------------------ drivers
    def enable_drivers(self) -> None:
        """Before a block starts (the executor asks)."""
        if not self.drivers_on:
            for s in self.steppers:
                s.set_auto_enable(False)
                s.enable_outputs()
            self.drivers_on = True
        self.idle_since = None

    def _disable_drivers(self) -> None:
        for s in self.steppers:
            s.disable_outputs()
        self.drivers_on = False
        self.idle_since = None

    def _idle_drivers(self, now: int) -> None:
        delay = self.settings.idle_delay_ms
        if not self.drivers_on or delay == KEEP_ENABLED or self.executor.moving() or (
                self.executor.busy() and not self.hold and not self.door):
            self.idle_since = None
            return
        if self.idle_since is None:
            self.idle_since = now
        if now - self.idle_since >= delay * self.backend.profile.ticks_per_ms:
            self._disable_drivers()

    def wake_tick(self) -> int | None:
        """When :meth:`poll` next has something to do (None: only input)."""
        b = self.backend
        now = b.now()
        # the earliest of the times below (None: none); written without a list - the
        # loop asks after every periodic task
        ex = self.executor
        wake = ex.wake_tick()
        run = self.pending
        if run is not None and not (self.hold or self.door):
            if run.dwell_until is not None and (wake is None or run.dwell_until < wake):
                wake = run.dwell_until
            if run.handed or self.engine.sync.active():
                nxt = b.next_event_time()
                t = now + b.profile.fill_period_ticks if nxt is None else nxt
                if wake is None or t < wake:
                    wake = t
        if self.jog_cancel and ex.hold_state() == HoldState.HELD:
            wake = now if wake is None or now < wake else wake
        laser = self.tooling.wake_tick()
        if laser is not None and (wake is None or laser < wake):
            wake = laser
        if run is None and (self.rx.ring or self.startup_queue) and self._reading():
            wake = now if wake is None or now < wake else wake
        if self.drivers_on and self.settings.idle_delay_ms != KEEP_ENABLED:
            if self.idle_since is not None:
                t = self.idle_since + self.settings.idle_delay_ms * b.profile.ticks_per_ms
                if wake is None or t < wake:
                    wake = t
            elif not (ex.moving() or (ex.busy() and not self.hold and not self.door)):
                wake = now if wake is None or now < wake else wake  # (_idle_drivers)
        if wake is None:
            return None
        return wake if wake > now else now

    # ------------------------------------------------------- stop and reset
    def _clear(self) -> None:
        """Forget every line and block not yet done (the motion is stopped already)."""
        self.blocks.clear()
        self.rx.reset()
        self.pending = None
        self.startup_queue.clear()
        self.hold = self.paused = self.door = self.jog_cancel = False
        self.interp.sync_position(self.positions())

    def _raise_alarm(self, code: int, reason: str) -> None:
        self.alarm = code
        self.alarms += 1
        self.write(msg.GRBL_MSG.format(text=reason))
        self.write(msg.GRBL_ALARM.format(code=code))

    def abort(self) -> None:
        """The console's Ctrl-C (an emergency stop): every axis stops at once, the
        queue and the synchronized outputs not yet made are dropped, the outputs keep
        their state; ALARM:3 (locked until ``$X``) when anything was under way."""
        busy = self.executor.busy() or self.executor.moving() or self.pending is not None
        self.probe.cancel()
        self.executor.abort()
        self.engine.outputs.cancel_pending()
        self.tooling.all_off()  # Grbl's mc_reset: spindle and coolant stop
        self._clear()
        if busy:
            self._raise_alarm(Alarm.ABORT_CYCLE, msg.GRBL_ABORTED)
        elif self.sleeping:  # as a reset would: awake, in alarm (position not trusted)
            self.sleeping = False
            self.alarm = self.alarm or Alarm.ABORT_CYCLE
            self.write(msg.GRBL_UNLOCK_HINT)

    def motion_failed(self, result: AqeResult) -> None:
        """The library refused a queue command (a limit not checked): every axis stops,
        ALARM:3 (the position is not trusted) until ``$X``."""
        self.probe.cancel()
        self.executor.abort()
        self.engine.outputs.cancel_pending()
        self.tooling.all_off()
        self._clear()
        self._raise_alarm(Alarm.ABORT_CYCLE, msg.GCODE_MOTION_FAILED.format(code=result.name))

    def probe_alarm(self, code: int, reason: str) -> None:
        """A probe cycle failed (ALARM:4 touching at the start, ALARM:5 no contact):
        every axis at rest, the queue and the lines waiting dropped, locked until $X."""
        self.probe.cancel()
        self.executor.abort()
        self.blocks.clear()
        self.interp.sync_position(self.positions())
        self._raise_alarm(code, reason)

    def unlock(self) -> None:
        self.alarm = None
        self.write(msg.GRBL_UNLOCKED)

    def sleep(self) -> None:
        """``$SLP`` (after its ``ok``): drivers off; only a reset leaves (into Alarm)."""
        self._disable_drivers()
        self.sleeping = True
        self.write(msg.GRBL_SLEEPING)

    def soft_reset(self) -> None:
        """Ctrl-X: stop at once (ALARM:3 if anything was moving - the position is lost),
        every output off, everything received and queued dropped, the parser and the
        overrides as at power-on; the machine position is kept."""
        moving = self.executor.moving() or self.executor.hold_state() == HoldState.STOPPING
        self.probe.cancel()
        self.executor.abort()
        self.engine.outputs.reset()
        self.tooling.forget()
        self._clear()
        self._reset_state()
        if self.sleeping:
            self.sleeping = False
            self.alarm = self.alarm or Alarm.ABORT_CYCLE  # position not trusted after sleep
        if moving:
            self._raise_alarm(Alarm.ABORT_CYCLE, msg.GRBL_RESET_MOVING)
        self._banner()

    def power_on(self) -> None:
        """A host opened the port (an Arduino's DTR reset): as at power-on - stopped,
        outputs off, machine position 0, drivers off; settings and ``$N`` lines kept."""
        self.probe.cancel()
        self.executor.abort()
        self.engine.outputs.reset()
        self.tooling.forget()
        for s in self.steppers:
            s.force_stop_and_new_position(0)
        if self.drivers_on:
            self._disable_drivers()
        self._clear()
        self._reset_state()
        self.sleeping = False
        self.alarm = None
        self._banner()

    def _reset_state(self) -> None:
        self.interp.reset()
        self.interp.sync_position(self.positions())
        self.wco = (0.0,) * self.axes
        self.check_mode = False
        self.feed_override = self.rapid_override = self.spindle_override = 100
        self.executor.set_overrides(100, 100)
        self.schedule.reset()
        self.resets += 1

    def _banner(self) -> None:
        self.write("")
        self.write(msg.GCODE_BANNER)
        if self.alarm is not None:
            self.write(msg.GRBL_UNLOCK_HINT)
        else:
            self.startup_queue.extend(line for line in self.settings.startup if line)
