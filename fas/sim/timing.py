"""The simulated machine's timing model, per chip: one :class:`SimTiming` per profile.

What the simulated chip and its Arduino core take, in ticks of the profile: the step
timer and its interrupt, the library's periodic ramp task, reset, ``millis()``'s
timer interrupt and the console UART.  The machine (:mod:`fas.sim.machine`), its step
channels and the simulated backend read these; programs that run on the simulated
chip read them where they wait for its serial driver (the console device's receive
buffer).  What a program's own code costs (StepperDemo's loop, its message table, its
commands) belongs to that program (:mod:`stepperdemo.demo.build`).

Tables: :data:`BY_FAMILY` holds the timing of each chip family, :data:`BY_PROFILE`
the profiles that differ from their family (the ATmega32U4's USB console);
:func:`sim_timing` answers for a profile, by its name first, then its family.  For the
ATmega328P the figures are calibrated against the AVR-simulator runs in
``shared/conformance`` (see ``docs/timing-model.md``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

from ..arch import ATMEGA2560, ATMEGA2560_VARIANTS, Profile
from .builds import check_build


@dataclass(frozen=True, slots=True)
class SimTiming:
    """The simulated chip's timing (ticks of its profile)."""

    timer_wrap_ticks: int  # compare timer width: a missed compare waits one wrap (0: none)
    # step interrupt entered -> it clears the step pin, per channel (the pulse width of a
    # compare whose interrupt is entered at once); the last figure stands for the
    # channels after it
    isr_latency_ticks: tuple[int, ...]
    isr_duration_ticks: int  # CPU time of one step interrupt (taken from the loop)
    fill_entry_ticks: int  # periodic task start -> first command computed
    fill_cmd_ticks: int  # CPU time per generated queue command with several steps
    fill_single_ticks: int  # ... with one step
    fill_pause_ticks: int  # ... without steps (a pause)
    task_phase_ticks: int  # first periodic task after power-on
    boot_ticks: int  # reset -> first line of setup()
    # ... plus this per byte of initialised data the start-up code copies (a program's
    # built-in input line)
    boot_script_byte_ticks: int
    char_ticks: int  # CPU time to hand one character to the serial driver
    uart_byte_ticks: int  # one character on the wire (start + 8 data + stop)
    uart_tx_buffer: int  # characters the serial driver holds before blocking
    uart_isr_ticks: int  # transmit interrupt, once per buffered character
    # characters the serial driver's receive buffer holds; more arriving while the
    # program does not read are lost (the console device's line, issue 15)
    uart_rx_buffer: int
    millis_overflow_ticks: int  # Arduino timer0 overflow period (millis() source)
    millis_isr_ticks: int = 0  # Arduino's timer-0 overflow interrupt (millis())
    # --- interrupt contention (AVR: the step interrupt ends the pulse) ---
    # the step interrupt writes the next compare this long after it cleared the pin (a
    # value the timer has passed by then matches only after the timer wraps)
    isr_ocr_ticks: int = 0
    # ... this much later again where the interrupt takes up the next queue entry, per
    # channel (the last figure stands for the channels after it; empty: one figure for
    # both paths).  The library's interrupt writes the compare at its end, after the
    # entry switch: channel A 49 cycles after the pin's clear on that path against 25
    # where the entry has more steps, B and C 54 against 26 (build e's replica, the 328P
    # and the 2560 alike: docs/timing-model.md, "thirty-fourth pass")
    isr_ocr_next_ticks: tuple[int, ...] = ()
    # CPU time of one step interrupt per channel, entry to return (empty: all take
    # isr_duration_ticks); the last figure stands for the channels after it
    isr_duration_by_channel: tuple[int, ...] = ()
    # the ramp task (timer overflow interrupt) runs with interrupts enabled except for
    # its entry (until its sei) and its exit (from its cli)
    fill_mask_entry_ticks: int = 0
    fill_mask_exit_ticks: int = 0
    # ... and for this long when it writes a command to the queue
    fill_cmd_mask_ticks: int = 0
    # ... or in these sections per command written, as (ticks before the write's end,
    # ticks with interrupts off), the earliest first (none: fill_cmd_mask_ticks alone)
    fill_cmd_mask_sections: tuple[tuple[int, int], ...] = ()
    # ... and in two sections before its exit, every run (off: empty): (the last one's
    # width per running stepper, at least one; its end before the task's end; the ticks
    # between the one before it and it; then that one's width where a stepper's fill ran,
    # where the running steppers' ramps are done, where no stepper runs).  Build d's
    # replica: 28 ending 79 ticks before the reti, 56 / 28 / 116 ending 116 before it in
    # every task of d02, test_sd_14 and the README move; with two steppers running (d11)
    # 56 ending 79 and 56 ending 144 (docs/timing-model.md, "forty-fourth pass")
    fill_tail_mask_ticks: tuple[int, ...] = ()
    # the ramp task's work for each running stepper before its first command ...
    fill_stepper_ticks: int = 0
    # ... where it first sums the ticks of its queued entries (all but the running
    # one): this much per entry
    fill_queued_entry_ticks: int = 0
    # ... and once more when that fill goes on to plan commands (a fill that finds the
    # queue long enough plans none and skips it)
    fill_plan_ticks: int = 0
    # ... none of these for a running stepper whose ramp has planned everything (the
    # library's fill returns at its first check while the queue drains)
    fill_skips_done_ramps: bool = False
    # ... this per queued entry of at most one step or a pause (no multiply; 0: as
    # fill_queued_entry_ticks)
    fill_queued_single_ticks: int = 0
    # each running stepper's fill reads its queue when the library's code reaches it
    # (the entries the channel has taken up by then left out), its cost charged then
    fill_reads_queue_live: bool = False
    # interrupts nested in the ramp task (timer 0, the step interrupts) move the CPU
    # time line of its code: 1 the fill's read only, 2 every write and queue start too
    task_nested_isrs: int = 0
    # with fill_reads_queue_live: the task's fixed part before its first command
    # (fill_entry_ticks) comes after its fills' reads of their queues, not before them
    # (the firmware's first read: 199 ticks after the task's entry on the ATmega328P,
    # 174-210 on the ATmega2560 - fill_stepper_ticks alone; docs/timing-model.md,
    # "twenty-fourth pass").  Only the reads move: the charges, and with them the writes
    # and queue starts, stay where they are
    fill_entry_after_reads: bool = False
    # a command written to a queue that has not started yet costs this much more (the
    # replica: a starting ramp's one-step commands 1 862-1 872 ticks on the ATmega328P,
    # 1 799-1 813 in a running one)
    fill_unstarted_cmd_extra_ticks: int = 0
    # a command costs less where its stepper has no direction pin (StepperDemo's `u`): the
    # library skips its direction checks (the engine's isDirPinBusy() loop over its
    # steppers before a write to a stopped queue, the direction pin set at the first
    # write, the queue's direction state).  As (the first write to an empty stopped
    # queue, a later write to a stopped queue, a write to a running queue); build d's
    # replica, test_sd_14's start and run with and without `u`: 154, 123, 44 (every write
    # alike; docs/timing-model.md, "forty-fourth pass"; empty: off; build d's ATmega328P
    # since the fiftieth pass)
    fill_no_dir_pin_saved_ticks: tuple[int, ...] = ()
    # a command of a continuous run (runForward / runBackward: the ramp keeps running)
    # costs less than a move's, as (the first write to an empty stopped queue, any other
    # write); build d's replica, test_sd_14's input without `u` against d35 (the same ramp
    # as a move): 67, then 32 each, stopped or running (docs/timing-model.md, "forty-fourth
    # pass"; empty: off; build d's ATmega328P since the fiftieth pass)
    fill_continuous_saved_ticks: tuple[int, ...] = ()
    # the step interrupt takes this much more CPU when it takes up the next queue entry
    isr_next_entry_ticks: int = 0
    # a command at the speed of the one before (the ramp coasts; 0: as fill_cmd_ticks)
    fill_coast_cmd_ticks: int = 0
    # ... and a coast is a command the ramp planned without computing its period from a
    # ramp step (the library's coast state: no calculate_ticks), not one at the speed of
    # the one before (a slow ramp's accelerating or decelerating commands repeat their
    # period, but each costs the conversion; docs/timing-model.md, thirty-seventh pass)
    fill_coast_unconverted: bool = False
    # a command slower than the one before (the ramp decelerates; 0: as fill_cmd_ticks,
    # which then holds the accelerating ones)
    fill_dec_cmd_ticks: int = 0
    # --- the ramp's arithmetic per command (fas.sim.ramp_cost; off: an average of it is
    # in fill_cmd_ticks / fill_dec_cmd_ticks) ---
    # a command of several steps whose period the ramp computed from a ramp step costs
    # fill_cmd_ticks / fill_dec_cmd_ticks plus what the library's log2 conversions of that
    # step and back take (both depend on the values), plus fill_fast_acc_ticks where
    # it accelerates from a period below two min_cmd_ticks
    fill_cmd_maths: bool = False
    # the ramp step to log2: by the bit length (1..16) of the 16 bits of it the library
    # converts ...
    ramp_log2_from_ticks: tuple[int, ...] = ()
    # ... the log2 value back (calculate_ticks's own code included), by its exponent
    # (value >> 9, 0..) ...
    ramp_log2_to_ticks: tuple[int, ...] = ()
    # ... each this more where it reads two entries of its table (interpolates)
    ramp_log2_interp_ticks: int = 0
    # the library's check of an accelerating ramp for commands too short (its period
    # below two min_cmd_ticks)
    fill_fast_acc_ticks: int = 0
    # the ramp task runs in every period, also while no stepper runs (no run skipped as
    # engine.quiescent_tasks() allows), and a run in which no stepper runs costs this
    # instead of fill_entry_ticks (0: such runs are skipped and cost nothing)
    idle_task_ticks: int = 0
    # the ramp task's CPU after its fill (its return), charged at its end: of the task's
    # fixed cost, fill_entry_ticks comes before the first command, this after the last
    fill_exit_ticks: int = 0
    # the ramp task starts a stopped queue after its fill
    fill_start_ticks: int = 0
    # the ramp task's CPU after it started a queue: startQueue()'s rest and return, the
    # rest of that stepper's fill (0: the task ends at the start; build e's replica: 416
    # on the ATmega328P, 513 on the ATmega2560 - docs/timing-model.md, "twenty-eighth pass")
    fill_start_tail_ticks: int = 0
    # a running stepper's fill charges its fixed work (fill_stepper_ticks, the sum of its
    # queue, fill_plan_ticks) after its last write, not before its first: the replica's
    # running fills write their first command one command's cost after the task's
    # entry (one step: median 1 877 ticks over 350 tasks, ATmega328P) and spend
    # 1 093-1 167 ticks after their last write (docs/timing-model.md, "thirty-second
    # pass").  Only the order moves: the task's CPU stays.  Off everywhere
    fill_charges_after_writes: bool = False
    # a command of several steps written to a queue that has not started yet (a start
    # task's ramp up) costs this in all, instead of fill_cmd_ticks and its arithmetic
    # (0: as a running ramp's).  Build e's replica: 2 115 ticks on the ATmega328P, the
    # mean of 19 such pitches in e05, e11, e17 (docs/timing-model.md, "thirty-second
    # pass").  Off (0) everywhere
    fill_unstarted_multi_cmd_ticks: int = 0
    # the queue start when the last command the task wrote has several steps: this
    # instead of fill_start_ticks (0: as fill_start_ticks).  The replica: the last write
    # -> startQueue() 1 027 ticks after such a command, 975 after one step or a pause
    # (+ 70 to the model's compare: 1 097).  Off (0) everywhere
    fill_start_after_cmd_ticks: int = 0
    # a queue start whose fill wrote the ramp's last command (the whole move written in
    # the start task: the ramp generator's end, QueueChannel.ramp_ended): this on top of
    # the start's figure above.  Build d's replica: the last write -> the first step 575-601
    # ticks longer than the model's in all six such starts of d14, test_sd_06 and test_sd_07
    # (bench/replica/start_steps.py, "forty-fifth pass").  Build d's ATmega328P
    # (AVR_D_328P_TIMING) charges it by default; 0 everywhere else
    fill_start_ramp_end_ticks: int = 0
    # a pause the library writes itself before the first command (auto enable's delay):
    # a bare queue write, no ramp step planned (0: as fill_pause_ticks)
    fill_bare_pause_ticks: int = 0
    # auto enable switching a driver on in a command's write (FastAccelStepper's
    # addQueueEntry() calling enableOutputs()): the ramp task's CPU before that write.
    # Build d's replica: the first write of test_sd_07's first move (outputs off) comes
    # 311 ticks later after its library call than the second move's (outputs on):
    # 559 against 248 ("forty-second pass").  0 (not charged) by default
    fill_enable_ticks: int = 0
    # the same read on starts: the first write of a start (to an empty stopped queue) is
    # charged this less, and auto enable's enableOutputs() (a write with the outputs off)
    # this more - the model's figures were read on first moves, whose outputs were off.
    # Build d's replica: a later start with the outputs still on writes its first command
    # 137-194 ticks sooner after the task's entry than the same run's first start (nine
    # runs; bench/replica/start_steps.py, "forty-fifth pass").  Off (0) everywhere
    fill_first_write_enable_ticks: int = 0
    # the ramp config's update() with linear acceleration (s_h > 0: the cubic ramp's
    # figures - log2_pow_div_3, log2_sqrt, ... - at a move's first command): charged
    # before the command it planned.  Build d's replica: 314 / 323 / 331 ticks at `J100` /
    # `J10` / `J1000` (A2000 V400, the first write from rest against the same input
    # without `J`; docs/timing-model.md, "forty-sixth pass").  Off (0) everywhere
    fill_cubic_update_ticks: int = 0
    # a start from rest with a jump (s_jump > 0): calculate_ticks(s_jump), and where
    # the jump is over the maximum speed calculate_ramp_steps() too; charged before
    # the command it planned (figures: the first, the second on top).  Build d's
    # replica: 311-376 (`j3` `j30` `j1000`) and 684 / 724 (`j5000` / `j100000`) at A2000
    # V400 ("forty-sixth pass").  Off (()) everywhere
    fill_jump_start_ticks: tuple[int, ...] = ()
    # a starting ramp's command of several steps (fill_unstarted_multi_cmd_ticks) by the
    # branches _getNextCommand() took for it (QueueChannel.ramp_path): on top of that
    # figure (plain, near, check, coast, dec) - every such command, the accelerating
    # branch at a period under two MIN_CMD_TICKS, its coast check's multiplication, a
    # coast (the period kept: no calculate_ticks()), the decelerating calculate_ticks().
    # Build d's replica: -7 / +34 / +83 / -356 / +58 ("forty-seventh pass",
    # bench/replica/start_pitch.py).  Build d's ATmega328P since the fiftieth pass;
    # off (()) everywhere else
    fill_start_pitch_ticks: tuple[int, ...] = ()
    # a ramp task that runs while no stepper runs (it may start one) nests timer 0's
    # overflows (and the UART's) in its time line as task_nested_isrs 2 does in every
    # task: build d's replica nests 98 of timer 0's overflows (92 ticks) in its 75 start
    # tasks ("forty-fifth pass").  Off everywhere
    start_task_nested_isrs: bool = False
    # CPU time of one write call to the console's serial driver beyond char_ticks per
    # character (the ATmega32U4's USB CDC driver)
    console_call_ticks: int = 0
    # interrupts pending when the loop's blocked section ends enter after the
    # instruction that follows its sei
    sei_ticks: int = 0
    # how long the UART's transmit interrupt holds a step interrupt requested while it
    # runs: from its request to the step interrupt's entry - its reti's end and the
    # instruction of the main program after it (0: uart_isr_ticks, the CPU time it takes
    # from the loop and the ramp task, which was fitted with the default build's prints)
    uart_hold_ticks: int = 0
    # a step interrupt held behind another routine enters after the instruction of the
    # main program that runs after that routine's reti (not after a blocked section's
    # end: its sei's instruction is sei_ticks)
    reti_next_ticks: int = 0
    # the figures measured on the replica together with the main loop's own critical
    # sections (docs/timing-model.md, fourteenth and twenty-sixth passes): with it,
    # sim_timing() gives the chip LOOP_SECTIONS_FIGURES (the plain widths, the next
    # compare's write, reti_next_ticks, the UART's hold); StepperDemo follows the loop's
    # sections with DemoBuild.loop_sections (both together: the variant of `78087fe`).
    # Build d's ATmega328P since the fiftieth pass (with S42 P43 N44 F44 R47); off
    # everywhere else
    loop_section_widths: bool = False
    # the Arduino core's main() between init() (timer 0, millis(), starts) and setup()
    # (the ATmega32U4's USBDevice.attach())
    core_main_ticks: int = 0
    # the start-up code copies a built-in input line (initialised data, boot_script_byte_ticks
    # a byte) together with this many bytes of the program's other initialised data
    # (its terminating NUL included), the whole rounded up to boot_data_align bytes
    # (2: avr-gcc's .data section ends on an even address); boot_ticks then holds the
    # rest of the start-up
    boot_data_bytes: int = 0
    boot_data_align: int = 1
    # timer 0 (millis()) starts this much after the model's start-up (boot_ticks and the
    # copy above), setup() where it was, plus the bytes that round the copy up to
    # timer0_data_align.  Build d's replica (60 runs) puts timer 0's overflow 405 ticks
    # after the model's, 414 where the copy is odd: 405 and 2 make all 60 to the tick.
    # Build d's ATmega328P since the fortieth pass, with its ramp task read (alone
    # they failed d25, test_sd_09 and test_sd_14's pulse-high totals: "twenty-ninth pass");
    # 0 elsewhere
    timer0_lag_ticks: int = 0
    timer0_data_align: int = 1
    # a character handed to the UART while its line is idle goes onto the wire this
    # much later; the transmit interrupts that load the ones after it keep that phase.
    # Build d's replica (60 runs): the firmware's transmit interrupts enter 257 ticks
    # after the model's in every run.  Off (0) everywhere: with it and both phases at
    # the replica's the corpus fails d29's and test_sd_07's pulse-high totals and d30's
    # (docs/timing-model.md, "thirty-first pass")
    uart_idle_start_ticks: int = 0
    # the transmitter as the simulator that made the conformance runs has it: the data
    # register frees only when its character is done on the wire (no separate shift
    # register), so the transmit interrupt loads character k when k-1 ends, and a write
    # into a full buffer waits for character k-63's load (uart_tx_buffer 63: the ring's
    # 63 places).  Build d's replica: every transmit interrupt 1 496 ticks after the
    # write of the line's first character, then every 1 496 ("forty-second pass").
    # Off (False: a real chip's data register and shift register) by default
    uart_tx_single_register: bool = False

    def isr_latency(self, channel: int) -> int:
        """The step pulse width of queue ``channel`` when its interrupt enters at once."""
        table = self.isr_latency_ticks
        return table[min(channel, len(table) - 1)]

    def isr_ocr_next(self, channel: int) -> int:
        """How much later than ``isr_ocr_ticks`` queue ``channel``'s interrupt writes the
        next compare where it takes up the next queue entry."""
        table = self.isr_ocr_next_ticks
        return table[min(channel, len(table) - 1)] if table else 0

    def isr_duration(self, channel: int) -> int:
        """CPU time of one step interrupt of queue ``channel``."""
        table = self.isr_duration_by_channel
        if not table:
            return self.isr_duration_ticks
        return table[min(channel, len(table) - 1)]


