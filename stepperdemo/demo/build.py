"""StepperDemo's build for each chip: its wiring, pin configurations and its own costs.

One :class:`DemoBuild` per profile name in :data:`BY_PROFILE`; :func:`demo_build`
answers for a profile.  What is here is StepperDemo's, not the chip's or the
library's:

* its default wiring of the steppers (``StepperPins_*.h``): step, enable and
  direction pins and the enable delays; the debug LED it switches on;
* the pin configurations it offers at start-up (ESP32, Pico) and how long it waits;
* what its build contains (the ATmega32U4's small build; the stray-read command `r`
  of the AVR builds);
* the CPU time its own code takes on the simulated chip (measured on the firmware,
  ``docs/timing-model.md``): a loop pass, the message table, printing numbers, the
  status lines, parsing and executing a command (by letter), the blocked section of
  `e`.  The chip's own timing (interrupts, UART, ramp task) is in
  :mod:`fas.sim.timing`.

The other programs on the console (the winder, G-code, scenarios, the fuzzer, the
plots) wire their steppers as StepperDemo does, from :attr:`DemoBuild.steppers`.

The builds of one family share their costs: each is :data:`AVR_COSTS`,
:data:`ESP32_COSTS` or :data:`SAM_COSTS` with its own wiring
(:func:`dataclasses.replace`).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from fas.arch import (
    ATMEGA2560,
    ATMEGA2560_VARIANTS,
    ESP32,
    ESP32_PROFILES,
    PC_TEST,
    Profile,
)
from fas.codes import PIN_UNDEFINED, FasDriver
from fas.sim.builds import check_build

from .. import messages as msg


@dataclass(frozen=True)
class DemoStepper:
    """StepperDemo's default wiring of one stepper (StepperPins_*.h)."""

    step: int
    enable_low_active: int
    direction: int
    on_delay_us: int
    off_delay_ms: int
    enable_high_active: int = PIN_UNDEFINED
    dir_change_delay_us: int = 0
    direction_high_counts_up: bool = True
    auto_enable: bool = True
    driver: int = FasDriver.DONT_CARE  # ESP32: the driver StepperDemo asks for


@dataclass(frozen=True)
class DemoConfig:
    """One of the pin configurations StepperDemo offers at start-up (ESP32, Pico)."""

    name: str
    steppers: tuple[DemoStepper, ...]


LoopPoll = tuple[int, tuple[tuple[int, int], ...]]


