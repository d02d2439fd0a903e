"""The helix winder (seed 002, SPEC 7.2): two steppers, pots, limit switches, a link.

S1 is the spindle, S2 the traverse.  Each stepper is driven either by its pot (A0,
A1) or by link commands; a link command makes that control *sticky* until ``pots``.
At power-up the fixture switch A4 decides: closed = fixture mode (pots in control),
open = link mode.  While ``interlock 1`` is on and S2's pot is centred (or the pots
do not drive S2), S2 follows S1 at ``ratio n:m`` - its steps derived from S1's
queued commands by :class:`fas.gear.Gear`, so that |S2 - (n/m)·S1| <= 1 step at
every step edge.  A2/A3 are S2's lower/upper limits: running into a closed one stops
S2 at once (a hard stop); moving away is allowed.  ``traverse`` moves S2 end to end
(:mod:`.traverse`).

The program is a main loop on the backend's clock: each pass runs at most one
command, the pots are read every 50 ms, the limits are checked on every change of
their pins (a pin-change interrupt) and on every pass.  On the simulated backend
the pots and switches are simulated inputs (``pot``, ``switch``); on a device they
are its pins, reported by the device (docs/serial-protocol.md, inputs).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Callable

from fas import Engine
from fas.backend import Backend
from fas.codes import PIN_UNDEFINED, RAMP_DIRECTION_COUNT_UP
from fas.gear import Gear, GearResult

from .. import messages as msg
from ..demo.build import demo_build
from ..program import LoopProgram
from . import figures as fig
from .commands import WAIT, Item, completions, parse_int, parse_line, parse_ratio
from .potrule import PotCommand, pot_command
from .traverse import TraverseFeeder

POT = "pot"
LINK = "link"
FOLLOW = "follow"
TRAVERSE = "traverse"
IDLE = ""

GEAR_ERRORS = {
    GearResult.ERR_RATIO: "the ratio needs 1 <= n <= m",
    GearResult.ERR_FOLLOWER_BUSY: "S2 is moving",
    GearResult.ERR_AUTO_ENABLE: "S2 uses auto enable",
    GearResult.ERR_DIR_DELAY: "S2 has a direction-change delay",
    GearResult.ERR_NO_TIMING: "this backend cannot time S2's steps",
}


class WinderError(ValueError):
    """The profile cannot host the winder."""


class Axis:
    """One stepper of the winder and what drives it."""

    def __init__(self, index: int, stepper, pot_input: int) -> None:
        self.index = index
        self.name = f"S{index + 1}"
        self.stepper = stepper
        self.pot_input = pot_input  # A-number of its pot
        self.period_counts = fig.DEFAULT_PERIOD_COUNTS
        self.accel = fig.DEFAULT_ACCEL
        self.pots = False  # the pot drives it (else the link)
        self.motion = IDLE  # what moves it now
        self.pot_applied: PotCommand | None = None
        self.hold = False  # pot ignored until centred (after a stop the pot did not ask for)
        self.note: str | None = None  # the last "held" note printed


class Winder(LoopProgram):
    """The winder program on a backend (see module text)."""

    title = "helix winder"
    cli_description = msg.WINDER_CLI_DESCRIPTION
    stepper_prefix = "S"  # its steppers are S1, S2 (plots)

    def __init__(self, backend: Backend, *, scripted: bool = True,
                 output: Callable[[bytes], None] | None = None) -> None:
        self.backend = backend
        problem = self.profile_problem(backend.profile)
        if problem:
            raise WinderError(problem)
        self.engine = Engine(backend)
        self.scripted = scripted
        self.output = output
        self.transcript = bytearray()
        self.steppers: list = [None] * self.profile.max_steppers
        self.pending: deque[Item] = deque()
        self._partial = ""
        self.pause_until: int | None = None  # tick at which a `w` ends
        self.input_consumed_at: int | None = None
        self._setup_done = False
        self.axes: list[Axis] = []
        self.gear: Gear | None = None
        self.traverse: TraverseFeeder | None = None
        self.fixture = False
        self.interlock = False
        self.ratio = fig.DEFAULT_RATIO
        self.next_sample = 0  # tick of the next pot sample
        self.sample_ticks = fig.POT_SAMPLE_MS * self.profile.ticks_per_ms
        self.commands = 0
        self.rejected = 0
        self.passes = 0
        # limit stops: (switch A-number, tick the switch closed, tick S2 was stopped)
        self.limit_stops: list[tuple[int, int, int]] = []
        self._switch_tick: dict[int, int] = {}
        self._later: list[str] = []  # lines held back to the end of a command or pass
        # interlocked limit stops the backend reported, not yet acted on: (up, tick)
        self._limit_hits: list[tuple[bool, int]] = []
        self.hw_limits = False  # the backend stops S2 at its limits (else: software)

    @staticmethod
    def profile_problem(profile) -> str | None:
        demo = demo_build(profile).steppers
        if profile.max_steppers < 2 or len(demo) < 2:
            return msg.WINDER_BAD_PROFILE.format(profile=profile.name, why="two steppers")
        if demo[0].direction == demo[1].direction:
            return msg.WINDER_BAD_PROFILE.format(
                profile=profile.name, why="steppers 1 and 2 on their own direction pins")
        if len(profile.analog_pins) <= max(fig.SWITCHES):
            return msg.WINDER_BAD_PROFILE.format(profile=profile.name, why="inputs A0..A5")
        return None

    # ------------------------------------------------------------- output
    def say(self, text: str) -> None:
        data = (text + "\r\n").encode("utf-8")
        self.backend.console_write(data)
        self.transcript += data
        if self.output is not None:
            self.output(data)

    def error(self, text: str) -> None:
        self.rejected += 1
        self.say(text)

    # -------------------------------------------------------------- setup
    def setup(self) -> None:
        if self._setup_done:
            return
        self._setup_done = True
        b = self.backend
        p = self.profile
        b.app_started()
        self.engine.init()
        for i in range(2):
            cfg = demo_build(p).steppers[i]
            s = self.engine.stepper_connect_to_pin(cfg.step)
            s.set_direction_pin(cfg.direction, cfg.direction_high_counts_up, 0)
            s.set_enable_pin(cfg.enable_low_active, True)
            if cfg.enable_high_active != PIN_UNDEFINED:
                s.set_enable_pin(cfg.enable_high_active, False)
            s.set_auto_enable(False)
            s.enable_outputs()  # a winder holds its axes: drivers on from power-up
            self.steppers[i] = s
            axis = Axis(i, s, fig.POT_INPUTS[i])
            s.set_acceleration(axis.accel)
            s.set_speed_in_ticks(self.period_ticks(axis.period_counts))
            self.axes.append(axis)
        self.gear = Gear(self.engine, self.steppers[0], self.steppers[1],
                         guard=self._gear_may_step, on_blocked=self._gear_blocked)
        self._watch_inputs()
        b.input_listeners.append(self._on_input)
        b.limit_listeners.append(self._on_limit)
        self._arm_limits()
        self._power_up()
        self.next_sample = b.now()

    def _watch_inputs(self) -> None:
        b = self.backend
        for a in fig.POT_INPUTS:
            b.watch_input(self.pin(a), analog=True, period_ms=fig.POT_SAMPLE_MS)
        for a in fig.SWITCHES:
            b.watch_input(self.pin(a), analog=False, pullup=True)
        pins = [self.pin(a) for a in (*fig.POT_INPUTS, *fig.SWITCHES)]
        if any(b.read_input(self.pin(a)) is None for a in fig.SWITCHES):
            # a device reports its inputs once it watches them (its pots as they are)
            b.wait_until(lambda: all(b.read_input(pin) is not None for pin in pins),
                         self.profile.ticks_per_s // 2)
        for a in fig.POT_INPUTS:  # the simulated pots start centred
            if b.read_input(self.pin(a)) is None:
                b.drive_input(self.pin(a), fig.POT_CENTRE)

    def _power_up(self) -> None:
        p = self.profile
        s1, s2 = demo_build(p).steppers[0], demo_build(p).steppers[1]
        self.say(msg.WINDER_BANNER.format(version=msg.VERSION, profile=p.name, s1_step=s1.step,
                                          s1_dir=s1.direction, s2_step=s2.step,
                                          s2_dir=s2.direction))
        self.say(msg.WINDER_INPUTS.format(**{f"a{a}": self.pin(a) for a in range(6)}))
        self.fixture = self.closed(fig.FIXTURE)
        for axis in self.axes:
            axis.pots = self.fixture
        self.say(msg.WINDER_FIXTURE_MODE if self.fixture else msg.WINDER_LINK_MODE)

    # ------------------------------------------------------------ helpers
    def pin(self, a: int) -> int:
        return self.profile.analog_pins[a]

    def period_ticks(self, counts: int) -> int:
        return counts * fig.COUNT_US * self.profile.ticks_per_us

    def read(self, a: int) -> int:
        value = self.backend.read_input(self.pin(a))
        if value is None:  # not reported (yet): a pot centred, a switch open
            return fig.POT_CENTRE if a in fig.POT_INPUTS else 1 - fig.SWITCH_CLOSED_LEVEL
        return value

    def closed(self, a: int) -> bool:
        return self.read(a) == fig.SWITCH_CLOSED_LEVEL

    @property
    def s1(self) -> Axis:
        return self.axes[0]

    @property
    def s2(self) -> Axis:
        return self.axes[1]

    @staticmethod
    def moving_up(stepper) -> bool | None:
        """The direction the stepper steps in now or next (None: it does not move)."""
        q = stepper.queue
        q.channel.sync()
        rp, wp = q.read_idx, q.next_write_idx
        while rp != wp:
            e = q.entries[rp % q.queue_len]
            if e.steps > 0:
                return e.count_up
            rp = (rp + 1) & 0xFF
        if stepper.is_ramp_generator_active():
            return bool(stepper.ramp_state() & RAMP_DIRECTION_COUNT_UP)
        return None

    def limit_closed(self, up: bool) -> bool:
        return self.closed(fig.LIMIT_HIGH if up else fig.LIMIT_LOW)

    # -------------------------------------------------------------- input
    def load_script(self, line: str | bytes) -> None:
        text = line.decode("utf-8", "replace") if isinstance(line, bytes) else line
        self.pending.extend(parse_line(text))
        self.input_consumed_at = None

    def feed(self, text: str | bytes) -> None:
        data = text.decode("utf-8", "replace") if isinstance(text, bytes) else text
        self._partial += data.replace("\r", "\n")
        *lines, self._partial = self._partial.split("\n")
        for line in lines:
            self.pending.extend(parse_line(line))

    def input_pending(self) -> bool:
        return bool(self.pending)

    # ------------------------------------------------------------ the loop
    def _runnable(self) -> bool:
        return bool(self.pending) and self.pause_until is None

    def _sampling(self) -> bool:
        """Is there anything the 50 ms pot sample has to look at?"""
        return (any(a.pots or a.motion for a in self.axes) or self.interlock
                or any(s is not None and s.is_running() for s in self.steppers))

    def loop_pass(self) -> None:
        b = self.backend
        self.passes += 1
        now = b.now()
        if self.pause_until is not None and now >= self.pause_until:
            self.pause_until = None
        self._take_limit_hits()  # (reported meanwhile) before the pots are looked at
        if now >= self.next_sample:
            if self._sampling():
                self._sample()
            self.next_sample = now + self.sample_ticks
        self._say_later()
        if self._runnable():
            self._execute(self.pending.popleft())
        if not self.pending and self.pause_until is None and self.input_consumed_at is None:
            self.input_consumed_at = b.now()
        self._check_limits()
        self._say_later()
        self._watch_motion()
        b.app_spend(demo_build(self.profile).loop_pass_ticks)

    def _wake_time(self) -> int | None:
        times = []
        if self.pause_until is not None:
            times.append(self.pause_until)
        if self._sampling():
            times.append(self.next_sample)
        return min(times) if times else None

    def next_wake_tick(self) -> int | None:
        if not self._setup_done or self._runnable() or self._later or self._limit_hits:
            return self.backend.now()
        wake = self._wake_time()
        return None if wake is None else max(wake, self.backend.now())

    def _advance(self, limit: int) -> None:
        b = self.backend
        if not self._runnable() and not self._later and not self._limit_hits:
            wake = self._wake_time()
            if wake is None or wake > limit:
                b.app_wait_until(limit)
                return
            if wake > b.now():
                b.app_wait_until(wake)
        self.loop_pass()

    def at_rest(self) -> bool:
        return (not any(s is not None and s.is_running() for s in self.steppers)
                and (self.traverse is None or not self.traverse.active)
                and not any(a.motion in (POT, LINK, TRAVERSE) for a in self.axes))

    def finished(self) -> bool:
        return (self.input_consumed_at is not None and not self.pending
                and self.pause_until is None and not self._limit_hits and self.at_rest())

    def script_consumed(self) -> bool:
        return self.input_consumed_at is not None and not self.pending

    # ------------------------------------------------------------- control
    def _sample(self) -> None:
        """The 50 ms look at the pots: who drives which stepper, at what speed."""
        for axis in self.axes:
            if not axis.pots:
                continue
            cmd = pot_command(self.read(axis.pot_input))
            if axis.hold:
                if cmd.active:
                    continue
                axis.hold = False
            if axis is self.s2 and self._want_follow():
                continue
            if cmd.active:
                self._pot_drive(axis, cmd)
            elif axis.motion == POT and axis.pot_applied is not None:
                axis.stepper.stop_move()
                axis.pot_applied = None
        self._update_interlock()
        self._watch_motion()

    def _pot_drive(self, axis: Axis, cmd: PotCommand) -> None:
        s = axis.stepper
        up = cmd.direction > 0
        if axis is self.s2:
            if self.gear.engaged:
                self.gear.disengage()
                self._arm_limits()
                self.say(msg.WINDER_INTERLOCK_RELEASED)
            if self.limit_closed(up):
                self._note(axis, msg.WINDER_HELD_AT_LIMIT.format(
                    name=axis.name, a=fig.LIMIT_HIGH if up else fig.LIMIT_LOW))
                if axis.motion == POT and axis.pot_applied is not None:
                    s.stop_move()
                    axis.pot_applied = None
                return
        axis.note = None
        if cmd == axis.pot_applied and axis.motion == POT:
            return
        s.set_speed_in_ticks(self.period_ticks(cmd.period_counts))
        s.set_acceleration(axis.accel)
        if up:
            s.run_forward()
        else:
            s.run_backward()
        axis.pot_applied = cmd
        if axis.motion != POT:
            axis.motion = POT

    def _note(self, axis: Axis, text: str) -> None:
        if axis.note != text:
            axis.note = text
            self.say(text)

    def _want_follow(self) -> bool:
        s2 = self.s2
        return self.interlock and not (s2.pots and not s2.hold
                                       and pot_command(self.read(s2.pot_input)).active)

    def _update_interlock(self) -> None:
        gear = self.gear
        s2 = self.s2
        want = self._want_follow()
        if want and not gear.engaged:
            st = s2.stepper
            if st.is_running():
                if s2.motion in (POT, LINK) and st.is_ramp_generator_active() \
                        and not st.is_stopping():
                    st.stop_move()
                    s2.pot_applied = None
                return  # S2 joins once it stands
            res = gear.engage(*self.ratio)
            if res != GearResult.OK:
                self.say(msg.WINDER_INTERLOCK_FAILED.format(why=GEAR_ERRORS.get(res, res.name)))
                self.interlock = False
                return
            s2.motion = FOLLOW
            self._arm_limits()
            n, m = self.ratio
            self.say(msg.WINDER_INTERLOCK_ENGAGED.format(
                n=n, m=m, s1=self.s1.stepper.get_current_position(), x0=gear.x0,
                s2=st.get_current_position()))
        elif not want and gear.engaged:
            gear.disengage()
            self._arm_limits()
            s2.motion = IDLE
            self.say(msg.WINDER_INTERLOCK_RELEASED)

    def _watch_motion(self) -> None:
        for axis in self.axes:
            s = axis.stepper
            if axis.motion in (POT, LINK) and not s.is_running():
                axis.motion = IDLE
                axis.pot_applied = None
                self.say(msg.WINDER_STOPPED.format(name=axis.name,
                                                   position=s.get_current_position()))
            elif self._driver_gone(axis) and not s.is_running():
                axis.motion = IDLE

    def _driver_gone(self, axis: Axis) -> bool:
        """What moved ``axis`` has let go of it (the gear it followed, the traverse)."""
        if axis.motion == FOLLOW:
            return not self.gear.engaged
        if axis.motion == TRAVERSE:
            return self.traverse is None or not self.traverse.active
        return False

    def _take_link(self, axis: Axis) -> None:
        """A link command for ``axis``: the link drives it until ``pots``."""
        if axis.pots:
            axis.pots = False
            self.say(msg.WINDER_LINK_CONTROL.format(name=axis.name))
        axis.hold = False
        if axis is self.s2:
            if self.interlock:
                self.interlock = False
                self.say(msg.WINDER_INTERLOCK_OFF_BY_LINK)
            if self.gear.engaged:
                self.gear.disengage()
                self._arm_limits()
            if self.traverse is not None and self.traverse.active:
                self.traverse.stop()
        if axis.motion == POT:
            axis.motion = LINK
            axis.pot_applied = None

    # -------------------------------------------------------------- limits
    def _arm_limits(self) -> None:
        """A2/A3 as limit switches where S2's pulses are made (the chip, the device):
        S2 stops there without a further step; interlocked, S1 stops with it."""
        stop = (0,) if self.gear is not None and self.gear.engaged else ()
        ok = True
        for up, a in ((True, fig.LIMIT_HIGH), (False, fig.LIMIT_LOW)):
            ok = self.backend.set_limit(1, self.pin(a), fig.SWITCH_CLOSED_LEVEL, up, stop) and ok
        self.hw_limits = ok

    def _on_input(self, pin: int, value: int, tick: int) -> None:
        for a in (fig.LIMIT_LOW, fig.LIMIT_HIGH):
            if pin == self.pin(a) and value == fig.SWITCH_CLOSED_LEVEL:
                self._switch_tick[a] = tick
        if not self.hw_limits:
            self._check_limits()  # at once, as a pin-change interrupt would

    def _on_limit(self, index: int, pin: int, position: int, tick: int) -> None:
        """The backend stopped a stepper at a limit: the library follows suit.

        Interlocked, the backend stops S2 and S1 at one switch and reports them one
        after the other; the winder then acts on the stop (:meth:`_after_limit`) once
        all reports are in - at the end of the command, or first thing in the next
        pass - so that it finds S1 where its pulses stopped, not where the library
        had it before S1's report."""
        st = self.steppers[index]
        st.force_stop_and_new_position(position)
        if index != 1:
            return
        up = pin == self.pin(fig.LIMIT_HIGH)
        if self.gear.engaged:
            self.gear.disengage()  # no S2 step is derived from S1 any more
            self._limit_hits.append((up, tick))
        else:
            self._after_limit(up, tick, both=False)

    def _take_limit_hits(self) -> None:
        while self._limit_hits:
            self._after_limit(*self._limit_hits.pop(0), both=True)

    def _check_limits(self) -> None:
        """The check in software (backends without limit switches, and a backstop)."""
        if not self._setup_done or self.hw_limits:
            return
        st = self.s2.stepper
        if not st.is_running():
            return
        up = self.moving_up(st)
        if up is None or not self.limit_closed(up):
            return
        both = self.gear.engaged
        if both:
            self.gear.force_stop()
        else:
            st.force_stop_and_new_position(st.get_current_position())
        self._after_limit(up, self.backend.now(), both)

    def _after_limit(self, up: bool, tick: int, both: bool) -> None:
        a = fig.LIMIT_HIGH if up else fig.LIMIT_LOW
        s2 = self.s2
        st = s2.stepper
        which = msg.WINDER_UPPER if up else msg.WINDER_LOWER
        if both:  # interlocked: the spindle stopped with it
            s1 = self.s1.stepper
            if s1.is_running():  # a backend stops only S2: then S1 here
                s1.force_stop_and_new_position(s1.get_current_position())
            self.gear.disengage()
            for axis in self.axes:
                self._halt(axis)
            self.interlock = False
            self._arm_limits()
            self.later(msg.WINDER_LIMIT_STOP_BOTH.format(
                a=a, which=which, s1=self.s1.stepper.get_current_position(),
                s2=st.get_current_position()))
        else:
            traversing = s2.motion == TRAVERSE and self.traverse is not None \
                and self.traverse.active
            if traversing:
                self.traverse.limit_hit()
            else:
                self._halt(s2)
            self.later(msg.WINDER_LIMIT_STOP.format(
                a=a, which=which, position=st.get_current_position(),
                then=msg.WINDER_LIMIT_TURN if traversing else ""))
        self.limit_stops.append((a, self._switch_tick.get(a, tick), tick))

    def later(self, text: str) -> None:
        """A line said at the end of the current command or loop pass (a limit may
        act inside an interrupt, where the program does not print)."""
        self._later.append(text)

    def _say_later(self) -> None:
        self._take_limit_hits()  # every report of a stop is in: act on it
        while self._later:
            self.say(self._later.pop(0))

    def _halt(self, axis: Axis) -> None:
        """The axis was stopped by force: a pot that drives it must be centred first."""
        if axis.motion in (POT, LINK, FOLLOW):
            axis.motion = IDLE
        if axis.pots and axis.pot_applied is not None:
            axis.hold = True
            self.later(msg.WINDER_HOLD.format(name=axis.name, a=axis.pot_input))
        axis.pot_applied = None

    def _gear_may_step(self, up: bool) -> bool:
        return not self.limit_closed(up)

    def _gear_blocked(self, up: bool) -> None:
        """The interlocked S2 would step into a closed limit: both stop."""
        self.gear.force_stop()
        self._after_limit(up, self.backend.now(), True)

    # ------------------------------------------------------------ commands
    def _execute(self, item: Item) -> None:
        self.commands += 1
        if item.error is not None:
            self.error(item.error)
            return
        if item.name == WAIT:
            ms = int(item.args[0])
            self.pause_until = self.backend.now() + ms * self.profile.ticks_per_ms
            return
        handler = getattr(self, "cmd_" + {"?": "help"}.get(item.name, item.name))
        problem = handler(*item.args)
        if problem is not None:
            self.error(msg.WINDER_ERROR.format(cmd=item.text, problem=problem))

    def _axis_arg(self, word: str) -> Axis | None:
        n = parse_int(word)
        return self.axes[n - 1] if n in (1, 2) else None

    def cmd_move(self, s_word: str, count_word: str) -> str | None:
        axis = self._axis_arg(s_word)
        if axis is None:
            return msg.WINDER_BAD_STEPPER.format(word=s_word)
        count = parse_int(count_word)
        if count is None or abs(count) > fig.MOVE_MAX:
            return msg.WINDER_BAD_COUNT.format(word=count_word, max=fig.MOVE_MAX)
        if axis is self.s2 and count != 0 and self.limit_closed(count > 0):
            a = fig.LIMIT_HIGH if count > 0 else fig.LIMIT_LOW
            return msg.WINDER_BLOCKED.format(name=axis.name, a=a,
                                             which=msg.WINDER_UPPER if count > 0
                                             else msg.WINDER_LOWER)
        self._take_link(axis)
        s = axis.stepper
        if count == 0:
            s.stop_move()
            self.say(msg.WINDER_MOVE_STOP.format(name=axis.name))
            return None
        s.set_speed_in_ticks(self.period_ticks(axis.period_counts))
        s.set_acceleration(axis.accel)
        speed = fig.COUNTS_PER_S / axis.period_counts
        if abs(count) == fig.MOVE_FOREVER:
            if count > 0:
                s.run_forward()
            else:
                s.run_backward()
            self.say(msg.WINDER_MOVE_RUN.format(name=axis.name,
                                                way=msg.WINDER_WAY[count > 0],
                                                counts=axis.period_counts, speed=speed))
        else:
            target = s.get_current_position() + count
            s.move_to(target)
            self.say(msg.WINDER_MOVE.format(name=axis.name, count=count, target=target,
                                            counts=axis.period_counts, speed=speed))
        axis.motion = LINK
        axis.pot_applied = None
        return None

    def cmd_period(self, s_word: str, counts_word: str) -> str | None:
        axis = self._axis_arg(s_word)
        if axis is None:
            return msg.WINDER_BAD_STEPPER.format(word=s_word)
        counts = parse_int(counts_word)
        if counts is None or not fig.PERIOD_MIN_COUNTS <= counts <= fig.PERIOD_MAX_COUNTS:
            return msg.WINDER_BAD_PERIOD.format(word=counts_word, lo=fig.PERIOD_MIN_COUNTS,
                                                hi=fig.PERIOD_MAX_COUNTS)
        traversing = axis is self.s2 and self.traverse is not None and self.traverse.active
        if traversing:  # the traverse is a link program: it takes the new top speed
            self.traverse.top_speed = fig.COUNTS_PER_S / counts
        else:
            self._take_link(axis)
        axis.period_counts = counts
        s = axis.stepper
        s.set_speed_in_ticks(self.period_ticks(counts))
        if s.is_ramp_generator_active():
            s.apply_speed_acceleration()
            axis.motion = LINK
        self.say(msg.WINDER_PERIOD.format(name=axis.name, counts=counts,
                                          us=counts * fig.COUNT_US,
                                          speed=fig.COUNTS_PER_S / counts))
        return None

    def cmd_accel(self, s_word: str, a_word: str) -> str | None:
        axis = self._axis_arg(s_word)
        if axis is None:
            return msg.WINDER_BAD_STEPPER.format(word=s_word)
        a = parse_int(a_word)
        if a is None or not 1 <= a <= fig.ACCEL_MAX:
            return msg.WINDER_BAD_ACCEL.format(word=a_word, hi=fig.ACCEL_MAX)
        axis.accel = a
        s = axis.stepper
        s.set_acceleration(a)
        if s.is_ramp_generator_active():
            s.apply_speed_acceleration()
        if axis is self.s2 and self.traverse is not None:
            self.traverse.accel = a
        self.say(msg.WINDER_ACCEL.format(name=axis.name, accel=a))
        return None

    def cmd_interlock(self, word: str) -> str | None:
        on = parse_int(word)
        if on not in (0, 1):
            return msg.WINDER_BAD_BOOL.format(word=word)
        self.interlock = bool(on)
        n, m = self.ratio
        self.say(msg.WINDER_INTERLOCK_ON.format(n=n, m=m) if on else msg.WINDER_INTERLOCK_OFF)
        if on and self.traverse is not None and self.traverse.active:
            self.traverse.stop()
        self._update_interlock()
        return None

    def cmd_ratio(self, word: str) -> str | None:
        r = parse_ratio(word)
        if r is None or not 1 <= r[0] <= r[1] <= fig.RATIO_MAX:
            return msg.WINDER_BAD_RATIO.format(word=word, hi=fig.RATIO_MAX)
        self.ratio = r
        if self.gear.engaged:
            self.gear.set_ratio(*r)
        self.say(msg.WINDER_RATIO.format(n=r[0], m=r[1]))
        return None

    def cmd_pots(self) -> str | None:
        if self.traverse is not None and self.traverse.active:
            self.traverse.stop()
        for axis in self.axes:
            axis.pots = True
            if axis.motion == LINK:
                axis.stepper.stop_move()
        self.say(msg.WINDER_POTS)
        return None

    def cmd_traverse(self, from_word: str, to_word: str) -> str | None:
        ends = parse_int(from_word), parse_int(to_word)
        if None in ends or any(abs(e) > 2**31 - 1 for e in ends):
            return msg.WINDER_BAD_POSITION.format(words=f"{from_word} {to_word}")
        if ends[0] == ends[1]:
            return msg.WINDER_TRAVERSE_SAME
        s2 = self.s2
        self._take_link(s2)
        st = s2.stepper
        if st.is_ramp_generator_active():
            st.stop_move()
        self.traverse = TraverseFeeder(
            self.engine, st, ends, start_counts=fig.TRAVERSE_START_COUNTS, accel=s2.accel,
            top_counts=s2.period_counts, blocked=self.limit_closed,
            on_event=self._traverse_event)
        self.traverse.start()
        s2.motion = TRAVERSE
        self.say(msg.WINDER_TRAVERSE.format(a=ends[0], b=ends[1],
                                            start=fig.COUNTS_PER_S / fig.TRAVERSE_START_COUNTS,
                                            accel=s2.accel,
                                            top=fig.COUNTS_PER_S / s2.period_counts))
        return None

    def _traverse_event(self, what: str, value: int) -> None:
        if what == "done":  # from the ramp task: said by the loop
            self.later(msg.WINDER_TRAVERSE_DONE.format(position=value))

    def cmd_status(self) -> str | None:
        for line in self.status_lines():
            self.say(line)
        return None

    def cmd_pot(self, s_word: str, v_word: str) -> str | None:
        axis = self._axis_arg(s_word)
        if axis is None:
            return msg.WINDER_BAD_STEPPER.format(word=s_word)
        value = parse_int(v_word)
        if value is None or not 0 <= value <= fig.POT_MAX:
            return msg.WINDER_BAD_POT.format(word=v_word, hi=fig.POT_MAX)
        if not self.backend.drive_input(self.pin(axis.pot_input), value):
            return msg.WINDER_INPUTS_ARE_PINS.format(what="pots")
        cmd = pot_command(value)
        self.say(msg.WINDER_POT.format(a=axis.pot_input, value=value,
                                       what=self._pot_text(axis, cmd)))
        return None

    def _pot_text(self, axis: Axis, cmd: PotCommand) -> str:
        if not cmd.active:
            return msg.WINDER_POT_OFF.format(name=axis.name)
        return msg.WINDER_POT_RULE.format(name=axis.name,
                                          way=msg.WINDER_WAY[cmd.direction > 0],
                                          speed=cmd.speed, counts=cmd.period_counts,
                                          real=cmd.steps_per_s)

    def cmd_switch(self, a_word: str, v_word: str) -> str | None:
        word = a_word.upper()
        a = parse_int(word[1:]) if word.startswith("A") else None
        if a not in fig.SWITCHES:
            return msg.WINDER_BAD_SWITCH.format(word=a_word)
        value = parse_int(v_word)
        if value not in (0, 1):
            return msg.WINDER_BAD_BOOL.format(word=v_word)
        level = fig.SWITCH_CLOSED_LEVEL if value else 1 - fig.SWITCH_CLOSED_LEVEL
        said = len(self._later)
        if not self.backend.drive_input(self.pin(a), level):
            return msg.WINDER_INPUTS_ARE_PINS.format(what="switches")
        # what changed first, then what it caused
        self._later.insert(said, msg.WINDER_SWITCH.format(
            a=a, state=msg.WINDER_SWITCH_STATE[bool(value)], role=msg.WINDER_SWITCH_ROLES[a]))
        return None

    def cmd_reset(self) -> str | None:
        """Power cycle: everything stops, positions and settings start again, A4 is read."""
        self._stop_everything()
        for axis in self.axes:
            s = axis.stepper
            s.force_stop_and_new_position(0)
            axis.period_counts = fig.DEFAULT_PERIOD_COUNTS
            axis.accel = fig.DEFAULT_ACCEL
            axis.hold = False
            axis.note = None
            s.set_acceleration(axis.accel)
            s.set_speed_in_ticks(self.period_ticks(axis.period_counts))
        self.interlock = False
        self.ratio = fig.DEFAULT_RATIO
        self._power_up()
        return None

    def cmd_help(self) -> str | None:
        self.say(msg.WINDER_HELP_HEAD)
        for text, hint in completions():
            self.say(msg.WINDER_HELP_LINE.format(text=text, hint=hint))
        return None

    # -------------------------------------------------------------- status
    def _control_text(self, axis: Axis) -> str:
        if axis.motion == FOLLOW or (axis is self.s2 and self.gear.engaged):
            n, m = self.ratio
            return msg.WINDER_CTL_FOLLOW.format(n=n, m=m)
        if axis.motion == TRAVERSE:
            return msg.WINDER_CTL_TRAVERSE
        if axis.pots:
            return msg.WINDER_CTL_POT.format(a=axis.pot_input) + (
                msg.WINDER_CTL_HOLD if axis.hold else "")
        return msg.WINDER_CTL_LINK

    def status_lines(self) -> list[str]:
        lines = []
        for axis in self.axes:
            s = axis.stepper
            lines.append(msg.WINDER_STATUS_AXIS.format(
                name=axis.name, role=msg.WINDER_ROLES[axis.index],
                position=s.get_current_position(),
                speed=s.get_current_speed_in_milli_hz() / 1000,
                control=self._control_text(axis), counts=axis.period_counts,
                accel=axis.accel))
        lines.append(msg.WINDER_STATUS_INPUTS.format(
            pots=" ".join(msg.WINDER_STATUS_POT.format(a=a, value=self.read(a))
                          for a in fig.POT_INPUTS),
            switches=" ".join(msg.WINDER_STATUS_SWITCH.format(
                a=a, state=msg.WINDER_SWITCH_STATE[self.closed(a)])
                              for a in fig.SWITCHES)))
        n, m = self.ratio
        lines.append(msg.WINDER_STATUS_MODE.format(
            mode=msg.WINDER_MODE[self.fixture],
            interlock=msg.WINDER_ON_OFF[self.interlock], n=n, m=m,
            engaged=msg.WINDER_ENGAGED if self.gear.engaged else ""))
        return lines

    # --------------------------------------------------- hosted by the console
    def _stop_everything(self) -> None:
        if self.traverse is not None and self.traverse.active:
            self.traverse.active = False
            self.engine.remove_task_hook(self.traverse)
        if self.gear is not None and self.gear.engaged:
            self.gear.force_stop()
            self._arm_limits()
        for axis in self.axes:
            s = axis.stepper
            s.force_stop_and_new_position(s.get_current_position())
            self._halt(axis)
            axis.motion = IDLE

    def force_stop_all(self) -> None:
        """Ctrl-C: everything stops at once; pots that drive must be centred again."""
        if self._setup_done:
            self._stop_everything()
        self.pending.clear()
        self.pause_until = None

    def mode_name(self) -> str:
        return msg.WINDER_MODE[self.fixture]

    def completions(self) -> list[tuple[str, str]]:
        return completions()

    def toolbar_status(self) -> str:
        if not self._setup_done:
            return ""
        pots = " ".join(msg.WINDER_TOOLBAR_POT.format(a=a, value=self.read(a))
                        for a in fig.POT_INPUTS)
        sw = " ".join(msg.WINDER_TOOLBAR_SWITCH.format(a=a, mark="#" if self.closed(a) else "-")
                      for a in fig.SWITCHES)
        axes = " ".join(msg.WINDER_TOOLBAR_AXIS.format(name=a.name, control=self._control_text(a))
                        for a in self.axes)
        n, m = self.ratio
        lock = msg.WINDER_TOOLBAR_LOCK.format(
            state=msg.WINDER_ON_OFF[self.interlock], n=n, m=m,
            engaged=msg.WINDER_TOOLBAR_ENGAGED if self.gear.engaged else "")
        return msg.WINDER_TOOLBAR.format(pots=pots, switches=sw, axes=axes, lock=lock)

    def watch(self, observers) -> None:
        from .watch import InterlockMeter

        pins = self.backend.pin_states  # (None: the pins are on a device)
        wiring = observers.wiring[:2]
        levels = {w.direction: pins.get(w.direction) for w in wiring
                  if w.direction is not None and pins is not None}
        positions = [s.get_current_position() if s is not None else 0
                     for s in self.steppers[:2]]
        # a replay of a bounded recording (issue 16) starts where its window starts
        start_levels = getattr(observers, "start_levels", None)
        if start_levels is not None:
            levels = {w.direction: start_levels.get(w.direction, 0) for w in wiring
                      if w.direction is not None}
            positions = list(observers.start_positions[:2])
        self._meter = InterlockMeter(self, wiring, levels, positions)
        observers.stream.add(self._meter)

    def watch_report(self) -> list[str]:
        meter = getattr(self, "_meter", None)
        if meter is None:
            return []
        return meter.report_lines(self.profile.ticks_per_s)

    @property
    def spans(self):
        """The gear's stretches of following (none before setup)."""
        return self.gear.spans if self.gear is not None else []

    def trace_signals(self) -> dict[int, list[str]]:
        """The winder's inputs as VCD signals beside the steppers' pins."""
        return {self.pin(a): [msg.WINDER_VCD_SWITCH.format(a=a, name=msg.WINDER_SWITCH_NAMES[a])]
                for a in fig.SWITCHES}


__all__ = ["Winder", "WinderError"]