def avr_uart_byte_ticks(f_cpu: int, baud: int, sim_bits: int = 10) -> int:
    """Ticks per character on the console UART.

    Arduino's HardwareSerial uses double speed: UBRR = (F_CPU/4/baud - 1)/2, so
    115200 baud is really 117647 baud, 136 CPU cycles per bit.  A real character is
    10 bits (1360 cycles).  The AVR simulator that produced the conformance data
    sends one character every 11 bit times (1496 cycles, measured on the firmware
    build); ``sim_bits=11`` reproduces it.
    """
    ubrr = (f_cpu // 4 // baud - 1) // 2
    return sim_bits * 8 * (ubrr + 1)


# The first ramp task: 67 989 ticks after engine.init() in the local build the loop was
# measured on (docs/timing-model.md, "Console and task timing"); the conformance build's
# task runs 9 us (144 ticks) later ("The main loop, per path").  The entry's CPU was
# fitted on the conformance runs' first steps counted from the local build's task, so
# it held those 144 ticks: 2 436 = 2 292 + 144 ("twenty-third pass").
LOCAL_BUILD_TASK_PHASE_TICKS = 67989
CONFORMANCE_TASK_LAG_TICKS = 144

AVR_TIMING = SimTiming(
    timer_wrap_ticks=65536,
    isr_latency_ticks=(61, 71, 71),
    isr_duration_ticks=120,
    fill_entry_ticks=2436 - CONFORMANCE_TASK_LAG_TICKS,
    fill_cmd_ticks=2367,
    fill_single_ticks=2102,
    fill_pause_ticks=1455,
    task_phase_ticks=LOCAL_BUILD_TASK_PHASE_TICKS + CONFORMANCE_TASK_LAG_TICKS,
    boot_ticks=11200,
    boot_script_byte_ticks=9,
    char_ticks=121,
    uart_byte_ticks=avr_uart_byte_ticks(16_000_000, 115200, sim_bits=11),
    uart_tx_buffer=64,
    uart_isr_ticks=114,
    uart_rx_buffer=63,  # HardwareSerial: a 64-byte ring keeps one slot free
    millis_overflow_ticks=64 * 256,
    millis_isr_ticks=96,
    isr_ocr_ticks=29,
    isr_duration_by_channel=(120, 146, 146),
    fill_mask_entry_ticks=50,
    fill_mask_exit_ticks=41,
    sei_ticks=1,
    # build d's start-up copies its .data rounded up to even bytes: timer 0 and the ramp
    # task of every build-d replica run come 9 ticks later where the input's line is odd
    # (60 runs: docs/timing-model.md, "thirtieth pass")
    boot_data_align=2,
)

# the library built with SIMAVR_TIME_MEASUREMENT (upstream's timing tests): the step
# interrupt sets a port bit on entry (sbi, before it clears the step pin) and toggles it
# before it returns
TIME_MEASUREMENT_STEP_ISR: dict[str, Any] = {
    "isr_latency_ticks": (62, 73, 73), "isr_duration_by_channel": (126, 152, 152)}

# the build of the runs e01-e18 (fas.sim.builds): the library's code takes fewer cycles.
# A running stepper's fill costs 226 + 100 per queued entry, and 100 more when it goes
# on to plan commands: the pitch between two blocks across a ramp task that plans none
# is the firmware's so in every run (bench/e_fidelity.py --holdout, "across a ramp task");
# none of that for a stepper whose ramp has planned everything (a task while its queue
# drains: 462 ticks on the firmware's replica, bench/replica)
AVR_E_TIMING = replace(AVR_TIMING, fill_entry_ticks=433, fill_stepper_ticks=226,
                       boot_data_align=1,
                       task_phase_ticks=LOCAL_BUILD_TASK_PHASE_TICKS,
                       fill_plan_ticks=100, fill_bare_pause_ticks=608,
                       fill_start_ticks=597 + 1250,
                       fill_pause_ticks=1259, fill_single_ticks=1817, fill_cmd_ticks=2060,
                       fill_coast_cmd_ticks=1600, fill_queued_entry_ticks=100,
                       fill_skips_done_ramps=True,
                       # the ramp's log2 arithmetic (fill_cmd_maths, off), the replica's
                       # cycles by value, every command of e01-e12, e17, e18
                       # (docs/timing-model.md, twenty-first pass): to log2 by bit length
                       # 1..16 (15 and 16 by the pattern of 9..14: no run reaches them),
                       # back by exponent 0..17 (below 9 by the code's shift loop, 5 a
                       # place: no run reaches them), 10 more for two table reads
                       ramp_log2_from_ticks=(176, 169, 164, 157, 153, 146, 141, 134,
                                             185, 178, 173, 166, 162, 155, 150, 143),
                       ramp_log2_to_ticks=(212, 207, 202, 197, 192, 187, 182, 177, 172,
                                           167, 148, 155, 160, 165, 170, 175, 198, 205),
                       ramp_log2_interp_ticks=10, fill_fast_acc_ticks=35,
                       isr_next_entry_ticks=24, isr_duration_by_channel=(120, 135, 135),
                       # the replica of this build (docs/timing-model.md, fifteenth pass, pulses):
                       # the UART's routine 118 ticks to its reti, the reti 4, one
                       # instruction (1-2) before a held step interrupt enters: 123-124
                       # ticks from the UART's request (test_sd_14_328p 315 pulses, e17 195)
                       uart_hold_ticks=124)

# build d's ramp task read piece by piece from its replica (bench/replica/task_costs.py
# over its 60 runs; docs/timing-model.md, "thirty-third pass"), in the model's terms:
# an idle task 664 (436 + the exit), a task whose stepper's ramp is done 604 (entry +
# exit), a planning stepper's task that writes nothing 813 + 75 a queued entry of
# several steps, 30 of one step or a pause (entry + exit + 209 + the sum); a task that
# writes 136 less than that plus its commands (the solve over 27 594 tasks); a lone
# start's first write 2 581 (436 + 2 145, its one-step commands 36 above a running
# ramp's), its last write to the task's end 976 + 621 (1 030 after a command of several
# steps).  Build d's ATmega328P default (AVR_D_328P_TIMING below, fortieth pass); alone
# with both phases the corpus failed d34, dm09 and test_sd_18 (the thirty-third pass's
# table): StepperDemo's commands read as well close them (stepperdemo.demo.build)
BUILD_D_REPLICA_TASK: dict[str, int] = {
    "fill_entry_ticks": 376, "fill_exit_ticks": 228, "idle_task_ticks": 436,
    "fill_stepper_ticks": 209 - 136, "fill_queued_entry_ticks": 75,
    "fill_queued_single_ticks": 30, "fill_plan_ticks": 0, "fill_skips_done_ramps": 1,
    "fill_single_ticks": 2109, "fill_cmd_ticks": 2392, "fill_pause_ticks": 1583,
    "fill_coast_cmd_ticks": 1903, "fill_unstarted_cmd_extra_ticks": 36,
    "fill_unstarted_multi_cmd_ticks": 2387, "fill_start_ticks": 976 + 70,
    "fill_start_after_cmd_ticks": 1030 + 70, "fill_start_tail_ticks": 621 - 70 - 228,
    # auto enable's pauses written in a first command's call: its queue writes 585, 517
    # and 152 ticks apart (all five such tasks), two pauses; a running fill's fixed work
    # after its writes (a second start's first write then lies where the replica's does)
    "fill_bare_pause_ticks": (585 + 517 + 152) // 2, "fill_charges_after_writes": 1,
}
# ... and build d's two phases as its replica measures them (thirtieth pass): the ramp
# task 217 ticks after the fitted phase (with the entry read, no longer taken off the
# entry; a difference: added once, in AVR_D_328P_TIMING), timer 0 405 (the copy rounded
# to even bytes)
BUILD_D_REPLICA_PHASES: dict[str, int] = {
    "task_phase_ticks": 217, "timer0_lag_ticks": 405, "timer0_data_align": 2,
}

# build d's plain step pulse as its replica measures it (docs/timing-model.md, "forty-third
# pass"; bench/replica/plain_pulse.py over the 60 build-d runs): the pin falls 60 ticks
# after the compare match on channel A, 70 on B, where the step interrupt enters at once
# (the vector table's jmp 3, the prologue's 14 pushes 30, the queue check 7, the
# entry's address and the timer's mode 20 up to the force-compare write); with
# SIMAVR_TIME_MEASUREMENT 62 / 72 (the entry's sbi, 2 more on both channels).  The model's
# 61 / 71 (62 / 73) were fitted: they stand for the entries that wait 1-14 ticks behind
# an instruction or a short section with interrupts off (millis(), queueEntries()) and the
# ramp task's own sections, which the default did not model.  Variant P43 of
# bench/d_corpus.py: alone the corpus fails 9 files' pulse-high totals, all short; build
# d's ATmega328P default since the fiftieth pass, with the other seven (the sections)
BUILD_D_REPLICA_PLAIN_PULSE_TICKS: tuple[int, ...] = (60, 70, 70)
BUILD_D_TM_REPLICA_PLAIN_PULSE_TICKS: tuple[int, ...] = (62, 72, 72)
# build d's ramp task's own sections with interrupts off, per command it writes, as
# (ticks of the task's own CPU before the write, ticks): read on d02's replica rebuilt with
# TASK_SECTIONS=1 (480 writes in 714 tasks; bench/replica/sketch_replica.task_sections, the
# commonest distance; docs/timing-model.md, "forty-third pass"): seven after the previous
# write (2, 13, 6, 51, 2, 15, 2), the queue's fill level (10), the ramp's state (40), three
# of 2 and the write's own (8 at 53).  Variant K43, off in the default: it costs the
# G-code look-ahead run 11 % of its instructions (issue 25) and the corpus passes without
# it (docs/timing-model.md, "fiftieth pass")
BUILD_D_REPLICA_CMD_MASK_SECTIONS: tuple[tuple[int, int], ...] = (
    (1418, 2), (1406, 13), (1328, 6), (1075, 51), (1004, 2), (949, 15), (927, 2),
    (721, 10), (600, 40), (458, 2), (276, 2), (129, 2), (53, 8))

# a command's saving where its stepper has no direction pin (`u`), read on build d's
# replica (docs/timing-model.md, "forty-fourth pass"): test_sd_14's input and
# `M1 u A1000000 V40 R20000 W` against d35 (the same ramp with a direction pin) - the
# first write to an empty stopped queue 154 ticks less, a later write to a stopped queue
# 123 (13 writes alike), a write to a running queue 44 (173 tasks of two writes: 88);
# d29's start after `u`, 127-128 a write (pauses and one-step commands).  Variant N44 of
# bench/d_corpus.py (SimTiming.fill_no_dir_pin_saved_ticks; build d's default since the
# fiftieth pass, as F44 and R47 below)
BUILD_D_REPLICA_NO_DIR_PIN_SAVED_TICKS: tuple[int, int, int] = (154, 123, 44)
# ... and the ramp task's two sections before its exit, every run (fill_tail_mask_ticks;
# variant T44, off in the default as K43: 6 % of the G-code run's instructions)
BUILD_D_REPLICA_TAIL_MASK_TICKS: tuple[int, ...] = (28, 79, 9, 56, 28, 116)
# ... and a continuous run's commands (fill_continuous_saved_ticks; variant F44)
BUILD_D_REPLICA_CONTINUOUS_SAVED_TICKS: tuple[int, int] = (67, 32)
# ... and a start whose fill ended the ramp (fill_start_ramp_end_ticks; variant E45)
BUILD_D_REPLICA_START_RAMP_END_TICKS = 598
# ... and the first write's enableOutputs() (fill_first_write_enable_ticks; variant O45)
BUILD_D_REPLICA_FIRST_WRITE_ENABLE_TICKS = 189
# ... and update()'s cubic figures with linear acceleration (fill_cubic_update_ticks;
# variant H46): the median of `J10` `J100` `J1000` (323, 314, 331) on `M1 A2000 V400 ...
# R3000 W` against the same without `J` (bench/replica/replica.py --profile; the
# first write from rest; "forty-sixth pass")
BUILD_D_REPLICA_CUBIC_UPDATE_TICKS = 323
# ... and a start's jump (fill_jump_start_ticks; variant Q46): calculate_ticks(s_jump),
# the median of `j3` `j30` `j1000` (376, 311, 341), and calculate_ramp_steps() on top
# where the jump is clipped to the maximum speed, `j5000` / `j100000` (684 / 724) less
# 341: 363 (their mean)
BUILD_D_REPLICA_JUMP_START_TICKS: tuple[int, int] = (341, 363)
# ... and a starting ramp's commands by the branches their planning took
# (fill_start_pitch_ticks; variant R47): bench/replica/start_pitch.py over the start
# tasks' 602 commands of several steps in 17 runs ("forty-seventh pass").  Plain: the
# median over the 12 runs of moves with a direction pin of their accelerating
# commands' mean (2 380) less the one figure 2 387; the others each a difference within
# a run against its plain commands: near +34 (34.0 in d35, d36, test_sd_11, test_sd_12,
# test_sd_14; 27.4 in test_sd_02, test_sd_03), the check's multiplication +83 on that
# (d23 86, test_sd_09 80), a coast -356 (test_sd_02 -366, test_sd_07 -356,
# test_seq_sd_01 -354), the decelerating calculate_ticks() +58 (test_sd_07 58.3,
# test_seq_sd_01 58.7)
BUILD_D_REPLICA_START_PITCH_TICKS: tuple[int, ...] = (-7, 34, 83, -356, 58)

# build d's ATmega328P as read from its replica (docs/timing-model.md, "fortieth pass";
# the default since then): AVR_TIMING's figures with the ramp task above (the pieces of
# the thirty-third pass), both phases (the task's 217 ticks added to the fitted phase:
# applied here once, nowhere else) and a coast charged as a command planned without a
# conversion (thirty-seventh pass).  AVR_TIMING stays the figures fitted on build d's
# runs: the other AVR chips' tables and the other builds start from it
_BUILD_D_TASK_FIELDS: dict[str, Any] = {
    k: bool(v) if k in ("fill_skips_done_ramps", "fill_charges_after_writes") else v
    for k, v in BUILD_D_REPLICA_TASK.items()}
AVR_D_328P_TIMING = replace(
    AVR_TIMING,
    **_BUILD_D_TASK_FIELDS,
    task_phase_ticks=AVR_TIMING.task_phase_ticks + BUILD_D_REPLICA_PHASES["task_phase_ticks"],
    timer0_lag_ticks=BUILD_D_REPLICA_PHASES["timer0_lag_ticks"],
    timer0_data_align=BUILD_D_REPLICA_PHASES["timer0_data_align"],
    fill_coast_unconverted=True,
    # the ramp's end in a start task (forty-fifth pass; the corpus passes with it)
    fill_start_ramp_end_ticks=BUILD_D_REPLICA_START_RAMP_END_TICKS,
    # update()'s cubic figures and a start's jump (forty-sixth pass; read on inputs of
    # their own, the corpus passes with them)
    fill_cubic_update_ticks=BUILD_D_REPLICA_CUBIC_UPDATE_TICKS,
    fill_jump_start_ticks=BUILD_D_REPLICA_JUMP_START_TICKS,
    # six of the eight read on its replica in the forty-second to forty-seventh passes
    # (bench/d_corpus.py's R47 S42 P43 L43 N44 F44; the default since the fiftieth pass,
    # together: the corpus passes with them, not with every part alone).  The plain pulse
    # (P43; with the loop's sections LOOP_SECTIONS_FIGURES gives build d the same), the
    # loop's sections (L43; StepperDemo's half in stepperdemo.demo.build), the direction
    # checks of a stepper without a direction pin (N44), a continuous run's commands
    # (F44), a starting ramp's commands by their branches (R47).  Before: (61, 71, 71),
    # the rest off.  The ramp task's own sections per command (K43) and before its exit
    # (T44) stay variants: the corpus passes without them and they cost the G-code run
    # 11 % and 6 % of its instructions (issue 25)
    isr_latency_ticks=BUILD_D_REPLICA_PLAIN_PULSE_TICKS,
    loop_section_widths=True,
    fill_no_dir_pin_saved_ticks=BUILD_D_REPLICA_NO_DIR_PIN_SAVED_TICKS,
    fill_continuous_saved_ticks=BUILD_D_REPLICA_CONTINUOUS_SAVED_TICKS,
    fill_start_pitch_ticks=BUILD_D_REPLICA_START_PITCH_TICKS)
# ... and the same build with SIMAVR_TIME_MEASUREMENT (upstream's timing tests
# test_sd_04_timing_*): its plain pulse read as well (P43: 62 / 72; before, 62 / 73)
AVR_TIME_MEASUREMENT_TIMING = replace(
    AVR_D_328P_TIMING, **{**TIME_MEASUREMENT_STEP_ISR,
                          "isr_latency_ticks": BUILD_D_TM_REPLICA_PLAIN_PULSE_TICKS})

# upstream's own simulator-tested sketches (FastAccelStepper 1.2.7's examples/Issue*,
# built by its test suite with SIMAVR_TIME_MEASUREMENT): the step interrupt as in
# d_time_measurement, the ramp task as in the build of the runs e01-e18 (its cost per
# running stepper, per queued entry, per planned command; an idle task takes 27 us, not
# the default build's 152).  Upstream's expect.txt traces the task from its entry to
# its exit (FillISR, step interrupts inside it included): 175 782 us for Issue280 and
# 1 209 943 us for Issue208; the model makes 187 755 / 1 242 566 us with these costs,
# 233 016 / 1 630 530 with the default build's (docs/timing-model.md, "Builds")
AVR_UPSTREAM_TM_TIMING = replace(
    AVR_TIMING, **TIME_MEASUREMENT_STEP_ISR, task_phase_ticks=LOCAL_BUILD_TASK_PHASE_TICKS,
    boot_data_align=1,
    **{name: getattr(AVR_E_TIMING, name) for name in (
        "fill_entry_ticks", "fill_stepper_ticks", "fill_queued_entry_ticks", "fill_plan_ticks",
        "fill_cmd_ticks", "fill_coast_cmd_ticks", "fill_single_ticks", "fill_pause_ticks",
        "fill_bare_pause_ticks", "fill_start_ticks", "fill_skips_done_ramps")},
    # the task's entry until its sei and its exit from its cli, read on Issue208 rebuilt
    # (bench/replica/sketch_replica.py; docs/timing-model.md, "The upstream sketches'
    # loop sections"): a step interrupt requested there enters 87 ticks after the task's
    # entry (290 pulses), or 5 ticks after its reti, up to 83 ticks before it (296)
    fill_mask_entry_ticks=87, fill_mask_exit_ticks=83 + 5)
# the same sketch's ramp task between its entry and exit: per command it writes, six
# sections with interrupts off, as (ticks of the task's own CPU before the write,
# ticks): the ramp's state (43), the queue's fill level (10), the command's own write
# (8 at 55 before it), and four the library makes before the next command's maths
# (2, 53, 2, 13; counted here as the next write's).  Read on Issue208 rebuilt
# (bench/replica/replica_run.c with TASK_SECTIONS; docs/timing-model.md, "The upstream
# sketches' loop sections"); with fill_cmd_mask_sections, off by default: not landed
UPSTREAM_TM_CMD_MASK_SECTIONS: tuple[tuple[int, int], ...] = (
    (1916, 2), (1561, 53), (1483, 2), (1428, 13), (1240, 10), (1190, 43), (55, 8))

# ATmega32U4: Serial is the USB CDC port, output costs no UART time (the AVR simulator
# has no USB host, so the firmware's prints return at once): a write call to the CDC
# driver costs 112 ticks (its checks), and its larger start-up code starts timer 0 2000
# ticks later than on the ATmega328P (both measured on the runs e15/e16)
AVR_USB_TIMING = replace(AVR_TIMING, char_ticks=40, uart_byte_ticks=0,
                         boot_ticks=AVR_TIMING.boot_ticks + 2000, console_call_ticks=112)
# In the build of the runs e15/e16 the core's main() attaches the USB device between
# init() and setup() for 10 880 ticks: their first steps and e15's ramp task (the
# pitches across it, mod 65536) come that much after the model's without it, while
# e15's `e` windows (millis()) start where the model's do.  The ramp task's entry: e15's
# pitch between two blocks across a task that plans no command is 2103 ticks wherever
# no timer-0 overflow (at its measured phase) falls in it and 2199 wherever one does
# (every such pitch, bench/e_blocks.py): 2103 = the pass's 298 + 479 + 226 + 11 * 100
AVR_USB_E_TIMING = replace(AVR_E_TIMING, char_ticks=40, uart_byte_ticks=0,
                           boot_ticks=AVR_USB_TIMING.boot_ticks,
                           console_call_ticks=AVR_USB_TIMING.console_call_ticks,
                           fill_entry_ticks=479, core_main_ticks=10880,
                           uart_hold_ticks=0)  # the USB's interrupt: not read

# ATmega2560: a 3-byte program counter makes calls, interrupt entries and returns
# longer.  Its step interrupts take 127 ticks (channel A) and 142 (B, C), timer 0's 97
# (measured on the runs e13/e14, the only ones of this chip); the pin falls 5 ticks later
# than on the ATmega328P (one more cycle to enter, the extra pushes of its prologue)
AVR_MEGA_TIMING = replace(AVR_TIMING, isr_latency_ticks=(66, 76, 76),
                          isr_duration_by_channel=(127, 142, 142), millis_isr_ticks=97)
# ... in the build of the runs e13/e14, where channel A's pin falls 64 ticks after the
# entry (3 later than on the ATmega328P): e13's plain pulses average 64.4 ticks, held
# pulses apart (bench/e_fidelity.py --pulses); B and C as above (e14).  Its start-up
# code (reset to init(), which starts timer 0) takes 4950 ticks longer than the
# ATmega328P's: every `e` window of e13 starts that much later after its multiple of
# 256 ms, and its ramp task (timer 1's overflow) runs ~4300 ticks later mod 65536 (the
# pitches across it).  With the task where the firmware has it, the commands a task
# plans cost what they cost on the ATmega328P (e13's pitches across a task that plans
# commands: 6500-6800 ticks, as the model's with these), and a queue's start 2384
# (e13's first step; e14's B and C then come to the tick as well)
AVR_MEGA_E_TIMING = replace(AVR_E_TIMING, fill_entry_ticks=517, fill_stepper_ticks=276,
                            boot_ticks=AVR_E_TIMING.boot_ticks + 4950,
                            fill_start_ticks=2384,
                            isr_latency_ticks=(64, 73, 73),
                            isr_duration_by_channel=AVR_MEGA_TIMING.isr_duration_by_channel,
                            millis_isr_ticks=AVR_MEGA_TIMING.millis_isr_ticks,
                            # the ramp's log2 arithmetic as on the ATmega328P (e13, e14):
                            # 3-5 ticks more a call (1..13 bits, exponents 9..16 measured)
                            ramp_log2_from_ticks=(181, 174, 169, 162, 158, 151, 146, 139,
                                                  188, 181, 176, 169, 165, 158, 153, 146),
                            ramp_log2_to_ticks=(216, 211, 206, 201, 196, 191, 186, 181, 176,
                                                171, 152, 159, 164, 169, 174, 179, 202,
                                                209),
                            # the replica of e13/e14: the UART's routine 126 ticks to its
                            # reti, the reti 5 (3-byte return address), one instruction:
                            # 132-133 ticks (e13 62 pulses, e14 211)
                            uart_hold_ticks=133)

ESP32_TIMING = SimTiming(
    timer_wrap_ticks=0,
    isr_latency_ticks=(16,),
    isr_duration_ticks=0,
    fill_entry_ticks=80,
    fill_cmd_ticks=80,
    fill_single_ticks=80,
    fill_pause_ticks=40,
    task_phase_ticks=8000,
    boot_ticks=16000,
    boot_script_byte_ticks=0,
    char_ticks=4,
    uart_byte_ticks=(10 * 16_000_000) // 115200,
    uart_tx_buffer=128,
    uart_isr_ticks=0,
    uart_rx_buffer=256,  # the Arduino-ESP32 core's default receive buffer
    millis_overflow_ticks=16000,
)

SAM_TIMING = SimTiming(
    timer_wrap_ticks=0,
    isr_latency_ticks=(21 * 2,),
    isr_duration_ticks=21 * 3,
    fill_entry_ticks=100,
    fill_cmd_ticks=400,
    fill_single_ticks=400,
    fill_pause_ticks=200,
    task_phase_ticks=10000,
    boot_ticks=21000,
    boot_script_byte_ticks=0,
    char_ticks=10,
    uart_byte_ticks=(10 * 21_000_000) // 115200,
    uart_tx_buffer=128,
    uart_isr_ticks=0,
    uart_rx_buffer=127,  # UARTClass: a 128-byte ring keeps one slot free
    millis_overflow_ticks=21000,
)

# the Pico: the ESP32's model with a USB console (no UART time)
PICO_TIMING = replace(ESP32_TIMING, uart_byte_ticks=0, char_ticks=8,
                      millis_overflow_ticks=16000)

MEGA_NAMES = tuple(p.name for p in (ATMEGA2560, *ATMEGA2560_VARIANTS))

# (the AVR family's entry answers for the ATmega328P alone: the ATmega2560s and the
# ATmega32U4 have their own in BY_PROFILE, every other build its own 328P entry)
BY_FAMILY: dict[str, SimTiming] = {
    "avr": AVR_D_328P_TIMING,
    "esp32": ESP32_TIMING,
    "sam": SAM_TIMING,
    "rp2040": PICO_TIMING,
    "test": ESP32_TIMING,  # upstream's pc_based test platform: ESP32-like
}

BY_PROFILE: dict[str, SimTiming] = {
    "atmega32u4": AVR_USB_TIMING,
    **{name: AVR_MEGA_TIMING for name in MEGA_NAMES},
}


# the builds that differ from the default build (fas.sim.builds), by profile name or
# family, as in BY_PROFILE / BY_FAMILY
BY_BUILD: dict[str, dict[str, SimTiming]] = {
    "d_time_measurement": {"atmega328p": AVR_TIME_MEASUREMENT_TIMING},
    "e": {"atmega328p": AVR_E_TIMING, "atmega32u4": AVR_USB_E_TIMING,
          **{name: AVR_MEGA_E_TIMING for name in MEGA_NAMES}},
    "upstream_time_measurement": {"atmega328p": AVR_UPSTREAM_TM_TIMING},
}


# the figures measured on the replica (build e's timing; docs/timing-model.md,
# fourteenth, fifteenth and seventeenth passes, pulses) that go with the loop's critical
# sections (SimTiming.loop_section_widths), by build and profile name: the pin falls 60 / 70
# ticks after an entry at once (the 2560's build e 63 / 73 / 73), the next compare 30
# after it; a step interrupt held behind a routine enters after its reti and one
# instruction of the loop (reti_next_ticks 2): the UART's routine 118 ticks to its reti,
# the reti 4 (the 2560: 126 + 5, a 3-byte return address).  Build d takes build e's chip
# figures: its replica's interrupts and sections are build e's to the tick (twenty-seventh
# pass; only its loop's passes differ: stepperdemo's AVR_COSTS)
_SECTIONS_328P: dict[str, object] = {"isr_latency_ticks": (60, 70, 70), "isr_ocr_ticks": 30,
                                     "reti_next_ticks": 2, "uart_hold_ticks": 118 + 4}
_SECTIONS_MEGA: dict[str, object] = {"isr_ocr_ticks": 29, "reti_next_ticks": 2,
                                     "uart_hold_ticks": 126 + 5}
LOOP_SECTIONS_FIGURES: dict[str, dict[str, dict[str, object]]] = {
    "d": {"atmega328p": _SECTIONS_328P, "atmega32u4": {**_SECTIONS_328P, "uart_hold_ticks": 0},
          **{name: _SECTIONS_MEGA for name in MEGA_NAMES}},
    "e": {"atmega328p": _SECTIONS_328P, "atmega32u4": {**_SECTIONS_328P, "uart_hold_ticks": 0},
          **{name: {**_SECTIONS_MEGA, "isr_latency_ticks": (63, 73, 73), "isr_ocr_ticks": 30}
             for name in MEGA_NAMES}},
}


def sim_timing(profile: Profile, build: str | None = None) -> SimTiming:
    """The simulated timing of ``profile`` in firmware ``build`` (None: the default
    build): the build's entry for the profile or its family, else the profile's own
    entry, else its family's; with its ``loop_section_widths`` on, with the figures measured
    together with them (:data:`LOOP_SECTIONS_FIGURES`)."""
    build = check_build(build)
    timing = _sim_timing(profile, build)
    if timing.loop_section_widths:
        figures = LOOP_SECTIONS_FIGURES.get(build, {}).get(profile.name)
        if figures:
            # one table per table and figures: the same object on every call, as a table
            # without them (a variant's new table gets its own)
            key = (build, profile.name)
            made = _WITH_SECTIONS.get(key)
            if made is None or made[0] is not timing:
                made = (timing, replace(timing, **figures))  # type: ignore[arg-type]
                _WITH_SECTIONS[key] = made
            timing = made[1]
    return timing


# sim_timing()'s tables with the loop's sections' figures, by build and profile name: (the
# table they were made from, the table with them)
_WITH_SECTIONS: dict[tuple[str, str], tuple[SimTiming, SimTiming]] = {}


def _sim_timing(profile: Profile, build: str) -> SimTiming:
    variant = BY_BUILD.get(build, {})
    timing = (variant.get(profile.name) or variant.get(profile.family)
              or BY_PROFILE.get(profile.name) or BY_FAMILY.get(profile.family))
    if timing is None:
        raise ValueError(f"no simulated timing for profile {profile.name!r} "
                         f"(family {profile.family!r}): add it to fas/sim/timing.py")
    return timing