@dataclass(frozen=True)
class DemoBuild:
    """StepperDemo built for one chip (costs in ticks of its profile)."""

    steppers: tuple[DemoStepper, ...] = ()  # the wiring (of configuration 0, if any)
    debug_led_pin: int = PIN_UNDEFINED  # engine.set_debug_led() after init
    configs: tuple[DemoConfig, ...] = ()  # >0: the start-up pin configuration prompt
    config_wait_ms: int = 5000  # ... how long it waits for a digit
    small_build: bool = False  # ATmega32U4: no T, d, W/w usage, test usage, seq 13
    has_stray_digital_read: bool = False  # `r` exists (AVR Arduino core only)
    # --- CPU time of StepperDemo's own code (docs/timing-model.md) ---
    setup_head_ticks: int = 0  # setup() entry -> first character of the banner
    setup_steppers_ticks: int = 0  # engine.init() -> first stepper's pins configured
    loop_pass_ticks: int = 0  # one pass of loop() without output
    # ... plus, per path (docs/timing-model.md): isRunning() of each connected stepper
    # in the normal mode (a running one answers at once, an idle one asks its queue)
    loop_running_stepper_ticks: int = 0
    loop_idle_stepper_ticks: int = 0
    loop_pause_ticks: int = 0  # a pass during `w<ms>`: it compares millis()
    loop_char_ticks: int = 0  # a pass that takes an input character (not a command end)
    loop_stray_read_ticks: int = 0  # `r`: a digitalRead() of a step pin, per pin
    msg_scan_byte_ticks: int = 0  # the message table: one byte read
    msg_lookup_ticks: int = 0  # ... one look-up (call overhead)
    print_digit_ticks: int = 0  # printing a number: one 32-bit division per digit
    print_call_ticks: int = 0  # printing a number or an empty line: the call
    info_ticks: int = 0  # one stepper's status (the library getters), without prints
    info_scan_ticks: int = 0  # output_info(): per connected stepper (isRunning)
    cmd_arg_char_ticks: int = 0  # parsing a command: per character after the letter
    cmd_default_ticks: int = 0  # executing a command without its own figure
    # executing a command, by letter, without its prints and argument parsing
    cmd_ticks: dict[str, int] = field(default_factory=dict, compare=False)
    # ... and, by letter, the command's CPU after its prints: the rest of the pass that ran
    # it (empty: none; build d's 328P: its replica's, docs/timing-model.md, "thirty-sixth",
    # "thirty-ninth" and "fortieth pass")
    cmd_tail_ticks: dict[str, int] = field(default_factory=dict, compare=False)
    irq_block_ticks: int = 0  # `e`: length of one blocked section
    # the pass that ends a `w<ms>` pause: its CPU before `Wait complete`'s first character
    # beyond the message table's look-up (the pass's head, millis(), the check), spent
    # there (0: none; build d's 328P: its replica's, docs/timing-model.md, "thirty-sixth pass")
    pause_end_ticks: int = 0
    # a print's body from a buffer in RAM (Print::write's loop: a number, a status line's
    # pieces), CPU per character handed to the serial driver; 0: the timing's char_ticks
    # (build d's 328P: its replica's 107 against 121; docs/timing-model.md, "thirty-ninth
    # pass", the default since the fortieth pass)
    buffer_char_ticks: int = 0
    # an idle loop woken by a deadline of millis() (timer 0's overflow) reads millis()
    # where the pass the overflow interrupted gets to it: on average half a pass later
    # (the pass's phase at the overflow is not kept; False: at once)
    wake_mid_pass: bool = False
    # `e` on: run every pass of the loop, also between the windows, so that the pass
    # that reads a window's deadline is the one the loop's pass lengths and the
    # interrupts lead to (the loop's phase kept; False: idle passes skipped to the
    # deadline; docs/timing-model.md, "sixteenth pass")
    e_every_pass: bool = False
    # a held `W` (the built-in line's W puts itself back while the stepper runs) runs
    # every pass while a stepper runs, in the normal mode without `e` (whose passes
    # e_every_pass governs): the pass that reads a status line's deadline is the one the
    # pass chain leads to (docs/timing-model.md, "forty-second pass"; False: idle passes
    # skipped to the deadline; build d's ATmega328P since the fiftieth pass)
    w_every_pass: bool = False
    # ... and the pass's CPU before a running stepper's status line (its millis() read,
    # the steppers' isRunning(), output_info()'s head), taken out of the pass's own
    # charge: build d's replica puts the line's first character 408-854 ticks after
    # timer 0's overflow (35 lines of the README move), the model with every pass of W
    # 151-597: 257 (forty-second pass; 0: at the pass's start; 257 in build d's
    # ATmega328P since the fiftieth pass)
    status_lead_ticks: int = 0
    # ... and with loop_sections, each such pass's own sections with interrupts off, as
    # the idle polls place them (loop_poll_running's widths): isRunning()'s queue read at
    # the pass's start and millis() this many ticks before its end (build d's replica:
    # passes of 330 / 467 with millis() at 207 / 344, both 123 before the end;
    # docs/timing-model.md, "forty-third pass"; 0: a held W's passes carry no sections;
    # 123 in build d's ATmega328P since the fiftieth pass)
    w_pass_millis_before_end: int = 0
    # `e` on, outside a window: a pass that skips the block is this much shorter than a
    # window's pass less its block (the replica of e01: 267 against 1 852 - 1 582)
    e_outside_saved_ticks: int = 0
    # `e` on: the loop's own check of the flag and of millis() on every pass, beside the
    # block (0: in loop_pass_ticks; build d's replica: its passes 4 ticks longer in a
    # window, 3 outside - docs/timing-model.md, "thirty-first pass"; off)
    e_check_ticks: int = 0
    # the loop's CPU from its `ms = millis()` read to the `e` block's cli (the replica:
    # 26 ticks on the ATmega328P and the ATmega2560), spent there rather than with the
    # rest of the pass after the check (the pass's length unchanged; 0: the block
    # follows the read at once; docs/timing-model.md, "twenty-second pass")
    e_read_block_ticks: int = 0
    # the loop's own critical sections (docs/timing-model.md, fourteenth and twenty-sixth
    # passes) followed: build d's ATmega328P since the fiftieth pass, off elsewhere
    # (the chip's figures measured with them: fas.sim.timing's
    # SimTiming.loop_section_widths)
    loop_sections: bool = False
    # those sections while the loop polls with a stepper running, as (pass length,
    # ((offset in the pass, ticks with interrupts off), ...)): during a `w<ms>` and
    # otherwise (None: not measured)
    loop_poll_pause: LoopPoll | None = None
    loop_poll_running: LoopPoll | None = None
    # test sequence 11's position reads in a loop: one getCurrentPosition() (ticks) and,
    # where measured, how that loop turns interrupts off (as loop_poll_pause; one read
    # per section: with loop_sections on, a read takes its pass's length / its sections)
    position_read_ticks: int = 96
    position_read_poll: LoopPoll | None = None


