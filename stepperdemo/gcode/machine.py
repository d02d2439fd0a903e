"""The G-code machine: lines in, ``ok``/``error:`` out, blocks executed in order.

Shared by the ``stepperdemo gcode`` program and StepperDemo's ``g`` mode.  It owns
no clock: its host calls :meth:`GcodeMachine.line` for every complete input line,
:meth:`GcodeMachine.poll` whenever time has passed, and sleeps until
:meth:`GcodeMachine.wake_tick`.

* Every line is answered when it is taken: ``ok`` (parsed and queued) or
  ``error: <reason>`` (nothing of it happens; the program goes on - Grbl's
  convention, so that a sender streaming a file sees every mistake and decides).
  Lines are taken only while the block queue has room (16 blocks, as Grbl's
  planner): a sender waiting for ``ok`` before each line, or counting characters,
  streams without overrunning it.
* The block queue runs in order: a move starts when the previous move has finished
  and every synchronized output before it has changed; a synchronized output (M62,
  M63, M67) is handed to the library once the move before it is completely queued
  (the library makes it when the steppers stop - :mod:`fas.sync`); a dwell (G4)
  starts when everything before it is done.  Immediate outputs (M64, M65, M68)
  happen when their line is taken.
* A move is a straight line (:mod:`.line`): its axes start on the same tick, stay on
  the line and make their last steps on the same tick; every move starts and ends
  at rest (exact stop).
* An abort (the console's Ctrl-C) stops every stepper at once, drops the queue and
  the synchronized outputs not yet made, leaves the outputs as they are and locks
  the machine (ALARM) until ``$X``.  Ctrl-X (soft reset) stops the same way,
  switches every output off and resets the modal state.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable, Iterator

from fas.codes import PIN_UNDEFINED, AqeResult
from fas.output_figures import output_figures
from fas.outputs import OutputResult
from fas.pwm import PwmSetting, count_percent, duty_count, frequency_range
from fas.quickstep.setup import quickstep_of

from .. import messages as msg
from .interp import Action, Dwell, End, Interpreter, Move, SetOutput
from .line import Limits, StepTimes, axis_commands, line_profile
from .parser import AXES, GcodeError, parse_line, strip_comments
from .settings import (
    KEEP_ENABLED,
    SETTING_HELP,
    GcodeSettings,
    axis_setting,
    output_setting,
)

QUEUE_BLOCKS = 16  # blocks waiting (Grbl's planner buffer)
RESET = 0x18  # Ctrl-X
STATUS = "?"


class AxisFeed:
    """The queue commands of one axis of a move, fed into its stepper's queue."""

    def __init__(self, stepper, commands: Iterator[tuple[int, int, bool]]) -> None:
        self.stepper = stepper
        self.commands = commands
        self.next: tuple[int, int, bool] | None = next(commands, None)
        self.entries = 0

    @property
    def fed(self) -> bool:
        return self.next is None

    def feed(self, start: bool) -> AqeResult | None:
        """Add commands while the queue has room; the first error (None: all fine)."""
        s = self.stepper
        while self.next is not None and not s.is_queue_full():
            ticks, steps, up = self.next
            res = s.add_queue_entry(ticks, steps, up, start=start)
            if res != AqeResult.OK:
                return None if res.retry else res
            self.entries += 1
            self.next = next(self.commands, None)
        return None


