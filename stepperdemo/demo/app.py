"""StepperDemo, the firmware's serial console program, running on a backend's clock.

The program is StepperDemo's main loop: each pass takes at most one input character,
a completed command is executed in the current mode, status lines are printed every
100 ms while a stepper runs, and the usage is printed when the last stepper stops.
Everything it prints goes through :meth:`StepperDemo.print`, which on the simulated
backend is a 115200-baud UART whose buffer makes long prints block the loop, as on
the chip.

Two input modes: *scripted* (``stepperdemo -c``) behaves like the firmware built with
a compiled-in input line (the mode the conformance data was recorded in: ``W`` prints
nothing and only holds the input; test/config usage is not printed); *interactive*
takes characters as they are typed.
"""

from __future__ import annotations

from collections import deque
from dataclasses import replace
from typing import Callable

from fas import Engine
from fas.backend import Backend
from fas.codes import PIN_UNDEFINED, RAMP_STATE_MASK
from fas.sim.timing import sim_timing

from .. import messages as msg
from ..program import LoopProgram
from . import quickstep as qs_console
from .build import DemoConfig, demo_build
from .command_registry import COMMANDS
from .command_table import CommandTable, Mode
from .testseq import TEST_STATE_ERROR, SeqSlot

# the loop compares its mode in every pass: an Enum member read as a class attribute
# costs a metaclass lookup, a module constant does not
_NORMAL, _TEST, _GCODE = Mode.NORMAL, Mode.TEST, Mode.GCODE