# ------------------------------------------------------------------------------ costs
# build d's commands read from its replica (bench/replica/command_costs.py over 56 of its
# runs; docs/timing-model.md, "thirty-sixth pass"): by letter, the CPU from the firmware's
# process_cmd() entry to the command's first character handed to the serial driver
# (interrupts out), less what the model charges there beside cmd_ticks (the argument's
# characters, the message table's look-up before the first character, a number's
# digits): the median over the runs.  Build d's ATmega328P default (ATMEGA328P_BUILD,
# fortieth pass; alone it left d34, dm09 and test_sd_18 failing: the rest of their chain
# lay in the `w` end's anchor, the coasts and the tails below).  '+', '-' and '?' are not
# read (their first character waits for the step or for room in the serial
# buffer)
BUILD_D_REPLICA_COMMANDS: dict[str, int] = {
    "M": 515 + 64, "A": 680 - 165, "V": 528 - 15, "R": 552 - 87, "P": 596 - 118,
    "a": 770 - 268, "j": 433 + 221, "J": 456 + 196, "E": 515 + 12, "D": 435 + 79,
    "w": 461 - 98, "K": 128 + 109, "S": 145 + 195, "U": 156 + 103, "X": 323 - 90,
    "f": 226 + 54, "b": 223 + 58, "e": 140 + 180, "r": 144 + 176, "u": 223 + 122,
    "N": 319 - 102, "Q": 140 + 72, "H": 1110 - 489, "h": 1847 - 1197,
}
# ... and their tails (cmd_tail_ticks), read where a stepper runs (the serial buffer has
# room): from the command's last write call to the next command's process_cmd(), the
# replica's CPU less the model's charges there (the library call that follows the print:
# A's setAcceleration(), S's stopMove(); the rest of the command's pass): the median.
# Superseded by BUILD_D_REPLICA_TAILS_P39 (read again under the print body)
BUILD_D_REPLICA_COMMAND_TAILS: dict[str, int] = {
    "A": 296, "S": 347, "V": 158, "R": 136, "U": 41, "K": 25, "f": 59, "P": 14, "a": 14,
}
# ... and two letters given while a stepper runs, read on build d's replica of the runs
# dm01-dm12 (their firmware is build d's but for the input's define in the library and
# one byte of data: the same steps, 643-677 ticks earlier): `H` 749 (8 commands, 737-757:
# the speed's division after its print), `X` 1 058 (3, 966-1 066) (docs/timing-model.md,
# thirty-seventh pass; superseded by BUILD_D_REPLICA_TAILS_P39)
BUILD_D_REPLICA_RUNNING_TAILS: dict[str, int] = {"H": 749, "X": 1058}
# ... and a print's body from a buffer, CPU per character between two calls of
# HardwareSerial::write(unsigned char), interrupts out, read on build d's replica (1 990
# prints of dm01-dm12, d21, d34, test_sd_07 without a wait for room: 107, the model's 121
# less 14 in every one).  The message table's texts keep the timing's figure: their plain
# characters cost 114, but the look-ups between their fragments make up the rest
# (docs/timing-model.md, thirty-ninth pass; build d's ATmega328P default since the
# fortieth pass)
BUILD_D_REPLICA_PRINT_BODY: dict[str, int] = {"buffer_char_ticks": 107}
# ... and under that body, the tails (COMMAND_TAILS and RUNNING_TAILS) read again with
# `command_costs.py --tails` over the d-runs and dm01-dm12: a command whose last print is
# a number's or a line end's from a buffer (A, S, V, R, f, H, X) reads 14 ticks more (its
# last character 107, not 121), the others (U, K, P, a) the same.  Build d's ATmega328P
# default (fortieth pass)
BUILD_D_REPLICA_TAILS_P39: dict[str, int] = {
    "A": 310, "S": 361, "V": 172, "R": 150, "U": 41, "K": 25, "f": 73, "P": 14, "a": 14,
    "H": 763, "X": 1072,
}
# ... and the pass that ends a `w<ms>`: its CPU from the pass's start to `Wait complete`'s
# first character less the model's look-up of that message (9 329): 284 ticks, the median
# of all 44 such passes of the runs (276-376) - for pause_end_ticks.  Build d's ATmega328P
# default (fortieth pass)
BUILD_D_REPLICA_PAUSE_END_TICKS = 284
# ... and a held W's pass before a running stepper's status line: the line's first
# character 408-854 ticks after timer 0's overflow on the replica (35 lines of the README
# move), the model with every pass of W 151-597: 257 (forty-second pass, S42); each such
# pass's millis() 123 ticks before its end (passes of 330 / 467, millis() at 207 / 344:
# forty-third pass, L43).  Build d's ATmega328P default since the fiftieth pass
BUILD_D_REPLICA_STATUS_LEAD_TICKS = 257
BUILD_D_REPLICA_W_PASS_MILLIS_BEFORE_END = 123
AVR_COSTS = DemoBuild(
    has_stray_digital_read=True,
    setup_head_ticks=2700,
    setup_steppers_ticks=3758,
    loop_pass_ticks=342,
    msg_scan_byte_ticks=11,
    msg_lookup_ticks=56,
    print_digit_ticks=603,
    print_call_ticks=180,
    info_ticks=450,
    info_scan_ticks=50,
    cmd_arg_char_ticks=113,
    cmd_default_ticks=150,
    cmd_ticks={
        "M": 515, "A": 680, "V": 528, "H": 1110, "h": 1847, "R": 552, "P": 596, "a": 770,
        "j": 433, "J": 456, "@": 638, "E": 515, "D": 435, "w": 461, "K": 128, "S": 145,
        "U": 156, "X": 323, "f": 226, "b": 223, "e": 140, "r": 144, "u": 223, "F": 405,
        "N": 319, "O": 319, "Q": 140, "I": 140, "W": 148, "+": 150, "-": 150, "?": 0,
        "t": 0, "c": 0, "x": 0, "d": 1451,
    },
    # noInterrupts(); delayMicroseconds(100); interrupts(): the AVR core's busy loop of
    # 4 cycles per round, 4 rounds per us less 5 for the call, plus cli and sei
    irq_block_ticks=4 * (4 * 100 - 5) + 2,
    # the main loop's critical sections (followed only with loop_sections), measured on
    # the replica of build d's 328P (docs/timing-model.md, twenty-seventh pass): the
    # sections of build e's (fourteenth pass, pulses) at other offsets, its passes longer.
    # isRunning()'s queue read 10 ticks from cli to sei at the pass's start, millis() 9
    # from cli to the SREG restore; an interrupt requested inside enters after the next
    # instruction (1 tick after sei, 2 after millis()'s restore: 11 each); a `w` pass
    # reads millis() twice (the pause, then the pass's own), 290 ticks; otherwise passes
    # of 330 and 467 ticks alternate, millis() 207 and 344 ticks after isRunning().
    # Test sequence 11's getCurrentPosition() loop: build e's (one read every 183 or 198
    # ticks, interrupts off for 37 ticks of it and the instruction after the sei: 38;
    # not read on build d)
    loop_poll_pause=(290, ((0, 11), (167, 11), (215, 11))),
    loop_poll_running=(797, ((0, 11), (207, 11), (330, 11), (674, 11))),
    position_read_poll=(381, ((0, 38), (183, 38))),
)

