"""Architecture profiles: every hardware figure of the project lives in this module.

One :class:`Profile` per supported chip (and build variant: the ATmega2560's timer
module, the ESP-IDF version of an ESP32).  The library (`fas`) reads its limits from
here; the simulated machine (`fas.sim`) reads its timing model from here; the
StepperDemo console reads its default pin configuration and what its build of the
firmware contains from here.  Nothing else in the code base carries a
per-architecture number or an ``if arch == ...`` chain.

Figures come from FastAccelStepper 1.2.7 (its ``pd_*/pd_config*.h``, the platform
drivers and StepperDemo's ``StepperPins_*.h``).  The ``sim_*`` figures are the timing
model of the simulated machine; for the ATmega328P they are calibrated against the
AVR-simulator runs in ``shared/conformance`` (see ``docs/timing-model.md``).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from . import log2
from .codes import PIN_UNDEFINED, FasDriver

# --- the serial firmware's queue ring (docs/serial-protocol.md, section 9) ---
SERIAL_ENTRY_BYTES = 4  # steps u8, flags u8, ticks u16 per ring entry on the device
SERIAL_SLOT_HEADER_BYTES = 2  # an out-of-order frame slot: length and sequence number
SERIAL_QUEUE_MIN = 16  # a ring below this cannot hold the library's ramp planning
SERIAL_QUEUE_MAX = 128  # the ring is indexed by the 8-bit write index: a divisor of 256
# How the Uno (2048 bytes) spends its RAM on the serial firmware:
#   serial_reserved_bytes 1024 = UART rings 2 x 64, the frame received 64 and sent 64,
#     steppers' state 2 x 32, session, clock, counters 96, user outputs (section 16) 32,
#     inputs and limit switches (section 18) 128, Arduino core 64, stack 384;
#   out-of-order frame slots 8 x (32 + 2) = 272;
#   queue rings 2 x 64 entries x 4 bytes = 512          -> 1808 bytes, 240 spare.
# The other profiles have RAM to spare: their rings are SERIAL_QUEUE_MAX deep.


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


@dataclass(frozen=True)
class DriverPool:
    """One kind of step generator of a chip and what it can do (ESP32's FasDriver)."""

    driver: int  # FasDriver value
    queues: int  # steppers this driver can run
    max_speed_ticks: int  # shortest step period
    # get_current_position() counts the steps of the command being executed (MCPWM/PCNT
    # reads its counter); False: the position moves by whole commands (RMT, I2S)
    position_in_command: bool = True
    # pauses added before/after the first command in a new direction (the driver needs
    # the direction pin settled one buffer ahead)
    before_dir_change_ticks: int = 0
    after_dir_change_ticks: int = 0


PWM_RULE_COUNTS = "counts"  # AVR / SAM timers: a prescaler and a TOP (period = N*(TOP+1))
PWM_RULE_BITS = "bits"  # ESP32 LEDC: whole bits of resolution, fractional clock divider


@dataclass(frozen=True)
class PwmTimer:
    """A hardware timer that makes the PWM of user analog outputs (issue 12).

    ``rule`` says how a frequency becomes a timer setting (:mod:`fas.pwm`):

    * :data:`PWM_RULE_COUNTS` - the timer counts ``clock_hz / N`` with N one of
      ``prescalers`` up to TOP; a period is TOP+1 counts, at most ``2**width_bits``.
      ``fixed_top`` > 0: TOP cannot move (both compare units of the timer make PWM,
      or the timer also runs ``millis()``), only the prescaler is chosen.
    * :data:`PWM_RULE_BITS` - ESP32 LEDC: the resolution is the largest whole number
      of bits with ``2**bits <= clock_hz / f``, at most ``width_bits``; the clock
      divider has ``divider_frac_bits`` fractional bits and at most ``divider_max``
      as its integer part.
    """

    name: str
    clock_hz: int
    rule: str
    width_bits: int
    prescalers: tuple[int, ...] = (1,)
    fixed_top: int = 0
    divider_frac_bits: int = 0
    divider_max: int = 0


@dataclass(frozen=True)
class PwmPin:
    """A pin that a PWM timer drives (its compare unit, e.g. ``OC2B``)."""

    pin: int
    timer: str
    unit: str


@dataclass(frozen=True)
class QsTimer:
    """A hardware timer the QuickStep planner can run on (its periodic base time)."""

    number: int  # timer 2, timer 3 ...
    bits: int  # 8 or 16: the counter width, so the longest base time
    prescalers: tuple[int, ...]  # clock dividers the timer offers


@dataclass(frozen=True)
class Profile:
    name: str
    title: str
    f_cpu: int
    ticks_per_s: int
    min_cmd_ticks: int
    min_dir_delay_us: int
    max_dir_delay_us: int
    queue_len: int
    max_steppers: int
    # step pins: one tuple of alternatives per queue (channel); the index is the queue
    step_pin_groups: tuple[tuple[int, ...], ...]
    # fixed pin -> queue mapping (AVR timer channels) or first free queue (ESP32)
    fixed_queue_mapping: bool
    # max speed (ticks/step) by number of connected steppers: index 0 = one stepper
    max_speed_ticks_by_count: tuple[int, ...]
    fill_period_ticks: int  # the periodic ramp task (timer overflow / RTOS task)
    delay_ms_base: int  # granularity of the auto-disable counter in ms
    has_stray_digital_read: bool  # StepperDemo's `r` exists (AVR Arduino core only)
    irq_block_delays_steps: bool  # `e` delays step interrupts (AVR); ESP32 is immune
    demo_steppers: tuple[DemoStepper, ...]
    debug_led_pin: int
    # --- simulated machine timing model (ticks of this profile) ---
    sim_timer_wrap_ticks: int  # compare timer width: a missed compare waits one wrap (0: none)
    sim_queue_start_ticks: int  # startQueue(): first compare this far after the call
    # compare match -> ISR clears the step pin (the pulse width), per channel
    sim_isr_latency_ticks: tuple[int, ...]
    sim_isr_duration_ticks: int  # CPU time of one step interrupt (taken from the loop)
    sim_fill_entry_ticks: int  # periodic task start -> first command computed
    sim_fill_cmd_ticks: int  # CPU time per generated queue command with several steps
    sim_fill_single_ticks: int  # ... with one step
    sim_fill_pause_ticks: int  # ... without steps (a pause)
    sim_task_phase_ticks: int  # first periodic task after power-on
    sim_boot_ticks: int  # reset -> first line of setup()
    sim_boot_script_byte_ticks: int  # ... plus this per byte of a built-in input line
    sim_setup_head_ticks: int  # setup() entry -> first character of the banner
    sim_setup_steppers_ticks: int  # engine.init() -> first stepper's pins configured
    sim_loop_pass_ticks: int  # one pass of StepperDemo's loop() without output
    sim_char_ticks: int  # CPU time to hand one character to the serial driver
    sim_msg_scan_byte_ticks: int  # StepperDemo's message table: one byte read
    sim_msg_lookup_ticks: int  # ... one look-up (call overhead)
    sim_uart_byte_ticks: int  # one character on the wire (start + 8 data + stop)
    sim_uart_tx_buffer: int  # characters the serial driver holds before blocking
    sim_uart_isr_ticks: int  # transmit interrupt, once per buffered character
    sim_millis_overflow_ticks: int  # Arduino timer0 overflow period (millis() source)
    sim_irq_block_ticks: int = 0  # StepperDemo's `e`: length of one blocked section
    # StepperDemo's loop, per path (measured on the firmware, docs/timing-model.md):
    sim_print_digit_ticks: int = 0  # printing a number: one 32-bit division per digit
    sim_print_call_ticks: int = 0  # printing a number or an empty line: the call
    sim_info_ticks: int = 0  # one stepper's status (the library getters), without prints
    sim_info_scan_ticks: int = 0  # output_info(): per connected stepper (isRunning)
    sim_cmd_arg_char_ticks: int = 0  # parsing a command: per character after the letter
    sim_cmd_default_ticks: int = 0  # executing a command without its own figure
    sim_millis_isr_ticks: int = 0  # Arduino's timer-0 overflow interrupt (millis())
    # executing a command, by letter, without its prints and argument parsing
    sim_cmd_ticks: dict[str, int] = field(default_factory=dict, compare=False)
    # characters the serial driver's receive buffer holds; more arriving while the
    # program does not read are lost (the console device's line, issue 15)
    sim_uart_rx_buffer: int = 63
    # --- serial firmware (docs/serial-protocol.md): RAM budget of the device ---
    ram_bytes: int = 0  # the chip's data RAM
    serial_reserved_bytes: int = 0  # firmware RAM besides queue rings and frame slots
    serial_rx_slots: int = 0  # out-of-order frames the device holds (selective repeat)
    serial_slot_payload: int = 0  # payload bytes of one such slot = largest host frame
    # the library's own queue length where it differs from queue_len (a serial device's
    # deeper ring): the API's limits (the enable delay) stay those of the chip
    api_queue_len: int = 0
    # --- QuickStep planner (issue 14): its timers and their interrupt costs ---
    # timers QuickStep may use, the default first; empty: QuickStep is not available
    qs_timers: tuple[QsTimer, ...] = ()
    qs_ram_bytes: int = 0  # RAM left for the order FIFOs (4 bytes per order)
    qs_order_bytes: int = 4  # one order: int16 steps (sign = direction), uint16 interval
    qs_min_base_ticks: int = 0  # shortest base time (below it the ISR eats the CPU)
    qs_period_isr_ticks: int = 0  # CPU of the base-period interrupt (entry, exit, timer)
    qs_motor_isr_ticks: int = 0  # ... plus this per running QuickStep motor
    qs_step_isr_ticks: int = 0  # CPU of the compare interrupt that makes one step
    qs_pulse_ticks: int = 0  # step pin high time (the compare ISR writes it high, then low)
    qs_start_ticks: int = 0  # order pushed to an idle motor -> its first step
    # Arduino pin -> I/O port register (AVR); pins of one port are written together
    pin_ports: dict[int, str] = field(default_factory=dict, compare=False)
    # Arduino A0, A1, ... as pin numbers (analog inputs; the helix winder, issue 13)
    analog_pins: tuple[int, ...] = ()
    notes: str = field(default="", compare=False)
    # --- user outputs (issue 12, fas.outputs): Dout0..3 and Aout0..3 -----------------
    # pins of the four digital outputs (PIN_UNDEFINED: this chip has none free)
    user_digital_pins: tuple[int, ...] = ()
    # the four analog (PWM) outputs: pin and timer (pin PIN_UNDEFINED: none free)
    user_analog: tuple[PwmPin, ...] = ()
    # the PWM timers and every pin they can drive (overrides must pick one of these)
    pwm_timers: tuple[PwmTimer, ...] = ()
    pwm_pins: tuple[PwmPin, ...] = ()
    # the output's timer can be routed to any pin (ESP32 GPIO matrix)
    pwm_any_pin: bool = False
    pwm_default_hz: int = 5000  # seed 003: frequency of an analog output unless set
    # --- platform features (issue 17: parity with FastAccelStepper 1.2.7) ---
    family: str = "avr"  # avr, esp32, sam, rp2040, test
    timer_module: int = 0  # AVR: the 16-bit timer of the step channels (FAS_TIMER_MODULE)
    # SAM: each pin group is one PWM channel, usable once; queues are given out in order
    step_pin_channel_groups: bool = False
    # ESP32: the step generators, in the order DRIVER_DONT_CARE tries them
    drivers: tuple[DriverPool, ...] = ()
    driver_select: bool = False  # SUPPORT_SELECT_DRIVER_TYPE: driver_type() and friends
    dynamic_allocation: bool = False  # ESP-IDF 5: steppers numbered in connect order
    idf_version: tuple[int, int] = (0, 0)  # ESP-IDF major.minor of the build
    i2s_controllers: int = 0  # ESP-IDF 5: I2S units for I2S_DIRECT / the multiplexer
    i2s_mux_slots: int = 0
    pulse_counter_units: int = 0  # ESP32 pcnt units usable by attach_to_pulse_counter
    task_rate_change: bool = False  # engine.task_rate() (ESP32, Pico)
    cpu_affinity: bool = False  # engine.init(cpu_core) (ESP32)
    abs_speed_limit: bool = True  # set_absolute_speed_limit() (not on SAM)
    external_dir_pin: bool = True  # PIN_EXTERNAL_FLAG direction pins (not ATmega32U4)
    debug_led_half_period: int = 0  # ramp-task runs per LED phase (0: 1 Hz on the AVR timer)
    # --- StepperDemo's build for this chip ---
    demo_configs: tuple[DemoConfig, ...] = ()  # >0: the start-up pin configuration prompt
    demo_config_wait_ms: int = 5000  # ... how long it waits for a digit
    demo_small_build: bool = False  # ATmega32U4: no T, d, W/w usage, test usage, seq 13
    console_usb: bool = False  # Serial is USB CDC: no baud-rate limit (32U4, Pico)

    # ---- derived figures -------------------------------------------------
    @property
    def ticks_per_us(self) -> int:
        return self.ticks_per_s // 1_000_000

    @property
    def ticks_per_ms(self) -> int:
        return self.ticks_per_s // 1000

    @property
    def max_on_delay_ticks(self) -> int:
        return 65535 * ((self.api_queue_len or self.queue_len) - 1)

    @property
    def log2_ticks_per_s(self) -> int:
        return log2.const(self.ticks_per_s)

    @property
    def log2_ticks_per_s_div_sqrt2(self) -> int:
        return log2.const(self.ticks_per_s / 2**0.5)

    @property
    def log2_accel_factor(self) -> int:
        return log2.const(self.ticks_per_s * self.ticks_per_s / 2)

    def us_to_ticks(self, us: int) -> int:
        return (us * self.ticks_per_us) & 0xFFFFFFFF

    def ticks_to_us(self, ticks: int) -> int:
        return ticks // self.ticks_per_us

    def isr_latency_ticks(self, channel: int) -> int:
        table = self.sim_isr_latency_ticks
        return table[min(channel, len(table) - 1)]

    def max_speed_ticks(self, stepper_count: int) -> int:
        table = self.max_speed_ticks_by_count
        return table[min(max(stepper_count, 1), len(table)) - 1]

    # ---- the serial firmware's RAM budget (one table: SERIAL_RAM_TABLE) ----
    @property
    def serial_slot_bytes(self) -> int:
        """RAM of the out-of-order frame slots: payload plus length and sequence bytes."""
        return self.serial_rx_slots * (self.serial_slot_payload + SERIAL_SLOT_HEADER_BYTES)

    @property
    def serial_queue_len(self) -> int:
        """Entries per queue ring on a serial device: what its RAM holds after everything
        else, for every stepper, as the largest power of two (the ring is indexed by the
        8-bit write index) between SERIAL_QUEUE_MIN and SERIAL_QUEUE_MAX."""
        free = self.ram_bytes - self.serial_reserved_bytes - self.serial_slot_bytes
        per_queue = free // (self.max_steppers * SERIAL_ENTRY_BYTES)
        n = SERIAL_QUEUE_MIN
        while n * 2 <= min(per_queue, SERIAL_QUEUE_MAX):
            n *= 2
        return n

    @property
    def serial_ram_used(self) -> int:
        """RAM the serial firmware uses in all (reserved + rings + frame slots)."""
        return (self.serial_reserved_bytes + self.serial_slot_bytes
                + self.max_steppers * self.serial_queue_len * SERIAL_ENTRY_BYTES)

    def with_queue_len(self, queue_len: int) -> Profile:
        """This profile with a command queue of ``queue_len`` entries (a serial device's
        ring: the host's mirror and the device's queue are that deep)."""
        return replace(self, queue_len=queue_len,
                       api_queue_len=self.api_queue_len or self.queue_len)
    def pwm_timer(self, name: str) -> PwmTimer | None:
        for t in self.pwm_timers:
            if t.name == name:
                return t
        return None

    def pwm_pin(self, pin: int) -> PwmPin | None:
        """The PWM unit that can drive ``pin`` (None: the pin has no PWM hardware)."""
        for p in (*self.user_analog, *self.pwm_pins):
            if p.pin == pin and pin != PIN_UNDEFINED:
                return p
        return None

    def qs_timer(self, number: int | None = None) -> QsTimer | None:
        """The QuickStep timer ``number`` (None: the default one), or None."""
        for t in self.qs_timers:
            if number is None or t.number == number:
                return t
        return None

    def queue_for_step_pin(self, pin: int) -> int | None:
        """The pin group (AVR: the queue, SAM: the PWM channel) of a step pin."""
        for idx, group in enumerate(self.step_pin_groups):
            if pin in group:
                return idx
        return None

    def driver_pool(self, driver: int) -> DriverPool | None:
        for pool in self.drivers:
            if pool.driver == driver:
                return pool
        return None

    @property
    def has_pulse_counter(self) -> bool:
        return self.pulse_counter_units > 0

    @property
    def has_i2s(self) -> bool:
        return self.i2s_controllers > 0

    @property
    def led_half_period(self) -> int:
        return self.debug_led_half_period or max(1, self.ticks_per_s // 65536 // 2)


def _avr_uart_byte_ticks(f_cpu: int, baud: int, sim_bits: int = 10) -> int:
    """Ticks per character on the console UART.

    Arduino's HardwareSerial uses double speed: UBRR = (F_CPU/4/baud - 1)/2, so
    115200 baud is really 117647 baud, 136 CPU cycles per bit.  A real character is
    10 bits (1360 cycles).  The AVR simulator that produced the conformance data
    sends one character every 11 bit times (1496 cycles, measured on the firmware
    build); ``sim_bits=11`` reproduces it.
    """
    ubrr = (f_cpu // 4 // baud - 1) // 2
    return sim_bits * 8 * (ubrr + 1)


_AVR_TIMING = dict(
    sim_timer_wrap_ticks=65536,
    sim_queue_start_ticks=10,
    sim_isr_latency_ticks=(61, 73, 73),
    sim_isr_duration_ticks=120,
    sim_fill_entry_ticks=2436,
    sim_fill_cmd_ticks=2367,
    sim_fill_single_ticks=2102,
    sim_fill_pause_ticks=1455,
    sim_task_phase_ticks=67989,
    sim_boot_ticks=11200,
    sim_boot_script_byte_ticks=9,
    sim_setup_head_ticks=2700,
    sim_setup_steppers_ticks=3758,
    sim_loop_pass_ticks=342,
    sim_char_ticks=121,
    sim_msg_scan_byte_ticks=11,
    sim_msg_lookup_ticks=56,
    sim_uart_byte_ticks=_avr_uart_byte_ticks(16_000_000, 115200, sim_bits=11),
    sim_uart_tx_buffer=64,
    sim_uart_isr_ticks=114,
    sim_millis_overflow_ticks=64 * 256,
    sim_irq_block_ticks=100 * 16,
    sim_print_digit_ticks=603,
    sim_print_call_ticks=180,
    sim_info_ticks=450,
    sim_info_scan_ticks=50,
    sim_cmd_arg_char_ticks=113,
    sim_cmd_default_ticks=150,
    sim_millis_isr_ticks=96,
    sim_cmd_ticks={
        "M": 515, "A": 680, "V": 528, "H": 1110, "h": 1847, "R": 552, "P": 596, "a": 770,
        "j": 433, "J": 456, "@": 638, "E": 515, "D": 435, "w": 461, "K": 128, "S": 145,
        "U": 156, "X": 323, "f": 226, "b": 223, "e": 140, "r": 144, "u": 223, "F": 405,
        "N": 319, "O": 319, "Q": 140, "I": 140, "W": 148, "+": 150, "-": 150, "?": 0,
        "t": 0, "c": 0, "x": 0, "d": 1451,
    },
    sim_uart_rx_buffer=63,  # HardwareSerial: a 64-byte ring keeps one slot free
)

_AVR_PRESCALERS_T0_T1 = (1, 8, 64, 256, 1024)  # timers 0, 1, 3, 4, 5 (CS bits)
_AVR_PRESCALERS_T2 = (1, 8, 32, 64, 128, 256, 1024)  # timer 2 has two more
# timer 0 runs millis(): Arduino's fast PWM, prescaler 64, TOP 255 (976.5625 Hz) only
_AVR_TIMER0 = PwmTimer("timer 0", 16_000_000, PWM_RULE_COUNTS, 8, (64,), fixed_top=255)
_NO_PWM = PwmPin(PIN_UNDEFINED, "", "")
# QuickStep (seed 004) on AVR: timer 2 (8 bit, prescalers 1..1024) by default, so that
# the 16-bit timers stay free; base time 12 us .. 16.384 ms there, up to 4.19 s on a
# 16-bit timer.  No QuickStep build was available to measure the interrupt costs:
# they are estimates from the instruction counts of such routines (register saves
# ~40 cycles, a countdown per motor, a port write and the next compare per step),
# chosen so that at the 12 us minimum five motors leave no CPU (the seed's limit).
_TIMER2 = QsTimer(2, 8, (1, 8, 32, 64, 128, 256, 1024))
_AVR_QUICKSTEP = dict(
    qs_min_base_ticks=12 * 16,
    qs_period_isr_ticks=72,
    qs_motor_isr_ticks=24,
    qs_step_isr_ticks=96,
    qs_pulse_ticks=48,
    qs_start_ticks=80,
)

ATMEGA328P = Profile(
    name="atmega328p",
    title="ATmega328P (Arduino Uno/Nano), timer 1",
    f_cpu=16_000_000,
    ticks_per_s=16_000_000,
    min_cmd_ticks=16_000_000 // 25000,
    min_dir_delay_us=40,
    max_dir_delay_us=65535 // 16,
    queue_len=16,
    max_steppers=2,
    step_pin_groups=((9,), (10,)),
    fixed_queue_mapping=True,
    max_speed_ticks_by_count=(16_000_000 // 50000, 426, 16_000_000 // 20000),
    fill_period_ticks=65536,
    delay_ms_base=65_536_000 // 16_000_000,
    has_stray_digital_read=True,
    irq_block_delays_steps=True,
    demo_steppers=(
        DemoStepper(step=9, enable_low_active=6, direction=5, on_delay_us=500_000,
                    off_delay_ms=5000),
        DemoStepper(step=10, enable_low_active=8, direction=7, on_delay_us=5000,
                    off_delay_ms=10),
    ),
    debug_led_pin=13,
    pin_ports={**{p: "D" for p in range(0, 8)}, **{p: "B" for p in range(8, 14)},
               **{p: "C" for p in range(14, 20)}},
    analog_pins=tuple(range(14, 22)),  # A0..A7 (A6, A7: analog only)
    ram_bytes=2048,
    serial_reserved_bytes=1024,
    serial_rx_slots=8,
    serial_slot_payload=32,
    # free pins beside StepperDemo's wiring (5-10), the LED (13) and the UART (0, 1)
    user_digital_pins=(2, 4, 12, 14),
    # timer 1 steps the motors and timer 0 runs millis(): only timer 2 is left, and
    # with both its compare units as PWM its TOP is fixed at 255 (one prescaler for both)
    user_analog=(PwmPin(3, "timer 2", "OC2B"), PwmPin(11, "timer 2", "OC2A"),
                 _NO_PWM, _NO_PWM),
    pwm_timers=(PwmTimer("timer 2", 16_000_000, PWM_RULE_COUNTS, 8, _AVR_PRESCALERS_T2,
                         fixed_top=255), _AVR_TIMER0),
    pwm_pins=(PwmPin(5, "timer 0", "OC0B"), PwmPin(6, "timer 0", "OC0A")),
    # timer 1, the only 16-bit timer, belongs to FastAccelStepper (steps and ramp task)
    qs_timers=(_TIMER2,),
    # 2048 bytes of RAM; StepperDemo with FastAccelStepper keeps ~1 KB (input buffer 256,
    # serial buffers 128, queues, steppers, stack): the FIFOs get the other half
    qs_ram_bytes=1024,
    **_AVR_TIMING,
    **_AVR_QUICKSTEP,
)


def _ports(spec: str) -> dict[int, str]:
    """``"PE0 PE1 PE4 ..."`` in Arduino pin order -> {pin: port letter}."""
    return {pin: name[1] for pin, name in enumerate(spec.split())}


# Arduino Mega 2560: digital pin -> port (pins_arduino.h of the Arduino AVR core)
_MEGA_PORTS = _ports(
    "PE0 PE1 PE4 PE5 PG5 PE3 PH3 PH4 PH5 PH6 PB4 PB5 PB6 PB7 PJ1 PJ0 PH1 PH0 PD3 PD2 "
    "PD1 PD0 PA0 PA1 PA2 PA3 PA4 PA5 PA6 PA7 PC7 PC6 PC5 PC4 PC3 PC2 PC1 PC0 PD7 PG2 "
    "PG1 PG0 PL7 PL6 PL5 PL4 PL3 PL2 PL1 PL0 PB3 PB2 PB1 PB0 PF0 PF1 PF2 PF3 PF4 PF5 "
    "PF6 PF7 PK0 PK1 PK2 PK3 PK4 PK5 PK6 PK7")
# Arduino Leonardo (ATmega32U4)
_LEONARDO_PORTS = _ports(
    "PD2 PD3 PD1 PD0 PD4 PC6 PD7 PE6 PB4 PB5 PB6 PB7 PD6 PC7 PB3 PB1 PB2 PB0 PF7 PF6 "
    "PF5 PF4 PF1 PF0 PD4 PD7 PB4 PB5 PB6 PD6 PD5")

# ATmega2560: the step pins of each 16-bit timer's compare outputs A, B, C
_MEGA_TIMER_PINS = {1: (11, 12, 13), 3: (5, 2, 3), 4: (6, 7, 8), 5: (46, 45, 44)}


# user outputs of the Arduino Mega as issue 12 laid them out for the timer-4 build
_MEGA_OUTPUTS = dict(
    user_digital_pins=(22, 23, 24, 25),
    # one timer per output, so every output has its own frequency: the 16-bit timers
    # 1, 3, 5 with TOP in ICRn, and timer 2 (8 bit) with TOP in OCR2A (OC2A is lost)
    user_analog=(PwmPin(11, "timer 1", "OC1A"), PwmPin(5, "timer 3", "OC3A"),
                 PwmPin(46, "timer 5", "OC5A"), PwmPin(9, "timer 2", "OC2B")),
    pwm_timers=(
        PwmTimer("timer 1", 16_000_000, PWM_RULE_COUNTS, 16, _AVR_PRESCALERS_T0_T1),
        PwmTimer("timer 3", 16_000_000, PWM_RULE_COUNTS, 16, _AVR_PRESCALERS_T0_T1),
        PwmTimer("timer 5", 16_000_000, PWM_RULE_COUNTS, 16, _AVR_PRESCALERS_T0_T1),
        PwmTimer("timer 2", 16_000_000, PWM_RULE_COUNTS, 8, _AVR_PRESCALERS_T2),
        _AVR_TIMER0,
    ),
    pwm_pins=(PwmPin(12, "timer 1", "OC1B"), PwmPin(2, "timer 3", "OC3B"),
              PwmPin(3, "timer 3", "OC3C"), PwmPin(45, "timer 5", "OC5B"),
              PwmPin(44, "timer 5", "OC5C"), PwmPin(4, "timer 0", "OC0B"),
              PwmPin(13, "timer 0", "OC0A")),
)


def _mega(timer: int) -> Profile:
    a, b, c = _MEGA_TIMER_PINS[timer]
    default = timer == 4
    return Profile(
        name="atmega2560" if default else f"atmega2560_timer{timer}",
        title=f"ATmega2560 (Arduino Mega), timer {timer}",
        f_cpu=16_000_000,
        ticks_per_s=16_000_000,
        min_cmd_ticks=16_000_000 // 25000,
        min_dir_delay_us=40,
        max_dir_delay_us=65535 // 16,
        queue_len=16,
        max_steppers=3,
        step_pin_groups=((a,), (b,), (c,)),
        fixed_queue_mapping=True,
        max_speed_ticks_by_count=(16_000_000 // 50000, 426, 16_000_000 // 20000),
        fill_period_ticks=65536,
        delay_ms_base=65_536_000 // 16_000_000,
        has_stray_digital_read=True,
        irq_block_delays_steps=True,
        demo_steppers=(
            DemoStepper(step=a, enable_low_active=19, direction=21, on_delay_us=500_000,
                        off_delay_ms=5000),
            DemoStepper(step=b, enable_low_active=18, direction=20, on_delay_us=5000,
                        off_delay_ms=10),
            DemoStepper(step=c, enable_low_active=43, direction=42, on_delay_us=5000,
                        off_delay_ms=10),
        ),
        debug_led_pin=PIN_UNDEFINED,
        analog_pins=tuple(range(54, 70)),  # A0..A15
        ram_bytes=8192,
        serial_reserved_bytes=1024,
        serial_rx_slots=16,
        serial_slot_payload=59,
        pin_ports=_MEGA_PORTS,
        timer_module=timer,
        notes="FAS_TIMER_MODULE=%d" % timer + ("" if default else " (platformio build flag)"),
        # QuickStep: timer 2, or a 16-bit timer FastAccelStepper does not use
        qs_timers=(_TIMER2,) + tuple(QsTimer(t, 16, (1, 8, 64, 256, 1024))
                                     for t in ((3, 5) if default else (1, 3, 4, 5))
                                     if t != timer),
        qs_ram_bytes=8192 - 1536,  # 8 KB, ~1.5 KB for the program
        **(_MEGA_OUTPUTS if default else {}),
        **_AVR_TIMING,
        **_AVR_QUICKSTEP,
    )


ATMEGA2560 = _mega(4)
ATMEGA2560_VARIANTS = tuple(_mega(t) for t in (1, 3, 5))

ATMEGA32U4 = Profile(
    name="atmega32u4",
    title="ATmega32U4 (Arduino Leonardo), timer 1",
    f_cpu=16_000_000,
    ticks_per_s=16_000_000,
    min_cmd_ticks=16_000_000 // 25000,
    min_dir_delay_us=40,
    max_dir_delay_us=65535 // 16,
    queue_len=16,
    max_steppers=3,
    step_pin_groups=((9,), (10,), (11,)),
    fixed_queue_mapping=True,
    max_speed_ticks_by_count=(16_000_000 // 50000, 426, 16_000_000 // 20000),
    fill_period_ticks=65536,
    delay_ms_base=65_536_000 // 16_000_000,
    has_stray_digital_read=True,
    irq_block_delays_steps=True,
    # StepperPins_avr.h wires two of the three (the third entry of its table is empty)
    demo_steppers=(
        DemoStepper(step=9, enable_low_active=16, direction=26, on_delay_us=500_000,
                    off_delay_ms=5000),
        DemoStepper(step=10, enable_low_active=15, direction=14, on_delay_us=5000,
                    off_delay_ms=10),
    ),
    debug_led_pin=PIN_UNDEFINED,
    analog_pins=tuple(range(18, 24)),  # A0..A5 of the Leonardo
    ram_bytes=2560,  # 2.5 KB: the Uno's serial-firmware budget plus 512 bytes
    serial_reserved_bytes=1024,
    serial_rx_slots=8,
    serial_slot_payload=32,
    pin_ports=_LEONARDO_PORTS,
    timer_module=1,
    external_dir_pin=False,
    demo_small_build=True,
    console_usb=True,
    notes="Serial is the USB CDC port: output costs no UART time (the AVR simulator has "
          "no USB host, so the firmware's prints return at once)",
    **{**_AVR_TIMING, "sim_char_ticks": 40, "sim_uart_byte_ticks": 0},
)

# ----------------------------------------------------------------------------- ESP32
# Output-capable GPIOs per chip (the library accepts any pin whose drive strength can
# be read, i.e. every output GPIO; the SPI flash pins are included as upstream does).
_ESP32_GPIO = {
    "esp32": tuple(range(0, 20)) + (21, 22, 23, 25, 26, 27, 32, 33),
    "esp32s2": tuple(range(0, 46)),
    "esp32s3": tuple(range(0, 22)) + tuple(range(26, 49)),
    "esp32c3": tuple(range(0, 22)),
    "esp32c6": tuple(range(0, 31)),
    "esp32h2": tuple(range(0, 28)),
    "esp32p4": tuple(range(0, 55)),
}
_ESP32_F_CPU = {"esp32": 240_000_000, "esp32s2": 240_000_000, "esp32s3": 240_000_000,
                "esp32c3": 160_000_000, "esp32c6": 160_000_000, "esp32h2": 96_000_000,
                "esp32p4": 360_000_000}
_ESP32_TITLE = {"esp32": "ESP32", "esp32s2": "ESP32-S2", "esp32s3": "ESP32-S3",
                "esp32c3": "ESP32-C3", "esp32c6": "ESP32-C6", "esp32h2": "ESP32-H2",
                "esp32p4": "ESP32-P4"}
# per chip and ESP-IDF major version (pd_config_idf4/5/6.h):
# (MCPWM/PCNT queues, RMT queues, pulse counter units, I2S controllers)
_ESP32_IDF = {
    "esp32": {4: (6, 8, 8, 0), 5: (6, 8, 8, 2), 6: (0, 8, 0, 0)},
    "esp32s2": {4: (0, 4, 4, 0), 5: (0, 4, 4, 1), 6: (0, 4, 0, 0)},
    "esp32s3": {4: (4, 4, 4, 0), 5: (4, 4, 8, 2), 6: (0, 4, 0, 0)},
    "esp32c3": {4: (0, 2, 0, 0), 5: (0, 2, 0, 1), 6: (0, 2, 0, 0)},
    "esp32c6": {5: (2, 2, 4, 1), 6: (0, 2, 0, 0)},
    "esp32h2": {5: (2, 2, 4, 1), 6: (0, 2, 0, 0)},
    "esp32p4": {5: (0, 4, 4, 3), 6: (0, 4, 0, 0)},
}
_IDF_MINOR = {4: 4, 5: 3, 6: 0}  # the Arduino cores upstream tests: 2.0.17, 3.x, 7.x
_ESP32_RAM = {"esp32": 327680, "esp32s2": 327680, "esp32s3": 524288, "esp32c3": 409600,
              "esp32c6": 524288, "esp32h2": 327680, "esp32p4": 786432}  # internal SRAM
ESP32_MIN_CMD_TICKS = 16_000_000 // 5000
ESP32_MAX_SPEED_TICKS = 80  # 200 000 steps/s (MCPWM/PCNT, RMT, I2S direct)
ESP32_I2S_MUX_MAX_SPEED_TICKS = 400  # 40 000 steps/s
ESP32_I2S_MUX_SLOTS = 32
ESP32_I2S_DIRECT_QUEUES = 3
ESP32_I2S_BLOCK_TICKS = 500 * 16  # one 500 us DMA block at 16 ticks/us

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
_ESP32_SMALL_DEMO = {
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

_ESP32_TIMING = dict(
    sim_timer_wrap_ticks=0,
    sim_queue_start_ticks=16,
    sim_isr_latency_ticks=(16,),
    sim_isr_duration_ticks=0,
    sim_fill_entry_ticks=80,
    sim_fill_cmd_ticks=80,
    sim_fill_single_ticks=80,
    sim_fill_pause_ticks=40,
    sim_task_phase_ticks=8000,
    sim_boot_ticks=16000,
    sim_boot_script_byte_ticks=0,
    sim_setup_head_ticks=0,
    sim_setup_steppers_ticks=1600,
    sim_loop_pass_ticks=32,
    sim_char_ticks=4,
    sim_msg_scan_byte_ticks=1,
    sim_msg_lookup_ticks=5,
    sim_uart_byte_ticks=(10 * 16_000_000) // 115200,
    sim_uart_tx_buffer=128,
    sim_uart_isr_ticks=0,
    sim_millis_overflow_ticks=16000,
    sim_irq_block_ticks=100 * 16,
    sim_uart_rx_buffer=256,  # the Arduino-ESP32 core's default receive buffer
)


# user outputs of the ESP32 (issue 12; the other chips have no table yet)
_ESP32_OUTPUTS = dict(
    # with StepperDemo's six steppers wired only 0, 23, 32 and 33 stay free: the
    # outputs also use pins of steppers 4-6, and refuse them while those are connected
    user_digital_pins=(32, 33, 23, 25),
    user_analog=tuple(PwmPin(pin, f"LEDC timer {i}", f"LEDC channel {i}")
                      for i, pin in enumerate((5, 16, 4, 14))),
    # LEDC on the 80 MHz APB clock: whole bits of resolution, at most 13 (seed 003);
    # divider 1.0 .. 1023.996 in 1/256 steps (10.8 fixed point)
    pwm_timers=tuple(PwmTimer(f"LEDC timer {i}", 80_000_000, PWM_RULE_BITS, 13,
                              divider_frac_bits=8, divider_max=1023) for i in range(4)),
    pwm_any_pin=True,
)


def _esp32(chip: str, idf: int, name: str) -> Profile:
    mcpwm, rmt, pcnt, i2s = _ESP32_IDF[chip][idf]
    pools = []
    mcpwm_pool = DriverPool(FasDriver.MCPWM_PCNT, mcpwm, ESP32_MAX_SPEED_TICKS)
    rmt_pool = DriverPool(FasDriver.RMT, rmt, ESP32_MAX_SPEED_TICKS,
                          position_in_command=False,
                          before_dir_change_ticks=ESP32_MIN_CMD_TICKS)
    i2s_direct = DriverPool(FasDriver.I2S_DIRECT, min(ESP32_I2S_DIRECT_QUEUES, i2s),
                            ESP32_MAX_SPEED_TICKS, position_in_command=False,
                            before_dir_change_ticks=ESP32_I2S_BLOCK_TICKS,
                            after_dir_change_ticks=ESP32_I2S_BLOCK_TICKS)
    i2s_mux = DriverPool(FasDriver.I2S_MUX, ESP32_I2S_MUX_SLOTS if i2s else 0,
                         ESP32_I2S_MUX_MAX_SPEED_TICKS, position_in_command=False,
                         before_dir_change_ticks=ESP32_I2S_BLOCK_TICKS,
                         after_dir_change_ticks=ESP32_I2S_BLOCK_TICKS)
    dynamic = idf == 5
    # the order DRIVER_DONT_CARE tries: IDF 4 fills MCPWM/PCNT first, IDF 5 RMT first
    order = ((rmt_pool, i2s_direct, mcpwm_pool) if dynamic else (mcpwm_pool, rmt_pool))
    pools = [pool for pool in order if pool.queues]
    if i2s:
        pools.append(i2s_mux)  # only for I2S-flagged step pins (after init_i2s_mux)
    # the build's queue count (MAX_STEPPER, "Steppers=" in the banner)
    max_steppers = mcpwm + rmt + ((ESP32_I2S_MUX_SLOTS + ESP32_I2S_DIRECT_QUEUES) if i2s else 0)
    kinds = sum(1 for n in (mcpwm, rmt, i2s) if n)
    driver_select = kinds >= 2
    if chip in _ESP32_SMALL_DEMO:
        cfg_name, demo = _ESP32_SMALL_DEMO[chip]
        configs = (DemoConfig(cfg_name, demo),)
        led = 8
    else:
        demo = _esp32_test_hw(max_steppers)
        configs = (DemoConfig("Test-HW", demo),
                   DemoConfig("Driver-Types", _esp32_driver_types(
                       mcpwm if driver_select else 0, rmt if driver_select else 0,
                       bool(i2s) and driver_select)))
        led = PIN_UNDEFINED
    drivers = "+".join(f"{n} {d}" for n, d in ((mcpwm, "MCPWM/PCNT"), (rmt, "RMT")) if n)
    if i2s:
        drivers += f" + I2S ({i2s} controller{'s' if i2s > 1 else ''}, 32-slot mux)"
    major_minor = (idf, _IDF_MINOR[idf])
    gpio = _ESP32_GPIO[chip]
    return Profile(
        name=name,
        title=f"{_ESP32_TITLE[chip]}, ESP-IDF {idf}.{_IDF_MINOR[idf]}: {drivers}",
        f_cpu=_ESP32_F_CPU[chip],
        ticks_per_s=16_000_000,
        min_cmd_ticks=ESP32_MIN_CMD_TICKS,
        min_dir_delay_us=ESP32_MIN_CMD_TICKS // 16,
        max_dir_delay_us=65535 // 16,
        queue_len=32,
        max_steppers=max_steppers,
        step_pin_groups=(gpio,),
        fixed_queue_mapping=False,
        max_speed_ticks_by_count=(ESP32_MAX_SPEED_TICKS,),
        fill_period_ticks=4 * 16000,
        delay_ms_base=4,
        has_stray_digital_read=False,
        irq_block_delays_steps=False,
        demo_steppers=demo,
        debug_led_pin=led,
        family="esp32",
        drivers=tuple(pools),
        driver_select=driver_select,
        dynamic_allocation=dynamic,
        idf_version=major_minor,
        i2s_controllers=i2s,
        i2s_mux_slots=ESP32_I2S_MUX_SLOTS if i2s else 0,
        pulse_counter_units=pcnt,
        task_rate_change=True,
        cpu_affinity=True,
        debug_led_half_period=50,
        demo_configs=configs,
        ram_bytes=_ESP32_RAM[chip],
        serial_reserved_bytes=131072,
        serial_rx_slots=16,
        serial_slot_payload=59,
        notes="pulses come from the MCPWM/RMT/I2S peripherals; `e` does not delay them",
        # the ADC1 channels 0, 3, 6, 7, 4, 5 as A0..A5 (the ESP32 core's A-names)
        analog_pins=(36, 39, 34, 35, 32, 33) if chip == "esp32" else (),
        **(_ESP32_OUTPUTS if chip == "esp32" else {}),
        **_ESP32_TIMING,
    )


ESP32_PROFILES = tuple(
    _esp32(chip, idf, chip if idf == min(versions) else f"{chip}_idf{idf}")
    for chip, versions in _ESP32_IDF.items() for idf in sorted(versions))
ESP32 = next(p for p in ESP32_PROFILES if p.name == "esp32")

# ---------------------------------------------------------------------------- SAM Due
# pd_sam: the eight PWM channels and the pins that reach each (pinToChannel)
_SAM_CHANNEL_PINS = ((34, 67, 73, 35), (17, 36, 72, 37, 42), (38, 43, 63, 39),
                     (40, 64, 69, 41), (9,), (8, 44), (7, 45), (6,))

SAM_DUE = Profile(
    name="sam_due",
    title="Atmel SAM3X8E (Arduino Due)",
    f_cpu=84_000_000,
    ticks_per_s=21_000_000,
    min_cmd_ticks=21_000_000 // 5000,
    min_dir_delay_us=(21_000_000 // 5000) // 21,
    max_dir_delay_us=65535 // 21,
    queue_len=32,
    max_steppers=6,
    step_pin_groups=_SAM_CHANNEL_PINS,
    fixed_queue_mapping=False,
    max_speed_ticks_by_count=(420,),
    fill_period_ticks=2 * 21000,
    delay_ms_base=2,
    has_stray_digital_read=False,
    irq_block_delays_steps=False,
    # StepperPins_sam.h lists six steppers, but only GPIO 17 (PWM channel 1) is a step
    # pin on the Due: setup() stops at the second entry (GPIO 15), so the demo has M1
    demo_steppers=(
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
    debug_led_pin=PIN_UNDEFINED,
    analog_pins=tuple(range(54, 66)),  # A0..A11
    sim_timer_wrap_ticks=0,
    sim_queue_start_ticks=21,
    sim_isr_latency_ticks=(21 * 2,),
    sim_isr_duration_ticks=21 * 3,
    sim_fill_entry_ticks=100,
    sim_fill_cmd_ticks=400,
    sim_fill_single_ticks=400,
    sim_fill_pause_ticks=200,
    sim_task_phase_ticks=10000,
    sim_boot_ticks=21000,
    sim_boot_script_byte_ticks=0,
    sim_setup_head_ticks=0,
    sim_setup_steppers_ticks=2100,
    sim_loop_pass_ticks=100,
    sim_char_ticks=10,
    sim_msg_scan_byte_ticks=2,
    sim_msg_lookup_ticks=20,
    sim_uart_byte_ticks=(10 * 21_000_000) // 115200,
    sim_uart_tx_buffer=128,
    sim_uart_isr_ticks=0,
    sim_millis_overflow_ticks=21000,
    sim_irq_block_ticks=100 * 21,
    sim_uart_rx_buffer=127,  # UARTClass: a 128-byte ring keeps one slot free
    family="sam",
    step_pin_channel_groups=True,
    abs_speed_limit=False,
    debug_led_half_period=50,
    notes="step pins: one pin of each PWM channel group; six queues for eight channels",
    ram_bytes=98304,
    serial_reserved_bytes=16384,
    serial_rx_slots=16,
    serial_slot_payload=59,
    user_digital_pins=(50, 51, 52, 53),
    # timer-counter channels (TIOA), 32-bit, clocked from MCK/2, /8, /32, /128;
    # the PWM controller's pins 6-9 belong to the steppers
    user_analog=(PwmPin(2, "TC0 ch0", "TIOA0"), PwmPin(3, "TC2 ch1", "TIOA7"),
                 PwmPin(5, "TC2 ch0", "TIOA6"), PwmPin(11, "TC2 ch2", "TIOA8")),
    pwm_timers=tuple(PwmTimer(name, 84_000_000, PWM_RULE_COUNTS, 32, (2, 8, 32, 128))
                     for name in ("TC0 ch0", "TC2 ch1", "TC2 ch0", "TC2 ch2")),
    pwm_pins=(PwmPin(13, "TC0 ch0", "TIOB0"), PwmPin(10, "TC2 ch1", "TIOB7"),
              PwmPin(4, "TC2 ch0", "TIOB6"), PwmPin(12, "TC2 ch2", "TIOB8")),
)

# ------------------------------------------------------------------ Raspberry Pi Pico
_PICO_TIMING = {**_ESP32_TIMING, "sim_uart_byte_ticks": 0, "sim_char_ticks": 8,
                "sim_millis_overflow_ticks": 16000}
_PICO_DEMO = (
    DemoStepper(step=14, enable_low_active=13, direction=15, on_delay_us=500_000,
                off_delay_ms=5000),
    DemoStepper(step=18, enable_low_active=PIN_UNDEFINED, direction=PIN_UNDEFINED,
                on_delay_us=500_000, off_delay_ms=5000),
    DemoStepper(step=19, enable_low_active=PIN_UNDEFINED, direction=PIN_UNDEFINED,
                on_delay_us=500_000, off_delay_ms=5000),
)


def _pico(name: str, title: str, f_cpu: int, pios: int, ram: int) -> Profile:
    return Profile(
        name=name,
        title=title,
        f_cpu=f_cpu,
        ticks_per_s=16_000_000,
        min_cmd_ticks=16_000_000 // 5000,
        min_dir_delay_us=(16_000_000 // 5000) // 16,
        max_dir_delay_us=65535 // 16,
        queue_len=32,
        max_steppers=4 * pios,  # four state machines per PIO
        step_pin_groups=(tuple(range(32)),),
        fixed_queue_mapping=False,
        max_speed_ticks_by_count=(80,),  # 200 000 steps/s
        fill_period_ticks=4 * 16000,
        delay_ms_base=4,
        has_stray_digital_read=False,
        irq_block_delays_steps=False,
        demo_steppers=_PICO_DEMO,
        debug_led_pin=25,  # LED_BUILTIN
        family="rp2040",
        task_rate_change=True,
        debug_led_half_period=50,
        demo_configs=(DemoConfig("Default", _PICO_DEMO),),
        console_usb=True,
        ram_bytes=ram,
        serial_reserved_bytes=16384,
        serial_rx_slots=16,
        serial_slot_payload=59,
        notes=f"{pios} PIO blocks with 4 state machines each; Serial is USB CDC",
        **_PICO_TIMING,
    )


RP2040 = _pico("rp2040", "Raspberry Pi RP2040 (Pico), PIO", 133_000_000, 2, 270336)
RP2350 = _pico("rp2350", "Raspberry Pi RP2350 (Pico 2), PIO", 150_000_000, 3, 532480)

# ---------------------------------------------------------------- upstream's PC tests
# The platform of FastAccelStepper's pc_based tests (pd_test): ESP32-like timing, a
# 16-entry queue, two queues.  Used by the ramp regression tests; not a chip, so it is
# not offered by --arch.
PC_TEST = replace(
    ESP32, name="pc_test", title="FastAccelStepper pc_based test platform (pd_test)",
    f_cpu=16_000_000, queue_len=16, max_steppers=2, delay_ms_base=1, family="test",
    drivers=(), driver_select=False, dynamic_allocation=False, idf_version=(0, 0),
    i2s_controllers=0, i2s_mux_slots=0, pulse_counter_units=0, task_rate_change=False,
    cpu_affinity=False, demo_configs=(), step_pin_groups=(tuple(range(256)),),
    notes="")

PROFILES: dict[str, Profile] = {p.name: p for p in (
    ATMEGA328P, ATMEGA2560, *ATMEGA2560_VARIANTS, ATMEGA32U4, *ESP32_PROFILES, SAM_DUE,
    RP2040, RP2350)}
TEST_PROFILES: dict[str, Profile] = {PC_TEST.name: PC_TEST}
DEFAULT_PROFILE = ATMEGA328P


def get_profile(name: str | Profile | None) -> Profile:
    if name is None:
        return DEFAULT_PROFILE
    if isinstance(name, Profile):
        return name
    key = name.lower()
    profile = PROFILES.get(key) or TEST_PROFILES.get(key)
    if profile is None:
        raise ValueError(
            f"unknown architecture {name!r} (choose from {', '.join(PROFILES)})")
    return profile