class StepperDemo(LoopProgram):
    """The StepperDemo program on a backend; drive it with :meth:`run_until`."""

    title = "StepperDemo"
    #: what the loop runs a completed command with (.command_registry)
    command_table: CommandTable = COMMANDS

    def __init__(self, backend: Backend, *, scripted: bool = True,
                 output: Callable[[bytes], None] | None = None,
                 test_mode_wait: bool = False, pin_config: int | None = None) -> None:
        self.backend = backend
        self.scripted = scripted
        # the digit that answers every start-up prompt for a pin configuration (ESP32,
        # Pico), as upstream's hardware tests do (STEPPER_CONFIG); None: nobody answers
        # a scripted run (the 5 s wait), an interactive user types it
        self.pin_config = pin_config
        self.output = output
        self.transcript = bytearray()
        # extension, off by default: `w<ms>` also in test mode (the firmware answers
        # "Unknown command" there)
        self.test_mode_wait = test_mode_wait
        self.restarts = 0
        # the firmware build the simulated chip runs (fas.sim.builds; None elsewhere)
        self.firmware_build: str | None = getattr(backend, "build", None)
        self.build = demo_build(self.profile, self.firmware_build)
        if self.firmware_build is None and self.build.w_every_pass:
            # a held W's every pass is the simulated chip's loop (its sections, its status
            # lines' phase); beside a device this program is the host's and skips them
            self.build = replace(self.build, w_every_pass=False)
        self._timing = sim_timing(self.profile, self.firmware_build)
        # a write call to the console's serial driver (USB CDC: not nothing)
        self._call_ticks = self._timing.console_call_ticks
        # a print's body from a buffer beyond the timing's char_ticks (0: none)
        self._buffer_char_delta = (self.build.buffer_char_ticks - self._timing.char_ticks
                                   if self.build.buffer_char_ticks else 0)
        self._reset_state()
        self.rx: deque[int] = deque()
        self.script = b""
        self.script_pos = 0
        self.script_loaded = False
        self.input_consumed_at: int | None = None
        self.input_dropped = 0
        self.test_failed_count = 0
        self.tests_completed = 0
        self.passes = 0
        self.commands = 0
        self.rejected = 0
        self.ramp_aborts = 0
        self.listeners: list[Callable[[str, bytes], None]] = []

    def _reset_state(self) -> None:
        """Power-on state of the firmware's globals (also after an ESP32 restart)."""
        self.engine = Engine(self.backend)
        self.engine.ramp_abort_listener = self._ramp_abort
        self.steppers: list = [None] * self.profile.max_steppers
        self.mode = _NORMAL
        self.test_ongoing = False
        self.test_slots = [SeqSlot() for _ in range(self.profile.max_steppers)]
        self.in_buffer = bytearray(256)
        self.write_ptr = 0
        self.read_ptr = 0
        self.out_buffer = bytearray()
        self.stopped = True
        self.verbose = True
        self.usage_info = True
        self.speed_in_milli_hz = False
        self.last_time = 0
        self.selected = 0
        self.pause_ms = 0
        self.pause_start = 0
        self.simulate_digital_read_error = False
        self.simulate_blocked_isr = False
        self._wake_by_clock = False  # the idle loop's next wake is a deadline of millis()
        self.waiting_interactive = False  # interactive W holding the input
        self.restart_pending = False
        self._setup_done = False
        self._setup_started = False
        self._select_start_ms = 0  # the start-up prompt for a pin configuration
        self.config_index = 0
        self.demo_config: DemoConfig = DemoConfig("", self.build.steppers)
        self.qs_hold = None  # a QuickStep stepper whose move waits for FIFO room
        self.gcode = None  # issue 12: the G-code machine of the g mode
        self.gcode_failures = 0  # issue 24: g-mode lines refused or never ended (exit 1)

    # ------------------------------------------------------------- output
    def print(self, text: str | bytes) -> None:
        scan = None
        if isinstance(text, str):
            scan = msg.TABLE_SCAN.get(text)
            data = text.encode("utf-8")
        else:
            data = bytes(text)
        if scan is None:
            if data:
                call = self._call_ticks  # one write call for the whole text
                d = self._buffer_char_delta  # the body's characters from a buffer
                self.backend.console_write(data, [call + d] + [d] * (len(data) - 1)
                                           if call or d else None)
        else:
            self._print_from_table(data, scan)
        if not data:
            return
        self.transcript += data
        if self.output is not None:
            self.output(data)

    def _print_from_table(self, data: bytes, scan: tuple[int, int, int, int]) -> None:
        """CPU time of the firmware's table look-ups, interleaved with the output.

        What is read before the first character is spent first; the look-ups made
        while the text goes out are spread evenly over its characters.
        """
        lead_bytes, lead_lookups, total_bytes, total_lookups = scan
        p = self.build
        b = self.backend
        b.app_spend(lead_bytes * p.msg_scan_byte_ticks
                    + lead_lookups * p.msg_lookup_ticks)
        rest = ((total_bytes - lead_bytes) * p.msg_scan_byte_ticks
                + (total_lookups - lead_lookups) * p.msg_lookup_ticks)
        n = len(data)
        if n == 0:
            b.app_spend(rest)
            return
        share, extra = divmod(rest, n)
        share += self._call_ticks  # the table's text goes out a character per call
        b.console_write(data, [share + 1] * extra + [share] * (n - extra))

    def lookup(self, text: str) -> None:
        """CPU time the firmware spends on a text it looks up but does not print."""
        self._print_from_table(b"", msg.TABLE_SCAN[text])

    def print_number(self, value: int) -> None:
        """A number as the firmware prints it: a minus sign, then the digits, which
        ``Print::printNumber`` computes first (one 32-bit division each)."""
        p = self.build
        text = str(value)
        if value < 0:
            self.print("-")
            text = text[1:]
        self.backend.app_spend(p.print_call_ticks + len(text) * p.print_digit_ticks)
        self.print(text)

    def println_number(self, value: int) -> None:
        self.print_number(value)
        self.println()

    def println(self, text: str | bytes = "") -> None:
        if not text and self.build.print_call_ticks:
            self.backend.app_spend(self.build.print_call_ticks)  # println("")
        if text and self._call_ticks and not (isinstance(text, str)
                                              and text + msg.CRLF in msg.TABLE_SCAN):
            self.backend.app_spend(self._call_ticks)  # println(x): print(x), then "\r\n"
        if isinstance(text, str):
            self.print(text + msg.CRLF)
        else:
            self.print(bytes(text) + b"\r\n")

    # -------------------------------------------------------------- setup
    @property
    def demo_steppers(self):
        """The pin configuration in use (chosen at start-up on ESP32 and the Pico)."""
        return self.demo_config.steppers

    def setup(self) -> None:
        """The firmware's ``setup()``.

        Where the firmware first offers its pin configurations (ESP32, Pico), it then
        waits up to 5 s for a digit on the serial line; that wait runs in the
        following loop passes (:meth:`loop_pass`) so that an interactive user can
        answer.  A scripted run has no serial input in that phase: it waits the 5 s.
        """
        if self._setup_started:
            return
        self._setup_started = True
        b = self.backend
        timing = self._timing
        boot = timing.boot_ticks
        lag = timing.timer0_lag_ticks  # timer 0 starts later, setup() where it was
        if self.script_loaded:  # the built-in line is start-up data copied at reset
            align = timing.boot_data_align
            copied = -(-(len(self.script) + timing.boot_data_bytes) // align) * align
            boot += copied * timing.boot_script_byte_ticks
            if lag:
                t_align = timing.timer0_data_align
                lag += (-(-copied // t_align) * t_align - copied) * timing.boot_script_byte_ticks
        b.app_spend(boot + lag)
        b.app_started()
        b.app_spend(timing.core_main_ticks + self.build.setup_head_ticks - lag)
        configs = self.build.configs
        if not configs:
            self._finish_setup()
            return
        self.println(msg.SELECT_PIN_CONFIG)
        for i, cfg in enumerate(configs):
            self.print(msg.CONFIG_ENTRY_INDENT)
            self.print(str(i))
            self.print(msg.CONFIG_ENTRY_SEP)
            self.println(cfg.name)
        self.println(msg.PRESS_NUMBER_TO_SELECT)
        self._select_start_ms = b.millis()
        if self.pin_config is not None:  # the digit is on the line: the first poll takes it
            self._take_config_digit(self.pin_config)
            return
        if self.scripted:
            while not self._setup_done:
                self._select_pass()

    def _select_pass(self) -> None:
        """One turn of the start-up prompt's wait: poll a character, else 10 ms delay."""
        b = self.backend
        if self.rx and not self.scripted:
            ch = self.rx.popleft()
            if 0x30 <= ch <= 0x39:
                self._take_config_digit(ch - 0x30)
                return
        if ((b.millis() - self._select_start_ms) & 0xFFFFFFFF) >= self.build.config_wait_ms:
            self._finish_setup()
            return
        b.app_wait_until(b.now() + 10 * self.profile.ticks_per_ms)

    def _take_config_digit(self, n: int) -> None:
        """A digit answers the prompt: that configuration if the build has it, else 0."""
        if n < len(self.build.configs):
            self.config_index = n
        self._finish_setup()

    def _finish_setup(self) -> None:
        b = self.backend
        p = self.profile
        configs = self.build.configs
        if configs:
            self.demo_config = configs[self.config_index]
            self.print(msg.USING_CONFIG)
            self.print(str(self.config_index))
            self.print(msg.CONFIG_ENTRY_SEP)
            self.println(self.demo_config.name)
        if p.family == "esp32":
            self.print(msg.ESP32_LOG_START)
            self.println()
            self.print(msg.ESP_IDF)
            self.print(str(p.idf_version[0]))
            self.print(".")
            self.print(str(p.idf_version[1]))
            self.println()
        self._setup_done = True
        self.print(msg.BANNER_VERSION)
        self.print(msg.BANNER_F_CPU)
        self.println_number(p.f_cpu)
        self.print(msg.BANNER_TICKS)
        self.println_number(p.ticks_per_s)
        self.print(msg.BANNER_STEPPERS)
        self.println_number(p.max_steppers)
        self.engine.init()
        if self.build.debug_led_pin != PIN_UNDEFINED:
            self.engine.set_debug_led(self.build.debug_led_pin)
        b.app_spend(self.build.setup_steppers_ticks)
        for i, cfg in enumerate(self.demo_steppers[:p.max_steppers]):
            if cfg.step == PIN_UNDEFINED:
                break
            if p.driver_select:
                s = self.engine.stepper_connect_to_pin(cfg.step, cfg.driver)
            else:
                s = self.engine.stepper_connect_to_pin(cfg.step)
            if s is None:
                break
            s.set_direction_pin(cfg.direction, cfg.direction_high_counts_up,
                                cfg.dir_change_delay_us)
            s.set_enable_pin(cfg.enable_low_active, True)
            s.set_enable_pin(cfg.enable_high_active, False)
            s.set_auto_enable(cfg.auto_enable)
            s.set_delay_to_enable(cfg.on_delay_us)
            s.set_delay_to_disable(cfg.off_delay_ms)
            self.steppers[i] = s
        self.usage()

    def restart(self) -> None:
        """ESP32's ``ESP.restart()`` / watchdog reset: the chip reboots, the firmware
        starts again from ``setup()``.  Motion stops, the library starts empty; the
        input that follows is taken after the new start-up."""
        self.backend.reset_chip()
        self.restarts += 1
        self._reset_state()
        self.restart_pending = True
        self.read_ptr = self.write_ptr = 0
        self.setup()

    # --------------------------------------------------------------- input
    def load_script(self, line: str | bytes) -> None:
        """Scripted input: the firmware appends one space so the last command ends."""
        data = line.encode("utf-8") if isinstance(line, str) else bytes(line)
        self.script = data + b" "
        self.script_pos = 0
        self.script_loaded = True
        self.input_consumed_at = None

    def feed(self, text: str | bytes) -> None:
        """Interactive input: characters as they arrive on the serial line."""
        data = text.encode("utf-8") if isinstance(text, str) else bytes(text)
        self.rx.extend(data)

    def input_pending(self) -> bool:
        if self.read_ptr != self.write_ptr:
            return True
        if self.scripted:
            return self.script_pos < len(self.script)
        return bool(self.rx)

    # ---------------------------------------------------------- info lines
    @property
    def selected_stepper(self):
        return self.steppers[self.selected]

    def _info(self, s, long_info: bool) -> None:
        self.backend.app_spend(self.build.info_ticks)
        self.print("@")
        if self.profile.has_pulse_counter and s.pulse_counter_attached():
            pcnt_1 = s.read_pulse_counter()
            pos = s.get_current_position()
            pcnt_2 = s.read_pulse_counter()
            self.print_number(pos)
            self.print(msg.PCNT_OPEN)
            self.print_number(pcnt_1)
            self.print(msg.PCNT_CLOSE)
            if pcnt_1 != pcnt_2:
                self.print(msg.PCNT_OPEN)
                self.print_number(pcnt_2)
                self.print(msg.PCNT_CLOSE)
        else:
            self.print_number(s.get_current_position())
        if s.is_running():
            if s.is_running_continuously():
                self.print(msg.STATUS_NONSTOP)
            else:
                self.print(msg.STATUS_TARGET)
                self.print_number(s.target_pos())
            self.print(msg.STATUS_QUEUE_END)
            self.print_number(s.get_position_after_commands_completed())
            self.print(msg.STATUS_V)
            if self.speed_in_milli_hz:
                self.print_number(s.get_current_speed_in_milli_hz())
                self.print(msg.STATUS_MSTEPS)
            else:  # before the first command is queued the firmware prints its
                # "undefined" period: v=268435455us/4294967295ticks (issue 26: kept,
                # it is what the original prints - conformance d25, d26, d30)
                self.print_number(s.get_period_in_us_after_commands_completed())
                self.print(msg.STATUS_US)
                self.print_number(s.get_period_in_ticks_after_commands_completed())
                self.print(msg.STATUS_TICKS)
            if s.is_ramp_generator_active():
                state = s.ramp_state() & RAMP_STATE_MASK
                text = msg.RAMP_STATE_TEXT.get(state)
                if text is not None:
                    self.print(text)
                else:
                    self.print_number(s.ramp_state())
            else:
                self.print(msg.STATUS_MANUAL)
            if qs_console.quickstep_of(s) is not None:
                self.print(qs_console.status_suffix(s))
        elif long_info:
            self.print(msg.ACCELERATION_STATUS)
            self.print_number(s.get_acceleration())
            if self.speed_in_milli_hz:
                self.print(msg.SPEED_STATUS_FREQ)
                self.print_number(s.get_speed_in_milli_hz())
            else:
                self.print(msg.SPEED_STATUS_TIME)
                self.print_number(s.get_speed_in_us())
            if qs_console.quickstep_of(s) is not None:
                self.print(qs_console.table_suffix(self, s))
        self.print(" ")

    def output_info(self, only_running: bool) -> None:
        need_ln = False
        scan = self.build.info_scan_ticks
        for i, s in enumerate(self.steppers):
            if s is None:
                continue
            if scan:
                self.backend.app_spend(scan)
            if not only_running:
                self.print(msg.TABLE_SELECTED if i == self.selected else msg.TABLE_OTHER)
            if not only_running or s.is_running():
                self.print("M")
                self.print_number(i + 1)
                self.print(": ")
                self._info(s, not only_running)
                if self.profile.driver_select and not s.is_running():
                    self.print(msg.DRIVER_TYPE_SEP + s.driver_type_string())
                if not only_running:
                    self.println()
                else:
                    need_ln = True
        if need_ln:
            self.println()

    def stepper_info(self) -> None:
        self.output_info(False)
        if self.simulate_blocked_isr:
            self.print(msg.LONG_INTERRUPT_BLOCK_ENABLED)
        if self.simulate_digital_read_error:
            self.print(msg.STRAY_DIGITAL_READ_ENABLED)

    def usage(self) -> None:
        p = self.profile
        if self.mode == _NORMAL:
            text = msg.usage_normal(esp32=p.family == "esp32", avr=p.family == "avr",
                                    small=self.build.small_build)
            if (text in msg.TABLE_SCAN or not self.build.small_build
                    or not self.build.msg_scan_byte_ticks):
                self.print(text)
            else:  # the small build's usage (ATmega32U4): from its own table, which is
                # not counted; the full text's look-ups in proportion to its length
                full = msg.TABLE_SCAN[msg.USAGE_NORMAL]
                scan = tuple(x * len(text) // len(msg.USAGE_NORMAL) for x in full)
                data = text.encode("utf-8")
                self._print_from_table(data, scan)
                self.transcript += data
                if self.output is not None:
                    self.output(data)
        elif self.build.small_build:
            pass  # the ATmega32U4 build has no test and config usage texts
        elif not self.scripted:
            self.print(msg.USAGE_TEST if self.mode == _TEST else msg.USAGE_CONFIG)
        else:  # built-in-input firmware: the text is empty, the table is still scanned
            self.lookup(msg.USAGE_TEST if self.mode == _TEST else msg.USAGE_CONFIG)
        self.stepper_info()

    # ------------------------------------------------------------ the loop
    def any_running(self) -> bool:
        for s in self.steppers:  # noqa: SIM110 - asked in every pass: a loop, no generator
            if s is not None and s.is_running():
                return True
        return False

    def loop_pass(self) -> None:
        """One pass of StepperDemo's ``loop()``."""
        b = self.backend
        self.passes += 1
        if not self._setup_done:
            self._select_pass()
            return
        take_input = True
        if self.waiting_interactive:  # interactive W: the firmware busy-waits in it
            if self.selected_stepper.is_running():
                b.app_spend(self.build.loop_pass_ticks)
                return
            self.waiting_interactive = False
            self.println(msg.STOPPED)
            take_input = False  # the rest of the pass that took the W
        ch = 0
        if not take_input:
            pass
        elif self.scripted:
            if self.script_pos < len(self.script):
                if self.mode != _GCODE or self.gcode.room():  # g mode: wait for ring room
                    ch = self.script[self.script_pos]
                    self.script_pos += 1
            elif self.read_ptr == self.write_ptr and self.input_consumed_at is None:
                self.input_consumed_at = b.now()
                if self.mode == _GCODE:
                    self.gcode.script_ended()
        elif self.rx and (self.mode != _GCODE or not self.gcode.leaving):
            ch = self.rx.popleft()
        if ch and self.mode == _GCODE:  # issue 24: bytes go to Grbl's receive path
            self.gcode.receive(bytes((ch,)))
            ch = 0
        if ch:
            if ((self.write_ptr + 1) & 0xFF) == self.read_ptr:
                self.read_ptr = (self.read_ptr + 1) & 0xFF
                self.input_dropped += 1  # the oldest unread byte, as the firmware's ring
            self.in_buffer[self.write_ptr] = ch
            self.write_ptr = (self.write_ptr + 1) & 0xFF

        path = 0  # CPU time of this pass's path beyond loop_pass_ticks
        if not take_input:
            pass
        elif self.pause_ms > 0:
            path = self.build.loop_pause_ticks
            if ((b.millis() - self.pause_start) & 0xFFFFFFFF) >= self.pause_ms:
                self.pause_ms = 0
                if self.build.pause_end_ticks:
                    b.app_spend(self.build.pause_end_ticks)
                self.print(msg.WAIT_COMPLETE)
        elif self.qs_hold is not None:
            qs_console.service_hold(self)
        elif self.read_ptr != self.write_ptr:
            c = self.in_buffer[self.read_ptr]
            self.read_ptr = (self.read_ptr + 1) & 0xFF
            if c not in (0x20, 0x0A, 0x0D):
                # taken where the firmware takes it: before the rest of the pass (its
                # `e` block included), as a command's cost (_spend_command)
                if self.build.loop_char_ticks:
                    b.app_spend(self.build.loop_char_ticks)
                if len(self.out_buffer) == 255:
                    self.out_buffer.clear()
                self.out_buffer.append(c)
            else:
                if self.out_buffer:
                    cmd = bytes(self.out_buffer)
                    self.commands += 1
                    self._spend_command(cmd)
                    if not self.command_table.dispatch(self, cmd):
                        self.rejected += 1
                        self.print(msg.UNKNOWN_COMMAND)
                        self.println(cmd)
                    elif self.build.cmd_tail_ticks and not self.waiting_interactive:
                        tail = self.build.cmd_tail_ticks.get(chr(cmd[0]), 0)
                        if tail:
                            b.app_spend(tail)
                    if self.waiting_interactive or self.restart_pending:
                        # W blocks inside the command; a restart ends the old program
                        self.restart_pending = False
                        self.out_buffer.clear()
                        b.app_spend(self.build.loop_pass_ticks)
                        return
                self.out_buffer.clear()

        ms = b.millis()
        if self.simulate_digital_read_error:
            pins = tuple([s.get_step_pin() for s in self.steppers if s is not None])
            b.stray_read(pins)
            # spent where they run: before the `e` check below (docs/timing-model.md)
            b.app_spend(len(pins) * self.build.loop_stray_read_ticks)
        if self.simulate_blocked_isr:
            path += self.build.e_check_ticks
            if self.build.e_read_block_ticks:
                # the check lies this far after the read: spent before it, not after
                b.app_spend(self.build.e_read_block_ticks)
                path -= self.build.e_read_block_ticks
            if (ms & 0xFF) < 0x40:
                b.block_interrupts(self.build.irq_block_ticks)
            else:
                path -= self.build.e_outside_saved_ticks

        if self.mode == _TEST:
            if self.test_ongoing:
                self._run_tests(ms)
        elif self.mode == _GCODE:  # issue 12: G-code answers, it prints no status
            self.gcode.poll()
        else:
            running = False
            build = self.build
            for s in self.steppers:  # running |= stepper[i]->isRunning(), for each
                if s is not None:
                    if s.is_running():
                        running = True
                        path += build.loop_running_stepper_ticks
                    else:
                        path += build.loop_idle_stepper_ticks
            if running and ((ms - self.last_time) & 0xFFFFFFFF) >= 100:
                if self.verbose:
                    lead = build.status_lead_ticks
                    if lead:  # the pass's CPU before the status line's first character
                        b.app_spend(lead)
                        path -= lead
                    self.output_info(True)
                self.last_time = ms
            if not self.stopped and not running:
                self.output_info(True)
                if self.usage_info:
                    self.usage()
            self.stopped = not running
        ticks = self.build.loop_pass_ticks + path
        sections = self._w_pass_sections(ticks)
        if sections:
            b.app_spend_in(ticks, (ticks, sections))
        else:
            b.app_spend(ticks)

    def _w_pass_sections(self, ticks: int) -> tuple[tuple[int, int], ...]:
        """The sections with interrupts off of a held W's pass of ``ticks`` run one by one
        (DemoBuild.w_every_pass with loop_sections and w_pass_millis_before_end; empty:
        none followed)."""
        build = self.build
        before_end = build.w_pass_millis_before_end
        poll = build.loop_poll_running
        if (not before_end or not build.loop_sections or poll is None
                or not build.w_every_pass or self.mode != _NORMAL or self.simulate_blocked_isr
                or not self._held_by_w() or not self.any_running()):
            return ()
        width = poll[1][0][1]
        return ((0, width), (max(width, ticks - before_end), width))

    def _spend_command(self, cmd: bytes) -> None:
        """CPU time of parsing and executing a command, without its prints."""
        p = self.build
        ticks = p.cmd_ticks.get(chr(cmd[0]), p.cmd_default_ticks)
        ticks += (len(cmd) - 1) * p.cmd_arg_char_ticks
        if ticks:
            self.backend.app_spend(ticks)

    def _run_tests(self, ms: int) -> None:
        finished = True
        for i, slot in enumerate(self.test_slots):
            if slot.test is not None and slot.state != TEST_STATE_ERROR:
                res = slot.test(self, self.steppers[i], slot, ms)
                if res:
                    slot.test = None
                finished = finished and res
        if finished:
            self.test_ongoing = False
            failed = False
            self.stepper_info()
            for slot in self.test_slots:
                slot.test = None
                if slot.state == TEST_STATE_ERROR:
                    failed = True
            self.tests_completed += 1
            if failed:
                self.test_failed_count += 1
                self.print(msg.FAILED_STATUS)
            else:
                self.print(msg.PASS_STATUS)
            self.print(msg.TEST_COMPLETED)
        else:
            now = self.backend.millis()
            if ((now - self.last_time) & 0xFFFFFFFF) >= 100:
                if self.verbose:
                    self.output_info(True)
                self.last_time = now

    # ---------------------------------------------------- driving the loop
    def _idle(self) -> bool:
        """Would the next pass only look around (so that passes can be skipped)?

        Skipping is exact: every state the loop looks at changes only at a machine
        event or when ``millis()`` reaches a deadline, and :meth:`_wake_time` wakes
        the loop at the earliest of those.
        """
        if not self._setup_done:
            return False  # the start-up prompt polls the serial line every 10 ms
        if self.waiting_interactive:
            return True  # only the selected stepper's stop can end W
        if self.simulate_digital_read_error:
            return False  # every pass makes a stray read that we count
        if self.simulate_blocked_isr and (self.build.e_every_pass
                                          or (self.backend.millis() & 0xFF) < 0x40):
            return False  # every pass blocks interrupts in this window
        if (self.build.w_every_pass and self.mode == _NORMAL and not self.simulate_blocked_isr
                and self._held_by_w() and self.any_running()):
            return False  # every pass of a held W reads millis() where its chain is
        if not self._input_idle():
            return False
        if self.mode == _TEST and self.test_ongoing:
            return all(slot.test is None or slot.state == TEST_STATE_ERROR or slot.idle
                       for slot in self.test_slots)
        if self.mode == _GCODE:
            wake = self.gcode.wake_tick()
            return wake is None or wake > self.backend.now()
        return True

    def _input_idle(self) -> bool:
        """No input character can be taken or processed in the next pass."""
        if (self.pause_ms > 0 or self.waiting_interactive or self.qs_hold is not None
                or self._held_by_w()):
            return True
        if self.read_ptr != self.write_ptr:
            return False
        if self.scripted:
            if self.mode == _GCODE and self.script_pos < len(self.script):
                return not self.gcode.room()  # a script waits until Grbl would read
            return self.script_pos >= len(self.script) and self.input_consumed_at is not None
        return not self.rx or (self.mode == _GCODE and self.gcode.leaving)

    def _needs_machine_events(self) -> bool:
        """True when the loop must look at every interrupt, as the firmware's passes
        do: a test sequence waits for something in the machine (a stepper to stop,
        ...), an interactive W spins, or the G-code machine waits for queue room.
        Otherwise only a stepper starting or stopping can end an idle wait
        (:meth:`_watch`), besides the clock."""
        if self.waiting_interactive or self.mode == _GCODE:
            return True
        if self.mode != _TEST or not self.test_ongoing:
            return False
        for slot, s in zip(self.test_slots, self.steppers, strict=True):
            if slot.test is None or slot.state == TEST_STATE_ERROR or slot.wake_ms is not None:
                continue
            # a wait for the stop of a running stepper ends with the stop (_watch)
            if not (slot.stop_only and s is not None and s.is_running()):
                return True
        return False

    def _running_key(self) -> list[bool]:
        return [s is not None and s.is_running() for s in self.steppers]

    def _watch(self) -> Callable[[], bool]:
        """A predicate: has any stepper started or stopped since now?"""
        key = self._running_key()
        return lambda: self._running_key() != key

    def _held_by_w(self) -> bool:
        if self.out_buffer or self.pause_ms:
            return False
        n = (self.write_ptr - self.read_ptr) & 0xFF
        if n == 0 or self.in_buffer[self.read_ptr] != 0x57:  # "W"
            return False
        if n > 1 and self.in_buffer[(self.read_ptr + 1) & 0xFF] not in (0x20, 0x0A, 0x0D):
            return False
        s = self.selected_stepper
        return self.mode in (_NORMAL, _TEST) and (
            (s is not None and s.is_running()) or self.test_ongoing)

    def _wake_time(self) -> int | None:
        """Earliest tick at which an idle loop could have something to do."""
        b = self.backend
        self._wake_by_clock = False
        if self.waiting_interactive:  # only the stepper's stop ends the spin (a machine event)
            nxt = b.next_event_time()
            return None if nxt is None else max(nxt, b.now())
        candidates = []
        if self._needs_machine_events():
            nxt = b.next_event_time()
            if nxt is not None:
                candidates.append(nxt)
        machine = len(candidates)
        if self.pause_ms > 0:
            candidates.append(b.tick_at_millis(self.pause_start + self.pause_ms))
        # the 100 ms status line: printed in the normal and config modes while a stepper
        # runs, and by the tests while they run (in test mode nothing else renews it)
        if ((self.mode == _TEST and self.test_ongoing)
                or (self.mode not in (_TEST, _GCODE) and self.any_running())):
            candidates.append(b.tick_at_millis(self.last_time + 100))
        if self.simulate_blocked_isr:
            candidates.append(b.tick_at_millis((b.millis() | 0xFF) + 1))
        if self.mode == _TEST and self.test_ongoing:  # tests run in test mode only
            for slot in self.test_slots:
                if slot.test is not None and slot.wake_ms is not None:
                    candidates.append(b.tick_at_millis(slot.wake_ms))
        clock = min(candidates[machine:], default=None)  # the deadlines of millis()
        if self.mode == _GCODE:
            wake = self.gcode.wake_tick()
            if wake is not None:
                candidates.append(wake)
        if not candidates:
            return None
        first = min(candidates)
        self._wake_by_clock = first == clock and first not in candidates[:machine]
        return max(first, b.now())

    def next_wake_tick(self) -> int | None:
        """When the loop next has something to do (None: only new input can wake it).
        A stepper may stop at any interrupt: the next machine event is a candidate."""
        if not self._setup_done or not self._idle():
            return self.backend.now()
        times = [t for t in (self._wake_time(), self.backend.next_event_time())
                 if t is not None]
        return max(min(times), self.backend.now()) if times else None

    def _advance(self, limit: int) -> None:
        """One loop pass, after skipping idle time (never beyond ``limit``).

        While idle the loop only polls: it takes up work at the next deadline of the
        clock, or as soon as a stepper starts or stops, once no interrupt routine
        holds the CPU (``app_wait_until``)."""
        b = self.backend
        if self._idle():
            wake = self._wake_time()
            build = self.build
            if build.loop_sections:  # the loop's critical sections while it polls
                poll = None  # (a stepper runs)
                if (self.mode == _NORMAL and not self.waiting_interactive
                        and self.any_running()):
                    poll = (build.loop_poll_pause if self.pause_ms > 0
                            else build.loop_poll_running)
                b.app_polls(poll)
            if wake is None or wake > limit:
                if not b.app_wait_until(limit, self._watch()):
                    return
            else:  # (a wake due now waits for nothing: no watch to set up)
                waited = wake > b.now()
                changed = b.app_wait_until(wake, self._watch() if waited else None)
                if waited and not changed and self._wake_by_clock and self.build.wake_mid_pass:
                    b.app_spend(self._idle_pass_ticks() // 2)
        elif self.build.w_every_pass:
            self._held_w_passes(limit)
            if b.now() >= limit:  # (the passes reached it: the caller's next pass is not run)
                return
        self.loop_pass()

    def _held_w_passes(self, limit: int) -> None:
        """A held W's passes while nothing they look at changes (DemoBuild.w_every_pass),
        spent by the backend in rounds of two: the pass that takes the `W` and the pass
        whose terminator runs it, which rewinds the input to the `W` again - what
        :meth:`loop_pass` would spend in them, its reads (a stepper running, ``millis()``)
        between each pass's head and rest.  The backend stops before a pass whose reads
        come at the next status line's ``millis()`` or at ``limit``, or that an event
        meets before its reads, and after an event that started or stopped a stepper;
        :meth:`loop_pass` goes on from there."""
        if (self.mode != _NORMAL or self.waiting_interactive or self.simulate_blocked_isr
                or self.simulate_digital_read_error or self.pause_ms or self.qs_hold is not None
                or self.restart_pending or self.stopped or not self.scripted
                or self.script_pos < len(self.script)):
            return
        if (((self.write_ptr - self.read_ptr) & 0xFF) < 2 or not self._held_by_w()
                or not self.any_running()):
            return  # (the W's terminator read: _held_by_w; the selected stepper runs)
        b = self.backend
        build = self.build
        ticks = build.loop_pass_ticks
        for s in self.steppers:
            if s is not None:
                ticks += (build.loop_running_stepper_ticks if s.is_running()
                          else build.loop_idle_stepper_ticks)
        command = (build.cmd_ticks.get("W", build.cmd_default_ticks)
                   + (build.cmd_tail_ticks.get("W", 0) if build.cmd_tail_ticks else 0))
        sections = self._w_pass_sections(ticks)
        passes = [(build.loop_char_ticks, ticks, None),
                  (command, ticks, (ticks, sections) if sections else None)]
        before = min(limit, b.tick_at_millis(self.last_time + 100))
        n = b.app_spend_passes(passes, before, self._watch())
        if n:
            self.passes += n
            self.commands += n // 2
            if n & 1:  # the last pass took the W: its command comes next
                self.read_ptr = (self.read_ptr + 1) & 0xFF
                self.out_buffer.append(0x57)

    def _idle_pass_ticks(self) -> int:
        """CPU time of an idle pass as :meth:`loop_pass` charges it (a held `W`: its
        character and command passes alternate)."""
        p = self.build
        ticks = p.loop_pass_ticks
        if self.pause_ms > 0:
            ticks += p.loop_pause_ticks
        if self.mode not in (_TEST, _GCODE):
            for s in self.steppers:
                if s is not None:
                    ticks += (p.loop_running_stepper_ticks if s.is_running()
                              else p.loop_idle_stepper_ticks)
            if self._held_by_w():
                ticks += (p.loop_char_ticks + p.cmd_ticks.get("W", p.cmd_default_ticks)) // 2
        if self.simulate_blocked_isr:  # (an idle pass lies outside the `e` windows)
            ticks += p.e_check_ticks - p.e_outside_saved_ticks
        return ticks

    def finished(self) -> bool:
        """Input consumed and everything at rest (the end of a scripted run)."""
        return (self.input_consumed_at is not None and self.stopped and not self.test_ongoing
                and self.pause_ms == 0 and not self.any_running()
                and (self.mode != _GCODE or not self.gcode.busy()))

    # ------------------------------------------------------------- helpers
    def _ramp_abort(self, stepper, res, cmd) -> None:
        self.ramp_aborts += 1
        if self.scripted:
            self.println(msg.ABORT_RAMP)
            self.print_number(int(res))
            self.print(" Steps=")
            self.print_number(cmd.steps)
            self.print(" ticks=")
            self.print_number(cmd.ticks)
            self.print(" min_cmd_ticks=")
            self.println_number(self.profile.min_cmd_ticks)

    def force_stop_all(self) -> None:
        """Console Ctrl-C: stop every stepper at once, keep positions; release holds."""
        if self.mode == _GCODE:  # issue 12: an alarm of the G-code machine
            self.gcode.machine.abort()
        for s in self.steppers:
            if s is not None and s.is_running():
                s.force_stop_and_new_position(s.get_current_position())
        self.pause_ms = 0
        self.waiting_interactive = False
        self.qs_hold = None
        self.test_ongoing = False
        self.read_ptr = self.write_ptr
        self.out_buffer.clear()

    # --------------------------------------------------- hosted by the console
    def mode_name(self) -> str:
        return {_NORMAL: "normal", _TEST: "test", Mode.CONFIG: "config",
                _GCODE: "gcode"}[self.mode]

    # ------------------------------------------------------ g mode (issue 12)
    def enter_gcode(self) -> None:
        from ..gcode.demo_mode import DemoGcode

        self.print(msg.ENTER_GCODE_MODE)
        self.mode = _GCODE
        self.gcode = DemoGcode(self)
        if self.read_ptr != self.write_ptr:  # input held behind the g: the machine's now
            rest = bytearray()
            while self.read_ptr != self.write_ptr:
                rest.append(self.in_buffer[self.read_ptr])
                self.read_ptr = (self.read_ptr + 1) & 0xFF
            self.gcode.receive(bytes(rest))

    def leave_gcode(self) -> None:
        self.print(msg.EXIT_TO_MAIN_MENU)
        self.mode = _NORMAL
        self.gcode = None
        self.stopped = not self.any_running()
        self.usage()

    def completions(self) -> list[tuple[str, str]]:
        if self.mode == _GCODE:  # issue 12
            from ..gcode.program import COMPLETIONS
            return COMPLETIONS + [("x", "back to the main menu")]
        return self.command_table.hints(self.mode)

    def control_keys(self) -> dict[str, bytes]:
        """Keys the console sends as bytes: Ctrl-X in the g mode (issue 24)."""
        if self.mode == _GCODE:
            from ..gcode.program import CONTROL_KEYS
            return CONTROL_KEYS
        return {}

    def toolbar_status(self) -> str:
        if self.mode == _TEST and self.test_ongoing:
            return f"M{self.selected + 1} | test running"
        return f"M{self.selected + 1}"

    def exit_code(self) -> int:
        return 1 if self.test_failed_count or self.gcode_failures else 0

    def dropped_input(self) -> int:
        return self.input_dropped