# the same on the replica of build e's 328P (fourteenth pass, pulses): a `w` pass 260
# ticks, its millis() reads at 111 and 148; otherwise passes of 265 and 366 ticks,
# millis() 153 and 254 ticks after isRunning()
E_LOOP_POLLS: dict[str, LoopPoll] = {
    "loop_poll_pause": (260, ((0, 11), (111, 11), (148, 11))),
    "loop_poll_running": (631, ((0, 11), (153, 11), (265, 11), (519, 11))),
}

# ESP32 and the Pico: not measured on a firmware run, estimates
ESP32_COSTS = DemoBuild(
    setup_steppers_ticks=1600,
    loop_pass_ticks=32,
    msg_scan_byte_ticks=1,
    msg_lookup_ticks=5,
    irq_block_ticks=100 * 16,
)

SAM_COSTS = DemoBuild(
    setup_steppers_ticks=2100,
    loop_pass_ticks=100,
    msg_scan_byte_ticks=2,
    msg_lookup_ticks=20,
    irq_block_ticks=100 * 21,
)

# -------------------------------------------------------------------------------- AVR
ATMEGA328P_FITTED_BUILD = replace(
    AVR_COSTS,
    steppers=(
        DemoStepper(step=9, enable_low_active=6, direction=5, on_delay_us=500_000,
                    off_delay_ms=5000),
        DemoStepper(step=10, enable_low_active=8, direction=7, on_delay_us=5000,
                    off_delay_ms=10),
    ),
    debug_led_pin=13,
    # build d's `e` block: without link-time optimisation delayMicroseconds(100) is a
    # call with a run-time argument (its checks, shift and subtraction, call and ret):
    # 1 599 cycles from the cli to the SREG restore in every block of its replica (build
    # e inlines it: 1 582; docs/timing-model.md, "thirty-first pass")
    irq_block_ticks=1599,
    # build d's loop passes, read on its replica (d21, twenty-ninth pass; landed with the
    # block above, thirty-first pass): 376 ticks with both steppers idle, 330 with one
    # running, 338 in a `w` (millis() read twice); the paths as in AVR_COSTS (342 a pass)
    # on the other AVR chips, whose build d has no replica
    loop_pass_ticks=284,
    loop_idle_stepper_ticks=46,
    loop_running_stepper_ticks=0,
    loop_pause_ticks=8,
    # `W` holding the input: the command's pass 467 ticks against the letter's 330 (d21;
    # d30 in an `e` window 2 070 against 1 933, its blocks of 1 599 apart)
    cmd_ticks={**AVR_COSTS.cmd_ticks, "W": 137},
)
# ... and build d's StepperDemo as read from its replica (docs/timing-model.md, "fortieth
# pass (build d)": the default since then): each command's CPU to its first print, its tail after
# the prints (read under the print body below), the pass that ends a `w<ms>`, a print's
# body from a buffer.  ATMEGA328P_FITTED_BUILD keeps the fitted figures (build e's table
# starts from it)
ATMEGA328P_BUILD = replace(
    ATMEGA328P_FITTED_BUILD,
    cmd_ticks={**ATMEGA328P_FITTED_BUILD.cmd_ticks, **BUILD_D_REPLICA_COMMANDS},
    cmd_tail_ticks=dict(BUILD_D_REPLICA_TAILS_P39),
    pause_end_ticks=BUILD_D_REPLICA_PAUSE_END_TICKS,
    buffer_char_ticks=BUILD_D_REPLICA_PRINT_BODY["buffer_char_ticks"],
    # ... and since the fiftieth pass (with fas.sim.timing's half of the six): a held
    # W's every pass while a stepper runs and its CPU before a status line (S42), the
    # loop's critical sections with each such pass's millis() 123 ticks before its end
    # (L43).  Before: all off
    w_every_pass=True,
    status_lead_ticks=BUILD_D_REPLICA_STATUS_LEAD_TICKS,
    loop_sections=True,
    w_pass_millis_before_end=BUILD_D_REPLICA_W_PASS_MILLIS_BEFORE_END,
)


