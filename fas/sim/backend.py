"""The simulated backend: the library running on a virtual microcontroller."""

from __future__ import annotations

import heapq
from bisect import bisect_right
from typing import TYPE_CHECKING, Callable, Sequence

from ..arch import Profile, get_profile
from ..backend import AppPoll, Backend, OutputChange, PinStates, PulseCounter, TaskEngine
from ..pwm import PwmSetting
from ..queue import StepperQueue
from ..schedule import TaskSchedule
from .channel import SimChannel, flush_fills
from .machine import PRIO_PLAIN, PRIO_TASK, Event, Machine
from .pins import EdgeRecorder
from .printing import print_chars

if TYPE_CHECKING:  # pragma: no cover
    from ..queue import QueueEntry
    from .quickstep import QuickStepChannel, TimerLoad

DEFAULT_WAIT_LIMIT_S = 3600


class SimBackend(Backend):
    """Virtual time: ``run_for``/``run_until`` jump from event to event."""

    # Backend.task_period_ticks as a plain attribute, set where the period is (the path
    # planner and the G-code layer read it three times a task; a property's call costs
    # about eight times an attribute's look-up)
    task_period_ticks: int = 0

    def __init__(self, profile: Profile | str | None = None, record: bool = False,
                 build: str | None = None) -> None:
        self.profile = get_profile(profile)
        self.task_period_ticks = self.profile.fill_period_ticks
        # ``build``: the firmware build whose CPU costs the chip runs (fas.sim.builds)
        self.machine = Machine(self.profile, build)
        self.build = self.machine.build
        # how the main loop polls in its waits (app_polls; None: not followed)
        self._poll: tuple[int, tuple[tuple[int, int], ...]] | None = None
        self.channels: list[SimChannel] = []
        self.recorder: EdgeRecorder | None = None
        if record:
            self.recorder = EdgeRecorder()
            self.machine.pins.sinks.append(self.recorder)
        self._engine: TaskEngine | None = None
        self._task_event: Event | None = None
        # the event of the planned run that calls _run_task (at most one is pending),
        # its run's index, and the event of the run that ran last (free to reuse)
        self._task_run_ev: Event | None = None
        self._task_index = 0
        self._task_spare: Event | None = None
        self.tasks = TaskSchedule()  # the periodic task's runs
        self.task_runs = 0
        self.stray_reads = 0
        self.stray_reads_during_pulse = 0
        self.channel_listeners: list[Callable[[SimChannel], None]] = []  # observers
        # inputs of the application (switches, pots): pin -> analog?; analog values
        self.input_listeners = []
        self._inputs: dict[int, bool] = {}
        self._analog: dict[int, int] = {}
        self.limit_listeners = []
        # limit switches: (queue index, up) -> (pin, level, queues stopped with it)
        self._limits: dict[tuple[int, bool], tuple[int, int, tuple[int, ...]]] = {}
        self._sync_outputs: list[tuple[object, OutputChange]] = []  # waiting for idle queues
        self.output_listeners: list[Callable[[OutputChange, int], None]] = []  # (change, tick)
        self._timed: list[Event] = []  # timed output changes whose tick has not come
        # QuickStep's timer interrupt load (fas.sim.quickstep)
        self._qs_load: TimerLoad | None = None

    # ------------------------------------------------------------ Backend API
    def now(self) -> int:
        return self.machine.now

    def attach_engine(self, engine: TaskEngine) -> None:
        self._engine = engine
        # run 0 keeps its phase if the period changes before it
        self.tasks.start(self.machine.now + self.machine.timing.task_phase_ticks,
                         self.task_period_ticks, anchor=0)
        self._schedule_task(0)

    def set_task_period(self, ticks: int) -> None:
        """``engine.task_rate()``: runs after the last one follow the new period."""
        super().set_task_period(ticks)
        self.task_period_ticks = self._task_period or self.profile.fill_period_ticks
        if self._engine is None:
            return
        self.tasks.set_period(self.task_period_ticks)
        self.machine.cancel(self._task_event)
        self._task_event = None
        self.tasks.stop()
        self.wake_task()

    def _schedule_task(self, index: int) -> None:
        # the timer overflow interrupt: where interrupts contend (AVR) it is entered when
        # the CPU is free and holds it until its sei
        m = self.machine
        enter = m.timing.fill_mask_entry_ticks if m.profile.irq_block_delays_steps else 0
        time = self.tasks.time(index)
        live = self._task_run_ev
        if live is not None and not live.cancelled:
            # a run planned before is still pending (never while things go as planned):
            # this one carries its own index
            self._task_event = m.schedule(time, lambda: self._task(index), PRIO_TASK,
                                          isr=True, enter=enter)
        else:
            ev = self._task_spare
            if ev is None:
                ev = m.schedule(time, self._run_task, PRIO_TASK, isr=True, enter=enter)
            else:  # the event of the run that has just ended, reused (Machine.schedule)
                self._task_spare = None
                if time < m.now:
                    time = m.now
                ev.time = time
                ev.enter = enter
                ev.cancelled = False
                m.seq += 1
                heapq.heappush(m.events, (time, PRIO_TASK, m.seq, ev))
            self._task_index = index
            self._task_run_ev = self._task_event = ev
        self.tasks.next = index

    def _run_task(self) -> None:
        """The planned run's event: run ``_task_index``; the event is free afterwards."""
        self._task_spare = self._task_run_ev
        self._task_run_ev = None
        self._task(self._task_index)

    def _task(self, index: int) -> None:
        m = self.machine
        p = m.timing
        engine = self._engine
        assert engine is not None  # the task is scheduled from attach_engine on
        skipped = self.tasks.begin(index)
        if skipped > 0:
            engine.credit_skipped_tasks(skipped)
        may_stop = engine.may_stop_without_channel()
        m.in_task = True
        m.task_offset = p.fill_entry_ticks
        channels = self.channels
        if p.idle_task_ticks:
            for ch in channels:
                if ch.running:
                    break
            else:  # no stepper runs (a command may start one)
                m.task_offset = p.idle_task_ticks
        if p.start_task_nested_isrs:
            for ch in channels:
                if ch.running:
                    m.nest_timer0 = False
                    break
            else:
                m.nest_timer0 = True
        if p.task_nested_isrs and m.step_isrs_between is None:
            m.step_isrs_between = lambda lo, hi: sum(c.isr_cpu_between(lo, hi)
                                                     for c in self.channels)
        if p.fill_queued_entry_ticks or p.fill_stepper_ticks:
            # a stepper whose ramp has planned everything: its fill returns at once
            planning = engine.planning_queues() if p.fill_skips_done_ramps else None
            plan = bool(p.fill_plan_ticks)
            for ch in channels:  # a running stepper's fill first sums its queue
                if ch.running:
                    q = ch.q
                    if planning is not None:
                        # (among them by identity: a loop, neither any() over a
                        # generator nor a call - this runs for every running stepper in
                        # every run of the ramp task)
                        for x in planning:
                            if x is q:
                                break
                        else:
                            continue
                    ch.plan_pending = plan
                    if p.fill_reads_queue_live:
                        continue  # charged when its fill reads the queue (fill_begins)
                    if p.fill_charges_after_writes:  # charged after its writes
                        ch.fill_charge = p.fill_stepper_ticks + ch.queue_sum_ticks(q.read_idx)
                        continue
                    m.task_offset += p.fill_stepper_ticks + ch.queue_sum_ticks(q.read_idx)
        try:
            engine.manage_steppers()
        finally:
            if p.fill_charges_after_writes:  # the last fills' work, and those that never ran
                done = m.fills_done
                for ch in channels:
                    ch.plan_pending = False
                    if ch.fill_charge:
                        done.append(ch)
                flush_fills(m)
            else:
                for ch in channels:
                    ch.plan_pending = False
            # the task's own CPU time; the UART interrupts that run inside it are
            # counted as such by the loop (Machine.consume)
            cost = m.task_offset + p.fill_exit_ticks
            m.task_offset = 0
            m.in_task = False
            m.nest_timer0 = False
        m.stolen_ticks += cost
        exit_ticks = p.fill_mask_exit_ticks
        if p.fill_tail_mask_ticks and m.profile.irq_block_delays_steps:
            self._tail_sections(m.now + cost, engine)
        if exit_ticks and m.profile.irq_block_delays_steps:  # its exit: from cli to reti
            # (Machine.mask, written out: this runs for every run of the task)
            end = m.now + cost
            if len(m.exit_starts) > 1024:
                m._forget_isrs()  # noqa: SLF001
            start = end - exit_ticks
            while m.exit_ends and start < m.exit_ends[-1]:  # over a command's section
                start = min(start, m.exit_starts.pop())  # (fill_cmd_mask_sections)
                end = max(end, m.exit_ends.pop())
            m.exit_starts.append(start)
            m.exit_ends.append(end)
            if end > m._quiet_from:  # noqa: SLF001
                m._quiet_from = end  # noqa: SLF001
        self.task_runs += 1
        if may_stop or engine.may_stop_without_channel():
            m.activity += 1  # a stepper whose channel stands may have started or stopped
        if self._sync_outputs and self._make_sync_outputs():
            engine.queues_idle()
            m.activity += 1
        # idle_task_ticks: no run is skipped, each one costs CPU time
        nxt = self.tasks.end(0 if p.idle_task_ticks else engine.quiescent_tasks())
        if nxt is None:
            self._task_event = None  # suspended until wake_task()
        else:
            self._schedule_task(nxt)

    def _tail_sections(self, end: int, engine: TaskEngine) -> None:
        """The ramp task's two sections with interrupts off before its exit
        (SimTiming.fill_tail_mask_ticks), the task ending at ``end``.  A section that
        would begin while timer 0's or the UART's interrupt holds the CPU begins after
        that routine's reti (the task runs on only then, behind a step interrupt pending
        at the reti); none reaches into the exit."""
        m = self.machine
        timing = m.timing
        per, last_before, gap, fill, done, idle = timing.fill_tail_mask_ticks
        running = [ch.q for ch in self.channels if ch.running]
        last = per * max(1, len(running))
        before = last_before + last + gap
        if not running:
            width = idle
        else:
            width = done
            for q in engine.planning_queues():  # (any(...), written out: every task)
                if q in running:
                    width = fill
                    break
        limit = end - timing.fill_mask_exit_ticks
        ends = m.exit_ends
        for start, ticks in ((end - before - width, width), (end - last_before - last, last)):
            start = self._after_holds(start, ticks)
            if ends and ends[-1] > start:
                start = ends[-1]
            stop = start + ticks
            if stop > limit:
                stop = limit
            if start < stop:
                m.mask(start, stop)

    def _after_holds(self, start: int, ticks: int) -> int:
        """Where a section of the task of ``ticks`` planned at ``start`` begins: after
        the timer-0 and UART interrupts that would hold the CPU in it."""
        m = self.machine
        timing = m.timing
        after = timing.reti_next_ticks + 1
        hold = m._uart_hold  # noqa: SLF001
        ms = timing.millis_isr_ticks if m._millis_started else 0  # noqa: SLF001
        for _ in range(8):
            moved = start
            loads = m.uart.loads
            if hold and loads:
                i = bisect_right(loads, start + ticks - 1) - 1
                if i >= 0 and loads[i] + hold > start:
                    start = loads[i] + hold + after
            x = start + ticks - 1
            if ms and x >= m._millis_first:  # noqa: SLF001
                r = x - (x - m._millis_phase) % timing.millis_overflow_ticks  # noqa: SLF001
                if r >= m._millis_first and r + ms > start:  # noqa: SLF001
                    start = r + ms + after
            if start == moved:
                break
        return start

    def wake_task(self) -> None:
        if self._engine is None:
            return
        tasks = self.tasks
        nxt = tasks.next
        if nxt is not None and nxt <= tasks.last + 1:
            return  # the next slot is planned already (TaskSchedule.wake's common case)
        if tasks.wake(self.machine.now):
            self.machine.cancel(self._task_event)
            nxt = tasks.next
            assert nxt is not None  # wake() planned a run
            self._schedule_task(nxt)

    def reset_chip(self) -> None:
        m = self.machine
        for ch in self.channels:
            ch.release()
        if self._qs_load is not None and self._qs_load in m.cpu_sources:
            m.cpu_sources.remove(self._qs_load)
        self._qs_load = None
        self.channels = []
        self._sync_outputs.clear()
        self.cancel_timed_outputs()
        m.cancel(self._task_event)
        self._task_event = None
        self.tasks.stop()
        self._engine = None
        self._task_period = None
        self.task_period_ticks = self.profile.fill_period_ticks
        t = m.cpu_now()
        for pin in list(m.outputs.waves):  # PWM timers stop: the pins go LOW
            m.outputs.set_digital(pin, 0, t)
        for pin, level in list(m.pins.level.items()):
            if level:
                m.pins.set(pin, 0, t)

    def allocate_channel(self, queue: StepperQueue) -> SimChannel:
        # the platform drivers' init: the step pin becomes an output driven LOW
        self.machine.pins.set(queue.step_pin, 0, self.machine.cpu_now())
        ch = SimChannel(self.machine, queue)
        ch.on_idle = self.queue_ran_dry
        self.channels.append(ch)
        self.machine.block_sources.append(ch)
        for fn in self.channel_listeners:
            fn(ch)
        return ch

    def allocate_order_channel(self, queue: StepperQueue, fas_queue: StepperQueue,
                               clock: object) -> QuickStepChannel:
        """QuickStep's FIFO runs on the profile's QuickStep timer (timer 2 on AVR)."""
        from ..quickstep.clock import QuickStepClock
        from ..quickstep.orders import OrderQueue
        from .quickstep import QuickStepChannel, TimerLoad
        # the abstract backend names no QuickStep class; the only caller is its set-up
        if not isinstance(queue, OrderQueue) or not isinstance(clock, QuickStepClock):
            raise TypeError("the simulated order channel runs QuickStep's OrderQueue "
                            "on its QuickStepClock")
        load = self._qs_load
        if load is None or load.clock is not clock:
            load = self._qs_load = TimerLoad(self.machine, clock)
            self.machine.cpu_sources.append(load)
        ch = QuickStepChannel(self.machine, queue, clock, load)
        ch.on_idle = self.queue_ran_dry
        self.channels.append(ch)
        self.machine.block_sources.append(ch)
        for fn in self.channel_listeners:
            fn(ch)
        return ch

    def write_pin(self, pin: int, level: int) -> None:
        self.machine.pins.set(pin, level, self.machine.cpu_now())

    def auto_enabled(self) -> None:
        """Auto enable's ``enableOutputs()`` in a command's write: in the ramp task it
        costs the task ``SimTiming.fill_enable_ticks`` before the write."""
        m = self.machine
        if m.in_task and m.timing.fill_enable_ticks:
            m.task_offset += m.timing.fill_enable_ticks
        if m.in_task and m.timing.fill_first_write_enable_ticks:
            m.task_offset += m.timing.fill_first_write_enable_ticks

    def read_pin(self, pin: int) -> int:
        found = False
        for ch in self.channels:  # (a QuickStep stepper has two: its FIFO's and the idle one)
            if ch.step_pin == pin and not ch.detached:
                if ch.step_pin_high():
                    return 1
                found = True
        return 0 if found else self.machine.outputs.level(pin, self.machine.now)

    # ------------------------------------------------------- user outputs
    def configure_pwm(self, number: int, pin: int, setting: PwmSetting, count: int) -> None:
        m = self.machine
        m.outputs.configure(pin, setting.period_ticks(self.profile.ticks_per_s), setting.counts,
                            count, m.cpu_now())

    def set_output(self, change: OutputChange) -> None:
        self._make(change, self.machine.cpu_now())

    def _make(self, change: OutputChange, t: int) -> None:
        outputs = self.machine.outputs
        if change.analog:
            outputs.set_count(change.pin, change.value, t)
        else:
            outputs.set_digital(change.pin, change.value, t)
        for fn in self.output_listeners:
            fn(change, t)

    def sync_output(self, change: OutputChange) -> object:
        token = object()
        self._sync_outputs.append((token, change))
        self._make_sync_outputs()
        return token

    def sync_output_done(self, token: object) -> bool:
        return all(t is not token for t, _ in self._sync_outputs)

    def cancel_sync_outputs(self) -> None:
        self._sync_outputs.clear()

    def timed_output(self, change: OutputChange, tick: int) -> bool:
        """At ``tick`` the chip's timer makes the change (a compare, not the main loop:
        a busy CPU does not delay it); a PWM duty shows from the next period."""
        m = self.machine
        t = max(tick, m.cpu_now())
        holder: list[Event] = []

        def make() -> None:
            self._timed.remove(holder[0])
            self._make(change, t)

        ev = m.schedule(t, make, PRIO_PLAIN)
        holder.append(ev)
        self._timed.append(ev)
        return True

    def timed_waiting(self) -> int:
        """Timed changes whose tick has not come."""
        return len(self._timed)

    def cancel_timed_outputs(self) -> None:
        for ev in self._timed:
            self.machine.cancel(ev)
        self._timed.clear()

    def queues_idle(self) -> bool:
        """Every queue has executed all its commands and its timer stopped."""
        for ch in self.channels:
            q = ch.q
            if ch.running or q.read_idx != q.next_write_idx:
                return False
        return True

    def _make_sync_outputs(self) -> bool:
        """Make the waiting synchronized changes if every queue is done; True if made."""
        if not self._sync_outputs or not self.queues_idle():
            return False
        t = self.machine.cpu_now()
        waiting, self._sync_outputs = self._sync_outputs, []
        for _, change in waiting:
            self._make(change, t)
        return True

    def queue_ran_dry(self) -> None:
        """A queue ran dry (in its step interrupt): the moment synchronized outputs wait for."""
        self._make_sync_outputs()
        if self._engine is not None:
            self._engine.queues_idle()  # synchronized outputs may wait for this moment

    def wait_until(self, predicate: Callable[[], bool], timeout_ticks: int = 0) -> bool:
        m = self.machine
        limit = timeout_ticks or DEFAULT_WAIT_LIMIT_S * self.profile.ticks_per_s
        deadline = m.now + limit
        while not predicate():
            t = m.next_event_time()
            if t is None or t > deadline:
                m.run_until(deadline)
                return predicate()
            m.run_until(t)
        return True

    def attach_pulse_counter(self, queue: StepperQueue, counter: PulseCounter) -> bool:
        ch = queue.channel
        if not isinstance(ch, SimChannel):
            return False
        ch.sync()
        ch.pulse_counter = counter
        return True

    def detach_step_pin(self, queue: StepperQueue, detached: bool) -> None:
        queue.channel.detached = detached

    # ------------------------------------------------------ application host
    def app_started(self) -> None:
        self.machine.start_millis()

    def millis(self) -> int:
        return self.machine.millis()

    def tick_at_millis(self, ms: int) -> int:
        return self.machine.tick_at_millis(ms)

    def app_spend(self, ticks: int) -> None:
        self.machine.consume(ticks)

    def app_spend_in(self, ticks: int, poll: tuple[int, tuple[tuple[int, int], ...]]) -> None:
        m = self.machine
        m.poll_begin(*poll)
        m.consume(ticks)
        m.poll_end()

    def app_spend_passes(self, passes: Sequence[tuple[int, int, AppPoll | None]],
                         before: int, changed: Callable[[], bool]) -> int:
        return self.machine.consume_passes(passes, before, changed)

    def app_polls(self, poll: tuple[int, tuple[tuple[int, int], ...]] | None) -> None:
        self._poll = poll

    def app_wait_until(self, tick: int, until: Callable[[], bool] | None = None) -> bool:
        m = self.machine
        stopped = False
        if tick > m.now:
            poll = self._poll
            if poll is not None:
                m.poll_begin(*poll)
            if until is None:
                m.run_until(tick)
            else:
                stopped = m.run_until_changed(tick, until)
            if poll is not None:
                m.poll_end()
        # the loop polled while interrupts ran; it goes on once the CPU is free
        # (Machine.resume, written out: this runs after every wait)
        wait = m.resume_wait()
        if wait > 0:
            m.consume(wait)
        return stopped

    def next_event_time(self) -> int | None:
        return self.machine.next_event_time()

    def console_write(self, data: bytes, cpu_after: Sequence[int] | None = None) -> None:
        print_chars(self.machine, data, cpu_after, self.machine.timing.char_ticks)

    def block_interrupts(self, ticks: int) -> None:
        self.machine.block_interrupts(ticks)

    # ------------------------------------------------------------- inputs
    def watch_input(self, pin: int, analog: bool = False, pullup: bool = True,
                    period_ms: int = 0) -> bool:
        self._inputs[pin] = analog
        pins = self.machine.pins
        if not analog and pullup and pin not in pins.first_write:
            pins.set(pin, 1, self.machine.now)  # the pull-up holds an open input high
        return True

    def read_input(self, pin: int) -> int | None:
        analog = self._inputs.get(pin)
        if analog is None:
            return None
        if analog:
            return self._analog.get(pin)
        return self.machine.pins.get(pin)

    def drive_input(self, pin: int, value: int) -> bool:
        """The simulated world: a switch pulls ``pin`` to ``value`` (0/1), a pot turns
        the analog input to ``value`` (0..1023).  Listeners hear of it at once."""
        m = self.machine
        if self._inputs.get(pin):
            value = min(max(int(value), 0), 1023)
            changed = self._analog.get(pin) != value
            self._analog[pin] = value
        else:
            value = 1 if value else 0
            changed = m.pins.get(pin) != value or pin not in m.pins.first_write
            m.pins.set(pin, value, m.cpu_now())
        if changed:
            if not self._inputs.get(pin):
                self._limit_pin_changed(pin, value)
            self._notify_input(pin, value, m.cpu_now())
        return True

    # ------------------------------------------------------- limit switches
    def set_limit(self, index: int, pin: int, level: int, up: bool,
                  stop: tuple[int, ...] = ()) -> bool:
        ch = self._channel_of(index)
        if ch is None:
            return False
        self._limits[(index, bool(up))] = (pin, 1 if level else 0, tuple(stop))
        ch.entry_guard = lambda e, i=index: self._guard(i, e)
        return True

    def clear_limit(self, index: int, up: bool) -> None:
        self._limits.pop((index, bool(up)), None)

    def _channel_of(self, index: int) -> SimChannel | None:
        for ch in self.channels:
            if ch.q.index == index:
                return ch
        return None

    def _guard(self, index: int, entry: QueueEntry) -> bool:
        """A queue takes up an entry: towards a closed limit it must not step."""
        lim = self._limits.get((index, entry.count_up))
        if lim is None or self.machine.pins.get(lim[0]) != lim[1]:
            return False
        ch = self._channel_of(index)
        assert ch is not None  # the guard is set on this channel (set_limit)
        ch.on_halt = lambda: self._limit_stop(index, lim, halted=True)
        return True

    def _limit_pin_changed(self, pin: int, value: int) -> None:
        for (index, up), lim in list(self._limits.items()):
            if lim[0] != pin or lim[1] != value:
                continue
            ch = self._channel_of(index)
            if ch is not None and ch.is_running() and ch.moving_up() == up:
                self._limit_stop(index, lim)

    def _limit_stop(self, index: int, lim: tuple[int, int, tuple[int, ...]],
                    halted: bool = False) -> None:
        tick = self.machine.now
        stopped = []
        for i in (index, *lim[2]):
            ch = self._channel_of(i)
            if ch is None or (i != index and not ch.is_running()):
                continue
            if i == index and halted:
                ch.on_halt = None
            stopped.append((i, ch.stop_now()))
        for i, pos in stopped:
            self._notify_limit(i, lim[0], pos, tick)

    # -------------------------------------------------------- conveniences
    def run_for(self, ticks: int) -> None:
        self.machine.run_until(self.machine.now + ticks)

    def run_for_ms(self, ms: int) -> None:
        self.run_for(ms * self.profile.ticks_per_ms)

    def run_until(self, tick: int) -> None:
        self.machine.run_until(tick)

    def stray_read(self, pins: tuple[int, ...]) -> None:
        """The firmware's erroneous ``digitalRead()`` of step pins (StepperDemo `r`)."""
        self.stray_reads += len(pins)
        for ch in self.channels:  # (once per loop pass while `r` is on: one look per channel)
            if ch.step_pin in pins and ch.step_pin_high():
                self.stray_reads_during_pulse += pins.count(ch.step_pin)

    def channel_for_pin(self, step_pin: int) -> SimChannel | None:
        for ch in self.channels:
            if ch.step_pin == step_pin:
                return ch
        return None

    # ----------------------------------------------------------- observers
    @property
    def pin_states(self) -> PinStates:
        return self.machine.pins

    def deliver_edges(self) -> None:
        self.machine.outputs.deliver_until(self.machine.now)
