"""FastAccelStepper's ramp as a planner: the ramp generator fills the command queue.

Requests (move, run, stop ...) go to the :class:`~fas.ramp.generator.RampGenerator`;
the periodic task's :meth:`RampPlanner.fill` asks it for commands until the queue
holds the forward-planning time.  Behind a deep queue (a device on a serial link,
whose channel can *cut* its queue) the planner keeps the ramp's state after every
command it wrote, so that a stop can drop the commands the motor has not reached
and plan the stop from the first point the channel can still cut at.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..codes import RAMP_DIRECTION_COUNT_UP, MoveResult
from ..planner import Planner, PlannerChange, PlannerHost
from ..queue import AQE_OK, i32
from .generator import _IDLE, RampGenerator

if TYPE_CHECKING:  # pragma: no cover
    from ..motion import MotionSettings
    from .control import RampRw

Snapshot = tuple[int, tuple["RampRw", int, "MotionSettings"]]


class RampPlanner(Planner):
    """The default planner of every stepper (see the module text)."""

    def __init__(self, host: PlannerHost) -> None:
        super().__init__(host)
        p = host.profile
        self.queue = host.queue
        self.rg = RampGenerator(p.ticks_per_s, p.min_cmd_ticks, p.log2_ticks_per_s,
                                p.log2_ticks_per_s_div_sqrt2, p.log2_accel_factor,
                                host.settings)
        self.fill_calls = 0
        self.commands_generated = 0
        # ramp state after each planned command, by the write index that follows it:
        # the points a deep queue (serial backend) can be cut back to
        self._snapshots: list[Snapshot | None] | None = (
            [None] * 256 if self.queue.channel.supports_cut else None)

    def attach(self, previous: Planner | None) -> None:
        self.rg.set_target_position(self.queue.queue_end_pos)  # go on from the queue's end

    # ------------------------------------------------------------- requests
    def check_move(self, delta: int) -> MoveResult:
        if delta < 0 and not self.host.has_direction_pin():
            return MoveResult.ERR_NO_DIRECTION_PIN
        return MoveResult.OK

    def check_held(self) -> MoveResult:
        return self.rg.check_valid_config()

    def move(self, delta: int) -> MoveResult:
        res = self.rg.move(delta)
        self.host.wake()
        return res

    def move_to(self, position: int) -> MoveResult:
        res = self.rg.move_to(position, self.queue.queue_end_pos)
        self.host.wake()
        return res

    def run(self, count_up: bool) -> MoveResult:
        res = self.rg.start_run(count_up)
        self.host.wake()
        return res

    def keep_running(self) -> None:
        self.rg.set_keep_running()
        self.host.wake()

    def keep_speed(self) -> None:
        """``moveByAcceleration(0)``: both speed settings go through
        ``setSpeedInTicks()``'s check, so a period of 0 (not running) or a stepper
        without a speed leaves the speed as it was (undefined stays undefined)."""
        rg = self.rg
        settings = self.host.settings
        fastest = self.fastest_period_ticks()
        max_speed = rg.speed_in_ticks()
        settings.set_speed_checked(self.planned_period_ticks(), fastest)
        settings.set_acceleration(1)  # keeps the current speed
        self.apply_settings()
        self.host.wake()
        settings.set_speed_checked(max_speed, fastest)

    def apply_settings(self) -> None:
        self.rg.apply_speed_acceleration()

    def stop(self) -> None:
        self.rg.initiate_stop()
        self._cut_queue(immediate=False)
        self.host.wake()

    def force_stop(self) -> None:
        self.queue.ignore_commands = True
        self.rg.immediate_stop()
        self._cut_queue(immediate=True)
        self.host.wake()

    def force_stop_at(self, position: int) -> None:
        q = self.queue
        q.ignore_commands = True
        self.rg.stop_ramp()
        q.force_stop()
        q.queue_end_pos = i32(position)
        self.rg.set_target_position(position)

    def single_step(self, count_up: bool) -> None:
        self.queue.ignore_commands = False
        self.host.write(self.host.profile.min_cmd_ticks, 1, count_up, True)

    def positions_shifted(self, delta: int) -> None:
        self.rg.advance_target_position(delta)

    # ---------------------------------------------------------------- state
    def is_running(self) -> bool:
        q = self.queue
        return q.is_running() or self.rg.is_ramp_generator_active() or not q.is_queue_empty()

    def is_active(self) -> bool:
        return self.rg.is_ramp_generator_active()

    def is_running_continuously(self) -> bool:
        return self.rg.is_running_continuously()

    def is_stopping(self) -> bool:
        return self.rg.is_stopping()

    def ramp_state(self) -> int:
        return self.rg.ramp_state()

    def target_pos(self) -> int:
        return self.rg.target_pos

    def steps_to_stop(self) -> int:
        return self.rg.steps_to_stop()

    def current_speed(self, realtime: bool) -> tuple[int, bool]:
        valid = False
        ticks, count_up = 0, True
        if realtime:
            valid, ticks, count_up = self.queue.actual_ticks_with_direction()
        if not valid:
            rg = self.rg
            if rg.is_ramp_generator_active():
                ticks = rg.current_period_in_ticks()
                count_up = (rg.ramp_state() & RAMP_DIRECTION_COUNT_UP) != 0
            else:
                ticks = 0
        return ticks, count_up

    def planned_period_ticks(self) -> int:
        rg = self.rg
        return rg.current_period_in_ticks() if rg.is_ramp_generator_active() else 0

    def current_acceleration(self) -> int:
        return self.rg.current_acceleration()

    def fastest_period_ticks(self) -> int:
        return self.queue.max_speed_in_ticks

    def needs_task(self) -> bool:
        rg = self.rg
        q = self.queue
        return (rg.is_ramp_generator_active() or rg.force_immediate_stop or q.is_running()
                or not q.is_queue_empty())

    def wants_task_at_rest(self) -> bool:
        return self.rg.force_immediate_stop

    # ------------------------------------------------------------ ramp task
    def fill(self) -> int:
        """Plan commands until the queue holds the forward-planning time; returns count."""
        rg = self.rg
        # (rg.is_ramp_generator_active(), written out: every task, for every stepper)
        if rg.rw.ramp_state == _IDLE or not rg.has_valid_config():
            return 0
        host = self.host
        q = self.queue
        q.ignore_commands = False
        self.fill_calls += 1
        delayed_start = not q.is_running()
        need_delayed_start = False
        ticks_prepared = q.fill_ticks_in_queue()
        planning = host.settings.forward_planning_ticks
        if not delayed_start:  # a running queue: what the backend's link needs, too
            planning += host.backend.planning_extra_ticks
        snaps = self._snapshots
        cfg = rg.config
        cfg.take_converted()  # none from before this fill
        ch = q.channel
        ch.ramp_ended = False
        ch.ramp_cubic_update = False
        ch.ramp_jump_maths = 0
        write = host.write
        generated = 0
        queue_len = q.queue_len
        # ticks_in_queue() brought the channel's view up to date; the task runs at one
        # instant and only appends, so the count follows from the indices
        while True:
            entries = (q.next_write_idx - q.read_idx) & 0xFF
            if (entries >= queue_len or (ticks_prepared >= planning and entries > 1)
                    or not rg.is_ramp_generator_active()):
                break
            if snaps is not None and q.channel.cut_pending and rg.apply_pending():
                break  # a new request waits until the cut is confirmed or undone
            res = AQE_OK
            cmd = rg.get_next_command(q.queue_end_pos, q.queue_end_count_up)
            converted = cfg.take_converted()
            if rg.cubic_updated:
                ch.ramp_cubic_update = True
            if rg.jump_maths:
                ch.ramp_jump_maths = rg.jump_maths
            if cmd.ticks != 0:
                if converted is not None:  # the command's period came from the ramp step
                    q.channel.ramp_converted(*converted)
                q.channel.ramp_continuous = cfg.parameters.keep_running
                ch.ramp_path = cmd.path
                res = write(cmd.ticks, cmd.steps, cmd.count_up, not delayed_start)
                generated += 1
            if res == AQE_OK:
                rg.after_command_enqueued(cmd)
                if snaps is not None:
                    snaps[q.next_write_idx] = (q.entries_added, rg.snapshot())
                need_delayed_start = delayed_start
                ticks_prepared += cmd.ticks * cmd.steps if cmd.steps > 1 else cmd.ticks
            if cmd.ticks == 0:
                q.channel.ramp_ended = True  # the ramp's end (no more commands)
                break
            if res != AQE_OK:
                if res.retry:
                    break
                host.report_abort(res, cmd)
                rg.stop_ramp()
                delayed_start = False
        if need_delayed_start:
            write(None, 0, True, True)
        self.commands_generated += generated
        return generated

    def _cut_queue(self, immediate: bool) -> None:
        """On a backend with a deep queue: drop the planned commands the motor has not
        reached yet, back to the first point the backend can still cut at, and plan the
        stop from there (see :meth:`fas.channel.QueueChannel.cut`)."""
        snaps = self._snapshots
        if snaps is None:
            return
        q = self.queue
        ch = q.channel
        first = ch.cut_index()
        if first is None:
            return
        w = q.next_write_idx
        added = q.entries_added
        c = first
        snap = None
        while c != w:
            snap = snaps[c]
            if snap is not None and added - snap[0] == (w - c) & 0xFF:
                break
            c = (c + 1) & 0xFF
        else:
            return  # no command boundary before the end: the queue ends soon enough
        rg = self.rg
        before = rg.snapshot()
        host = self.host

        def refused() -> None:  # the cut came too late: stop from the queue's end
            rg.restore(before)
            if immediate:
                q.ignore_commands = True
                rg.immediate_stop()
            host.wake()

        ch.cut(c, refused)
        assert snap is not None
        rg.restore(snap[1])


def make(host: PlannerHost, current: Planner | None,
         kept: Planner | None) -> tuple[PlannerChange, Planner | None]:
    """The ramp for a stepper: the one it had before (its state goes on), else a new
    one.  Refused while the planner in use has motion to plan, or runs a queue of its
    own (the command queue may run on: its position goes on under the ramp)."""
    if current is not None and current is kept:
        return PlannerChange.OK, None
    if current is not None and (current.is_active() or (current.queue is not host.queue
                                                        and current.is_running())):
        return PlannerChange.RUNNING, None
    return PlannerChange.OK, kept if kept is not None else RampPlanner(host)