class MotionRun:
    """One move in execution: per moving axis its commands and how far they are fed."""

    def __init__(self, machine: GcodeMachine, move: Move) -> None:
        self.move = move
        backend = machine.backend
        profile = backend.profile
        tps = profile.ticks_per_s
        settings = machine.settings
        deltas = [t - s for t, s in zip(move.target, move.start, strict=True)]
        steppers = machine.steppers
        rates, accels = [], []
        for i in range(len(deltas)):
            spu = settings.steps_per_unit[i]
            top = tps / (steppers[i].get_max_speed_in_ticks() + 1)
            rates.append(min(settings.max_rate[i] * spu / 60, top))
            accels.append(settings.acceleration[i] * spu)
        path_speed = None
        if not move.rapid:
            length = math.sqrt(sum((d / settings.steps_per_unit[i]) ** 2
                                   for i, d in enumerate(deltas)))
            path_speed = move.feed / 60 / length
        self.profile = line_profile(deltas, rates, accels, path_speed)
        lead = profile.min_cmd_ticks
        if not machine.drivers_on:
            lead = max([lead] + [steppers[i].get_delay_to_enable_ticks()
                                 for i, d in enumerate(deltas) if d])
        for i, d in enumerate(deltas):
            if d:
                lead = max(lead, steppers[i].get_dir_change_delay_ticks())
        self.lead_ticks = lead
        limits_of = machine.limits
        # the last step of every axis is followed by the same wait: the queues run dry
        # together (it must suit the slowest stepper's top speed)
        tail = max([profile.min_cmd_ticks] + [steppers[i].get_max_speed_in_ticks()
                                              for i, d in enumerate(deltas) if d])
        self.axes = [
            AxisFeed(steppers[i], axis_commands(StepTimes(self.profile, abs(d), lead, tps),
                                                d > 0, tail, limits_of(i)))
            for i, d in enumerate(deltas) if d]
        self.started = False
        self.start_tick: int | None = None
        self.error: AqeResult | None = None

    def begin(self) -> None:
        """Fill every queue, then start them all on one tick."""
        for axis in self.axes:
            # after a force stop the queue ignores commands until a new motion is planned
            # (the ramp generator clears this; raw commands must do it themselves)
            axis.stepper.queue.ignore_commands = False
            err = axis.feed(start=False)
            self.error = self.error or err
        for axis in self.axes:
            axis.stepper.add_queue_entry(None, start=True)
        self.started = True

    def feed(self) -> None:
        for axis in self.axes:
            if not axis.fed:
                err = axis.feed(start=True)
                self.error = self.error or err

    @property
    def fed(self) -> bool:
        return self.error is not None or all(a.fed for a in self.axes)

    def done(self) -> bool:
        return self.fed and not any(a.stepper.is_running() for a in self.axes)