def _mega(profile: Profile) -> DemoBuild:
    """The Mega: its three steppers on the step timer's compare pins A, B, C."""
    a, b, c = (group[0] for group in profile.step_pin_groups)
    return replace(AVR_COSTS, steppers=(
        DemoStepper(step=a, enable_low_active=19, direction=21, on_delay_us=500_000,
                    off_delay_ms=5000),
        DemoStepper(step=b, enable_low_active=18, direction=20, on_delay_us=5000,
                    off_delay_ms=10),
        DemoStepper(step=c, enable_low_active=43, direction=42, on_delay_us=5000,
                    off_delay_ms=10),
    ))


# StepperPins_avr.h wires two of the three (the third entry of its table is empty)
ATMEGA32U4_BUILD = replace(
    AVR_COSTS,
    steppers=(
        DemoStepper(step=9, enable_low_active=16, direction=26, on_delay_us=500_000,
                    off_delay_ms=5000),
        DemoStepper(step=10, enable_low_active=15, direction=14, on_delay_us=5000,
                    off_delay_ms=10),
    ),
    small_build=True,
)

# ------------------------------------------------------------------------------ ESP32
# StepperPins_esp32.h, configuration 0 ("Test-HW"); its table has as many entries as
# the build has queues: 2, 4, 6, 8, 10 or (with exactly 14 queues) 14
_ESP32_TEST_HW = (
    DemoStepper(step=17, enable_low_active=26, direction=18, on_delay_us=50, off_delay_ms=1000),
    DemoStepper(step=15, enable_low_active=13, direction=18, on_delay_us=500, off_delay_ms=1000),
    DemoStepper(step=2, enable_low_active=12, direction=19, on_delay_us=500, off_delay_ms=1000),
    DemoStepper(step=5, enable_low_active=25, direction=22, on_delay_us=5000, off_delay_ms=10),
    DemoStepper(step=16, enable_low_active=27, direction=21, on_delay_us=5000, off_delay_ms=10),
    DemoStepper(step=4, enable_low_active=14, direction=21, on_delay_us=5000, off_delay_ms=10),
    DemoStepper(step=14, enable_low_active=26, direction=19, on_delay_us=5000, off_delay_ms=10),
    DemoStepper(step=23, enable_low_active=PIN_UNDEFINED, direction=18, on_delay_us=5000,
                off_delay_ms=10),
    DemoStepper(step=32, enable_low_active=PIN_UNDEFINED, direction=18, on_delay_us=5000,
                off_delay_ms=10),
    DemoStepper(step=33, enable_low_active=PIN_UNDEFINED, direction=PIN_UNDEFINED,
                on_delay_us=5000, off_delay_ms=10),
    DemoStepper(step=25, enable_low_active=PIN_UNDEFINED, direction=18, on_delay_us=5000,
                off_delay_ms=10),
    DemoStepper(step=26, enable_low_active=PIN_UNDEFINED, direction=18, on_delay_us=5000,
                off_delay_ms=10),
    DemoStepper(step=22, enable_low_active=26, direction=18, on_delay_us=5000, off_delay_ms=10),
    DemoStepper(step=21, enable_low_active=PIN_UNDEFINED, direction=18, on_delay_us=5000,
                off_delay_ms=10),
)


def _esp32_test_hw(max_steppers: int) -> tuple[DemoStepper, ...]:
    n = 2
    for limit, count in ((2, 4), (4, 6), (6, 8), (8, 10)):
        if max_steppers > limit:
            n = count
    if max_steppers == 14:
        n = 14
    return _ESP32_TEST_HW[:n]


def _esp32_driver_types(mcpwm: int, rmt: int, i2s: bool) -> tuple[DemoStepper, ...]:
    """Configuration 1 ("Driver-Types"): one stepper per driver the build has."""
    out = []
    if rmt:
        out.append(DemoStepper(step=17, enable_low_active=PIN_UNDEFINED, direction=18,
                               on_delay_us=0, off_delay_ms=0, auto_enable=False,
                               driver=FasDriver.RMT))
    if i2s:
        out.append(DemoStepper(step=15, enable_low_active=PIN_UNDEFINED, direction=18,
                               on_delay_us=0, off_delay_ms=0, auto_enable=False,
                               driver=FasDriver.I2S_DIRECT))
    if mcpwm:
        out.append(DemoStepper(step=2, enable_low_active=PIN_UNDEFINED, direction=19,
                               on_delay_us=0, off_delay_ms=0, auto_enable=False,
                               driver=FasDriver.MCPWM_PCNT))
    return tuple(out)