class GcodeMachine:
    """Interpreter, block queue and motion of the G-code program (see module text)."""

    def __init__(self, engine, steppers: list, write: Callable[[str], None],
                 settings: GcodeSettings | None = None) -> None:
        self.engine = engine
        self.backend = engine.backend
        self.steppers = steppers
        self.axes = len(steppers)
        self.write = write
        self.settings = settings or GcodeSettings()
        self.interp = Interpreter(self.axes, self.settings, check=self._check)
        self.queue: deque[Action] = deque()
        self.motion: MotionRun | None = None
        self.dwell_until: int | None = None
        self.alarm = False
        self.drivers_on = False
        self.idle_since: int | None = None
        self.lines = 0
        self.errors = 0
        self.moves = 0
        self.ends = 0
        self.last_error = ""
        self.motion_log: list[tuple[int, int]] = []  # (start tick, lead ticks) per move
        self.interp.sync_position(self._positions())

    # ----------------------------------------------------------- facts
    def limits(self, axis: int) -> Limits:
        p = self.backend.profile
        return Limits(p.ticks_per_s, p.min_cmd_ticks,
                      self.steppers[axis].get_max_speed_in_ticks(),
                      max(2 * p.min_cmd_ticks, p.ticks_per_s // 500))

    def _positions(self) -> list[int]:
        return [s.get_current_position() for s in self.steppers]

    def idle(self) -> bool:
        """Nothing queued, moving, dwelling or waiting for an output."""
        return (not self.queue and self.motion is None and self.dwell_until is None
                and not self.engine.sync.active())

    def can_take_line(self) -> bool:
        return len(self.queue) < QUEUE_BLOCKS

    def state_name(self) -> str:
        if self.alarm:
            return "Alarm"
        return "Idle" if self.idle() else "Run"

    # ----------------------------------------------------------- input
    def realtime(self, ch: str) -> bool:
        """A real-time character (handled on arrival, not a line); True if it was one."""
        if ch == STATUS:
            self.write(self.status_report())
            return True
        if ord(ch) == RESET:
            self.soft_reset()
            return True
        return False

    def line(self, text: str) -> None:
        """One complete input line: answered ``ok`` or ``error: <reason>``."""
        self.lines += 1
        stripped = text.strip()
        try:
            if stripped.startswith("$"):
                self._dollar(strip_comments(stripped).strip())
            else:
                block = parse_line(text)
                if self.alarm and not block.empty:
                    raise GcodeError(msg.GCODE_ERR_ALARM)
                for action in self.interp.interpret(block):
                    self._accept(action)
        except GcodeError as exc:
            self.errors += 1
            self.last_error = str(exc)
            self.write(msg.GCODE_ERROR.format(reason=exc))
            return
        self.write(msg.GCODE_OK)

    def _accept(self, action: Action) -> None:
        if isinstance(action, SetOutput) and not action.synchronized:
            self._output(action)  # M64/M65/M68: at once
            return
        if isinstance(action, SetOutput):
            self._report_duty(action)
        self.queue.append(action)
        self.idle_since = None

    def _check(self, action: Action) -> None:
        """Refuse a block before it changes anything (called by the interpreter)."""
        if isinstance(action, SetOutput):
            outputs = self.engine.outputs
            name = f"{'Aout' if action.analog else 'Dout'}{action.number}"
            pin = (outputs.analog_pin if action.analog else outputs.digital_pin)(action.number)
            if pin == PIN_UNDEFINED:
                raise GcodeError(msg.GCODE_ERR_NO_OUTPUT_PIN.format(
                    name=name, profile=self.backend.profile.name,
                    setting=(160 if action.analog else 150) + action.number))
            used = outputs.pin_user(pin)
            if used is not None and used != name:
                raise GcodeError(msg.GCODE_ERR_OUTPUT_PIN_USED.format(name=name, pin=pin,
                                                                     user=used))
        elif isinstance(action, Move):
            self._check_directions(action)

    def _check_directions(self, move: Move) -> None:
        """Two axes of one move on one direction pin must go the same way (and every
        moving axis must use FastAccelStepper's queue, not QuickStep's FIFO)."""
        seen: dict[int, tuple[int, bool]] = {}
        for i, (t, s) in enumerate(zip(move.target, move.start, strict=True)):
            if t == s:
                continue
            stepper = self.steppers[i]
            if quickstep_of(stepper) is not None:
                raise GcodeError(msg.GCODE_ERR_QUICKSTEP_AXIS.format(letter=AXES[i]))
            pin = stepper.get_direction_pin()
            if pin == PIN_UNDEFINED:
                if t < s:
                    raise GcodeError(msg.GCODE_ERR_NO_DIR_PIN.format(letter=AXES[i]))
                continue
            level = (t > s) == stepper.direction_pin_high_counts_up()
            other = seen.get(pin)
            if other is not None and other[1] != level:
                raise GcodeError(msg.GCODE_ERR_SHARED_DIR.format(
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
            raise GcodeError(self._output_problem(res, action.analog, action.number))
        if action.analog and not action.synchronized:
            self._report_duty(action)

    def _report_duty(self, action: SetOutput) -> None:
        """M67/M68: the duty the timer really makes (the nearest count)."""
        if not action.analog:
            return
        setting = self.engine.outputs.frequency_setting(action.number)
        if not isinstance(setting, PwmSetting):
            return
        count = duty_count(setting.counts, action.value)
        self.write(msg.GCODE_DUTY.format(
            number=action.number, duty=count_percent(count, setting.counts), count=count,
            counts=setting.counts, hz=setting.frequency_hz))

    def _output_problem(self, res: OutputResult, analog: bool, number: int,
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

    # ----------------------------------------------------------- execution
    def poll(self) -> None:
        """Feed the running move and start what the block queue allows, now."""
        now = self.backend.now()
        while True:
            if self.motion is not None:
                self.motion.feed()
                if self.motion.error is not None:
                    self._motion_failed(self.motion.error)
                elif self.motion.done():
                    self.motion = None
            if self.dwell_until is not None:
                if now < self.dwell_until:
                    break
                self.dwell_until = None
            if not self.queue or not self._start(self.queue[0], now):
                break
            self.queue.popleft()
        self._idle_drivers(now)

    def _start(self, head: Action, now: int) -> bool:
        """Start the block at the head of the queue if its turn has come."""
        busy = self.motion is not None or self.engine.sync.active()
        if isinstance(head, SetOutput):
            if self.motion is not None and not self.motion.fed:
                return False
            try:
                self._output(head)
            except GcodeError as exc:  # the pin was taken since the line was accepted
                self.errors += 1
                self.write(msg.GCODE_ERROR.format(reason=exc))
            return True
        if busy:
            return False
        if isinstance(head, Move):
            self._enable_drivers()
            run = MotionRun(self, head)
            run.start_tick = now
            run.begin()
            self.motion_log.append((now, run.lead_ticks))
            self.motion = run
            self.moves += 1
            if run.error is not None:
                self._motion_failed(run.error)
            return True
        if isinstance(head, Dwell):
            self.dwell_until = now + int(head.seconds * self.backend.profile.ticks_per_s)
            return True
        if isinstance(head, End):
            self.ends += 1
            return True
        return True  # pragma: no cover - every action is one of the above

    def _motion_failed(self, res: AqeResult) -> None:
        """The library refused a command (a bug or a limit not checked): abort."""
        self.write(msg.GCODE_MOTION_FAILED.format(code=res.name))
        self.abort()

    def _enable_drivers(self) -> None:
        if not self.drivers_on:
            for s in self.steppers:
                s.set_auto_enable(False)
                s.enable_outputs()
            self.drivers_on = True
        self.idle_since = None

    def _idle_drivers(self, now: int) -> None:
        delay = self.settings.idle_delay_ms
        if not self.drivers_on or delay == KEEP_ENABLED or not self.idle():
            self.idle_since = None
            return
        if self.idle_since is None:
            self.idle_since = now
        if now - self.idle_since >= delay * self.backend.profile.ticks_per_ms:
            for s in self.steppers:
                s.disable_outputs()
            self.drivers_on = False
            self.idle_since = None

    def wake_tick(self) -> int | None:
        """When :meth:`poll` next has something to do (None: only input)."""
        b = self.backend
        times = []
        if self.motion is not None or self.engine.sync.active() or (
                self.queue and self.dwell_until is None):
            nxt = b.next_event_time()
            times.append(b.now() + b.profile.fill_period_ticks if nxt is None else nxt)
        if self.dwell_until is not None:
            times.append(self.dwell_until)
        if self.idle_since is not None:
            times.append(self.idle_since + self.settings.idle_delay_ms * b.profile.ticks_per_ms)
        elif self.drivers_on and self.settings.idle_delay_ms != KEEP_ENABLED and self.idle():
            times.append(b.now())
        return max(min(times), b.now()) if times else None

    # ------------------------------------------------------- stop and reset
    def abort(self) -> None:
        """Alarm: stop at once, drop the queue and pending synchronized outputs."""
        for s in self.steppers:
            s.force_stop_and_new_position(s.get_current_position())
        self.engine.outputs.cancel_pending()
        had_work = not self.idle()
        self._flush()
        if had_work or self.motion_log:
            self.alarm = True
            self.write(msg.GCODE_ALARM_ABORT)

    def _flush(self) -> None:
        self.queue.clear()
        self.motion = None
        self.dwell_until = None
        self.interp.sync_position(self._positions())

    def soft_reset(self) -> None:
        """Ctrl-X: stop at once, every output off, modal state as at power-on."""
        for s in self.steppers:
            s.force_stop_and_new_position(s.get_current_position())
        self.engine.outputs.reset()
        self._flush()
        self.interp.reset()
        self.alarm = False
        self.write(msg.GCODE_BANNER)

    # ------------------------------------------------------------ reports
    def status_report(self) -> str:
        """Grbl's ``?`` answer, with the user outputs added."""
        pos = [s.get_current_position() / self.settings.steps_per_unit[i]
               for i, s in enumerate(self.steppers)]
        outputs = self.engine.outputs
        dout = "".join(str(outputs.digital_applied(n)) for n in range(4))
        aout = ",".join(f"{outputs.analog_applied(n)[0]:.2f}" for n in range(4))
        feed = self.interp.feed or 0
        wco = ""
        if any(self.interp.offset):
            wco = "|WCO:" + ",".join(f"{o:.3f}" for o in self.interp.offset)
        return msg.GCODE_STATUS.format(state=self.state_name(),
                                       pos=",".join(f"{p:.3f}" for p in pos),
                                       feed=f"{feed:g}", wco=wco, dout=dout, aout=aout)

    # ----------------------------------------------------------- $ commands
    def _dollar(self, text: str) -> None:
        body = "".join(text[1:].split()).upper()
        if body == "":
            self.write(msg.GCODE_HELP)
            return
        if body == "$":
            for line in self.settings_lines():
                self.write(line)
            return
        if body == "X":
            if self.alarm:
                self.alarm = False
                self.write(msg.GCODE_UNLOCKED)
            return
        if body == "G":
            self.write(msg.GCODE_MODES.format(
                motion=self.interp.motion, distance=90 if self.interp.absolute else 91,
                feed=f"{self.interp.feed or 0:g}"))
            return
        number, eq, value = body.partition("=")
        if not eq or not number.isdigit():
            raise GcodeError(msg.GCODE_ERR_DOLLAR.format(text=text))
        try:
            v = float(value)
        except ValueError:
            raise GcodeError(msg.GCODE_ERR_SETTING_VALUE.format(text=value or "?")) from None
        if not math.isfinite(v):
            raise GcodeError(msg.GCODE_ERR_SETTING_VALUE.format(text=value))
        if not self.idle():
            raise GcodeError(msg.GCODE_ERR_NOT_IDLE)
        self.set_setting(int(number), v)

    def set_setting(self, number: int, value: float) -> None:
        """``$number=value`` (raises :class:`GcodeError`)."""
        st = self.settings
        if number == 1:
            if value != int(value) or not 0 <= value <= 255:
                raise GcodeError(msg.GCODE_ERR_SETTING_RANGE.format(n=number, range="0..255"))
            st.idle_delay_ms = int(value)
            return
        axis = axis_setting(number)
        if axis is not None:
            base, i = axis
            if i >= self.axes:
                raise GcodeError(msg.GCODE_ERR_NO_SETTING.format(n=number))
            if value <= 0:
                raise GcodeError(msg.GCODE_ERR_SETTING_RANGE.format(n=number, range="> 0"))
            target = {100: st.steps_per_unit, 110: st.max_rate, 120: st.acceleration}[base]
            target[i] = value
            if base == 100:
                self.interp.sync_position(self._positions())
            return
        out = output_setting(number)
        if out is None:
            raise GcodeError(msg.GCODE_ERR_NO_SETTING.format(n=number))
        base, n = out
        outputs = self.engine.outputs
        if base == 140:
            res = outputs.set_frequency(n, value)
            if res != OutputResult.OK:
                raise GcodeError(self._output_problem(res, True, n, hz=value))
            return
        if value != int(value) or not 0 <= value < 128:
            raise GcodeError(msg.GCODE_ERR_SETTING_RANGE.format(n=number, range="0..127"))
        if base == 150:
            res = outputs.set_digital_pin(n, int(value))
        else:
            res = outputs.set_analog_pin(n, int(value))
        if res != OutputResult.OK:
            raise GcodeError(self._output_problem(res, base == 160, n, pin=int(value)))

    def settings_lines(self) -> list[str]:
        st = self.settings
        outputs = self.engine.outputs
        lines = [msg.GCODE_SETTING.format(n=1, value=st.idle_delay_ms, what=SETTING_HELP[1])]
        for base, values in ((100, st.steps_per_unit), (110, st.max_rate),
                             (120, st.acceleration)):
            for i in range(self.axes):
                lines.append(msg.GCODE_SETTING.format(
                    n=base + i, value=f"{values[i]:.3f}",
                    what=f"{AXES[i]} {SETTING_HELP[base]}"))
        for n in range(4):
            lines.append(msg.GCODE_SETTING.format(n=140 + n, value=f"{outputs.frequency_hz(n):g}",
                                                  what=f"Aout{n} {SETTING_HELP[140]}"))
        for n in range(4):
            lines.append(msg.GCODE_SETTING.format(n=150 + n, value=outputs.digital_pin(n),
                                                  what=f"Dout{n} {SETTING_HELP[150]}"))
        for n in range(4):
            lines.append(msg.GCODE_SETTING.format(n=160 + n, value=outputs.analog_pin(n),
                                                  what=f"Aout{n} {SETTING_HELP[160]}"))
        return lines