# StepperPins_esp32C3.h and StepperPins_esp32C6.h: two steppers, LED on GPIO 8
_ESP32_SMALL_DEMO: dict[str, tuple[str, tuple[DemoStepper, ...]]] = {
    "esp32c3": ("C3-Test", (
        DemoStepper(step=6, enable_low_active=PIN_UNDEFINED, direction=PIN_UNDEFINED,
                    on_delay_us=50, off_delay_ms=1000),
        DemoStepper(step=7, enable_low_active=PIN_UNDEFINED, direction=PIN_UNDEFINED,
                    on_delay_us=500, off_delay_ms=1000))),
    "esp32c6": ("C6-Test", (
        DemoStepper(step=6, enable_low_active=PIN_UNDEFINED, direction=7,
                    on_delay_us=50, off_delay_ms=1000),
        DemoStepper(step=15, enable_low_active=PIN_UNDEFINED, direction=18,
                    on_delay_us=500, off_delay_ms=1000))),
}


def _esp32(profile: Profile) -> DemoBuild:
    """An ESP32 profile's build: its pin configurations follow its chip and drivers."""
    chip = profile.name.split("_idf")[0]  # ESP32 profiles: <chip> or <chip>_idf<N>
    if chip in _ESP32_SMALL_DEMO:
        cfg_name, small = _ESP32_SMALL_DEMO[chip]
        return replace(ESP32_COSTS, steppers=small,
                       configs=(DemoConfig(cfg_name, small),), debug_led_pin=8)
    steppers = _esp32_test_hw(profile.max_steppers)
    select = profile.driver_select
    mcpwm = profile.driver_pool(FasDriver.MCPWM_PCNT)
    rmt = profile.driver_pool(FasDriver.RMT)
    types = _esp32_driver_types(mcpwm.queues if mcpwm and select else 0,
                                rmt.queues if rmt and select else 0,
                                profile.has_i2s and select)
    return replace(ESP32_COSTS, steppers=steppers,
                   configs=(DemoConfig("Test-HW", steppers), DemoConfig("Driver-Types", types)))


# ---------------------------------------------------------------------------- SAM Due
# StepperPins_sam.h lists six steppers, but only GPIO 17 (PWM channel 1) is a step
# pin on the Due: setup() stops at the second entry (GPIO 15), so the demo has M1
SAM_DUE_BUILD = replace(
    SAM_COSTS,
    steppers=(
        DemoStepper(step=17, enable_low_active=26, direction=18, on_delay_us=50,
                    off_delay_ms=1000),
        DemoStepper(step=15, enable_low_active=13, direction=18, on_delay_us=500,
                    off_delay_ms=1000),
        DemoStepper(step=2, enable_low_active=12, direction=19, on_delay_us=500,
                    off_delay_ms=1000),
        DemoStepper(step=5, enable_low_active=25, direction=22, on_delay_us=5000,
                    off_delay_ms=10),
        DemoStepper(step=16, enable_low_active=27, direction=21, on_delay_us=5000,
                    off_delay_ms=10),
        DemoStepper(step=4, enable_low_active=14, direction=21, on_delay_us=5000,
                    off_delay_ms=10),
    ),
)

# ------------------------------------------------------------------ Raspberry Pi Pico
_PICO_DEMO = (
    DemoStepper(step=14, enable_low_active=13, direction=15, on_delay_us=500_000,
                off_delay_ms=5000),
    DemoStepper(step=18, enable_low_active=PIN_UNDEFINED, direction=PIN_UNDEFINED,
                on_delay_us=500_000, off_delay_ms=5000),
    DemoStepper(step=19, enable_low_active=PIN_UNDEFINED, direction=PIN_UNDEFINED,
                on_delay_us=500_000, off_delay_ms=5000),
)

PICO_BUILD = replace(ESP32_COSTS, steppers=_PICO_DEMO,
                     configs=(DemoConfig("Default", _PICO_DEMO),), debug_led_pin=25)

BY_PROFILE: dict[str, DemoBuild] = {
    "atmega328p": ATMEGA328P_BUILD,
    **{p.name: _mega(p) for p in (ATMEGA2560, *ATMEGA2560_VARIANTS)},
    "atmega32u4": ATMEGA32U4_BUILD,
    **{p.name: _esp32(p) for p in ESP32_PROFILES},
    "sam_due": SAM_DUE_BUILD,
    "rp2040": PICO_BUILD,
    "rp2350": PICO_BUILD,
    # upstream's pc_based test platform: the ESP32's wiring, no start-up prompt
    PC_TEST.name: replace(_esp32(ESP32), configs=()),
}


# the firmware builds whose StepperDemo costs differ from the default build's
# (fas.sim.builds), by profile name
BY_BUILD: dict[str, dict[str, DemoBuild]] = {
    "e": {"atmega328p": replace(ATMEGA328P_FITTED_BUILD, loop_pass_ticks=220, setup_head_ticks=1450,
                                irq_block_ticks=AVR_COSTS.irq_block_ticks,
                                loop_pause_ticks=AVR_COSTS.loop_pause_ticks,
                                loop_running_stepper_ticks=10, loop_idle_stepper_ticks=40,
                                loop_char_ticks=5, loop_stray_read_ticks=81,
                                cmd_ticks={**AVR_COSTS.cmd_ticks, "W": 106}, **E_LOOP_POLLS),
          # (setup() entry to the banner: 2076 ticks - the ramp task of e13 runs where the
          # firmware's does, mod 65536, with the start-up of fas.sim.timing's
          # AVR_MEGA_E_TIMING)
          **{p.name: replace(_mega(p), loop_pass_ticks=300, loop_running_stepper_ticks=10,
                             setup_head_ticks=2076,
                             loop_idle_stepper_ticks=40, loop_char_ticks=5,
                             cmd_ticks={**AVR_COSTS.cmd_ticks, "W": 106}, **E_LOOP_POLLS)
             for p in (ATMEGA2560, *ATMEGA2560_VARIANTS)},
          "atmega32u4": replace(ATMEGA32U4_BUILD, loop_pass_ticks=248,
                                loop_running_stepper_ticks=10, loop_idle_stepper_ticks=40,
                                loop_char_ticks=5,
                                cmd_ticks={**AVR_COSTS.cmd_ticks, "W": 105}, **E_LOOP_POLLS)},
}


def demo_build(profile: Profile, firmware: str | None = None) -> DemoBuild:
    """StepperDemo's build for ``profile``, in firmware build ``firmware``
    (:mod:`fas.sim.builds`; None: the default build)."""
    build = BY_BUILD.get(check_build(firmware), {}).get(profile.name) or BY_PROFILE.get(
        profile.name)
    if build is None:
        raise ValueError(f"no StepperDemo build for profile {profile.name!r}: "
                         "add it to stepperdemo/demo/build.py")
    return build


def pin_config_problem(profile: Profile, index: int) -> str | None:
    """Why ``index`` cannot answer this build's start-up prompt, or None."""
    configs = demo_build(profile).configs
    if not configs:
        return msg.PIN_CONFIG_NONE.format(arch=profile.name)
    if not 0 <= index < len(configs):
        names = ", ".join(f"{i} ({c.name})" for i, c in enumerate(configs))
        return msg.PIN_CONFIG_RANGE.format(index=index, arch=profile.name, names=names)
    return None
