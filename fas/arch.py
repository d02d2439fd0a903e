"""Chip profiles: what each supported chip (and build variant) has, as the library sees it.

One :class:`Profile` per supported chip and build variant (the ATmega2560's timer
module, the ESP-IDF version of an ESP32).  The library (`fas`) reads its limits from
here: ticks, queue length, step pins, speed limits, the step generators of an ESP32,
which API calls the platform offers, the serial firmware's RAM budget.  Nothing else
in the code base carries a per-architecture number or an ``if arch == ...`` chain.

The other figures of a chip live beside the code that uses them, each in its own
table keyed by the profile's name (its room's lookup takes a :class:`Profile`):

* :mod:`fas.sim.timing` - the simulated machine's timing model (``sim_timing``);
* :mod:`fas.quickstep.figures` - QuickStep's timers and interrupt costs
  (``quickstep_figures``);
* :mod:`fas.output_figures` - the user outputs' pins and PWM timers (``output_figures``);
* :mod:`stepperdemo.demo.build` - StepperDemo's build for the chip: its wiring, pin
  configurations and the CPU cost of its own code (the console's, not the library's).

:func:`stepperdemo.chip_sheet.chip_sheet` gathers them all for one chip ("what does
this chip have"; ``python -m stepperdemo.chip_sheet NAME`` prints it).

Variants are made from a base with :func:`dataclasses.replace`: the ATmega2560 and
ATmega32U4 from the ATmega328P, the Mega's timer builds from the Mega, every ESP32
chip and ESP-IDF version from :data:`_ESP32_FAMILY`, the RP2350 from the RP2040.

A new chip: its :class:`Profile` here (a variant: ``replace`` of its base) and an
entry in :data:`PROFILES`; its simulated timing in :mod:`fas.sim.timing` (nothing to
add where its family's fits); its StepperDemo build in :mod:`stepperdemo.demo.build`
(required: the console wires its steppers from it); QuickStep's and the outputs'
tables only if it has them (without an entry it has neither).

Figures come from FastAccelStepper 1.2.7 (its ``pd_*/pd_config*.h`` and the platform
drivers).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from . import log2
from .codes import FasDriver

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


@dataclass(frozen=True)
class Profile:
    """The library's figures of one chip (see the module text for the other rooms')."""

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
    # interrupts blocked by the application delay the step interrupts (AVR: a missed
    # compare waits for the timer to wrap); the ESP32's step peripherals are immune
    irq_block_delays_steps: bool
    # the platform driver's startQueue(): the first compare comes this far after the
    # call (the simulated channel and the serial host's planning of a device queue)
    queue_start_ticks: int
    # --- serial firmware (docs/serial-protocol.md): RAM budget of the device ---
    ram_bytes: int = 0  # the chip's data RAM
    serial_reserved_bytes: int = 0  # firmware RAM besides queue rings and frame slots
    serial_rx_slots: int = 0  # out-of-order frames the device holds (selective repeat)
    serial_slot_payload: int = 0  # payload bytes of one such slot = largest host frame
    # the library's own queue length where it differs from queue_len (a serial device's
    # deeper ring): the API's limits (the enable delay) stay those of the chip
    api_queue_len: int = 0
    # Arduino pin -> I/O port register (AVR); pins of one port are written together
    pin_ports: dict[int, str] = field(default_factory=dict, compare=False)
    # Arduino A0, A1, ... as pin numbers (analog inputs; the helix winder, issue 13)
    analog_pins: tuple[int, ...] = ()
    notes: str = field(default="", compare=False)
    # --- platform features (issue 17: parity with FastAccelStepper 1.2.7) ---
    family: str = "avr"  # avr, esp32, sam, rp2040, test
    timer_module: int = 0  # AVR: the 16-bit timer of the step channels (FAS_TIMER_MODULE)
    # AVR: the step timer's compare vectors come after timer 0's overflow and the
    # console UART's in the vector table (the Mega's timers 3, 4, 5: vectors 33-50,
    # timer 0's overflow 24, USART0's 26-28), so when they are pending together
    # millis() and the UART run first; timer 1's (the 328P, the 32U4, the Mega's
    # timer 1) come before them
    step_vectors_after_timer0: bool = False
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

    def max_speed_ticks(self, stepper_count: int) -> int:
        table = self.max_speed_ticks_by_count
        return table[min(max(stepper_count, 1), len(table)) - 1]

    # ---- the serial firmware's RAM budget ----------------------------------
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



# ------------------------------------------------------------------------------- AVR
def _ports(spec: str) -> dict[int, str]:
    """``"PE0 PE1 PE4 ..."`` in Arduino pin order -> {pin: port letter}."""
    return {pin: name[1] for pin, name in enumerate(spec.split())}


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
    irq_block_delays_steps=True,
    queue_start_ticks=10,
    pin_ports={**{p: "D" for p in range(0, 8)}, **{p: "B" for p in range(8, 14)},
               **{p: "C" for p in range(14, 20)}},
    analog_pins=tuple(range(14, 22)),  # A0..A7 (A6, A7: analog only)
    ram_bytes=2048,
    serial_reserved_bytes=1024,
    serial_rx_slots=8,
    serial_slot_payload=32,
)

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

# the Mega's default build steps on timer 4 (FAS_TIMER_MODULE=4)
ATMEGA2560 = replace(
    ATMEGA328P,
    name="atmega2560",
    title="ATmega2560 (Arduino Mega), timer 4",
    max_steppers=3,
    step_pin_groups=tuple((pin,) for pin in _MEGA_TIMER_PINS[4]),
    analog_pins=tuple(range(54, 70)),  # A0..A15
    ram_bytes=8192,
    serial_rx_slots=16,
    serial_slot_payload=59,
    pin_ports=_MEGA_PORTS,
    timer_module=4,
    step_vectors_after_timer0=True,
    notes="FAS_TIMER_MODULE=4",
)


def _mega_timer(timer: int) -> Profile:
    """The Mega built with another step timer (a platformio build flag)."""
    return replace(ATMEGA2560, name=f"atmega2560_timer{timer}",
                   title=f"ATmega2560 (Arduino Mega), timer {timer}",
                   step_pin_groups=tuple((pin,) for pin in _MEGA_TIMER_PINS[timer]),
                   timer_module=timer,
                   step_vectors_after_timer0=timer != 1,
                   notes=f"FAS_TIMER_MODULE={timer} (platformio build flag)")


ATMEGA2560_VARIANTS = tuple(_mega_timer(t) for t in (1, 3, 5))

ATMEGA32U4 = replace(
    ATMEGA328P,
    name="atmega32u4",
    title="ATmega32U4 (Arduino Leonardo), timer 1",
    max_steppers=3,
    step_pin_groups=((9,), (10,), (11,)),
    analog_pins=tuple(range(18, 24)),  # A0..A5 of the Leonardo
    ram_bytes=2560,  # 2.5 KB: the Uno's serial-firmware budget plus 512 bytes
    pin_ports=_LEONARDO_PORTS,
    timer_module=1,
    external_dir_pin=False,
    console_usb=True,
    notes="Serial is the USB CDC port: output costs no UART time (the AVR simulator has "
          "no USB host, so the firmware's prints return at once)",
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



# The figures every ESP32 chip and ESP-IDF version shares; not a chip (not in PROFILES):
# each ESP32 profile is this with its chip's peripherals (:func:`_esp32`)
_ESP32_FAMILY = Profile(
    name="esp32_family",
    title="ESP32 family: the figures every ESP32 profile shares",
    f_cpu=0,
    ticks_per_s=16_000_000,
    min_cmd_ticks=ESP32_MIN_CMD_TICKS,
    min_dir_delay_us=ESP32_MIN_CMD_TICKS // 16,
    max_dir_delay_us=65535 // 16,
    queue_len=32,
    max_steppers=0,
    step_pin_groups=(),
    fixed_queue_mapping=False,
    max_speed_ticks_by_count=(ESP32_MAX_SPEED_TICKS,),
    fill_period_ticks=4 * 16000,
    delay_ms_base=4,
    irq_block_delays_steps=False,
    queue_start_ticks=16,
    family="esp32",
    task_rate_change=True,
    cpu_affinity=True,
    debug_led_half_period=50,
    serial_reserved_bytes=131072,
    serial_rx_slots=16,
    serial_slot_payload=59,
    notes="pulses come from the MCPWM/RMT/I2S peripherals; `e` does not delay them",
)


def _esp32(chip: str, idf: int, name: str) -> Profile:
    """The ESP32 family's figures with ``chip``'s peripherals under ESP-IDF ``idf``."""
    mcpwm, rmt, pcnt, i2s = _ESP32_IDF[chip][idf]
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
    drivers = "+".join(f"{n} {d}" for n, d in ((mcpwm, "MCPWM/PCNT"), (rmt, "RMT")) if n)
    if i2s:
        drivers += f" + I2S ({i2s} controller{'s' if i2s > 1 else ''}, 32-slot mux)"
    return replace(
        _ESP32_FAMILY,
        name=name,
        title=f"{_ESP32_TITLE[chip]}, ESP-IDF {idf}.{_IDF_MINOR[idf]}: {drivers}",
        f_cpu=_ESP32_F_CPU[chip],
        max_steppers=max_steppers,
        step_pin_groups=(_ESP32_GPIO[chip],),
        drivers=tuple(pools),
        driver_select=kinds >= 2,
        dynamic_allocation=dynamic,
        idf_version=(idf, _IDF_MINOR[idf]),
        i2s_controllers=i2s,
        i2s_mux_slots=ESP32_I2S_MUX_SLOTS if i2s else 0,
        pulse_counter_units=pcnt,
        ram_bytes=_ESP32_RAM[chip],
        # the ADC1 channels 0, 3, 6, 7, 4, 5 as A0..A5 (the ESP32 core's A-names)
        analog_pins=(36, 39, 34, 35, 32, 33) if chip == "esp32" else (),
    )


# named <chip> for the chip's oldest ESP-IDF, <chip>_idf<N> for the others
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
    irq_block_delays_steps=False,
    queue_start_ticks=21,
    analog_pins=tuple(range(54, 66)),  # A0..A11
    family="sam",
    step_pin_channel_groups=True,
    abs_speed_limit=False,
    debug_led_half_period=50,
    notes="step pins: one pin of each PWM channel group; six queues for eight channels",
    ram_bytes=98304,
    serial_reserved_bytes=16384,
    serial_rx_slots=16,
    serial_slot_payload=59,
)

# ------------------------------------------------------------------ Raspberry Pi Pico
RP2040 = Profile(
    name="rp2040",
    title="Raspberry Pi RP2040 (Pico), PIO",
    f_cpu=133_000_000,
    ticks_per_s=16_000_000,
    min_cmd_ticks=16_000_000 // 5000,
    min_dir_delay_us=(16_000_000 // 5000) // 16,
    max_dir_delay_us=65535 // 16,
    queue_len=32,
    max_steppers=4 * 2,  # four state machines per PIO, two PIO blocks
    step_pin_groups=(tuple(range(32)),),
    fixed_queue_mapping=False,
    max_speed_ticks_by_count=(80,),  # 200 000 steps/s
    fill_period_ticks=4 * 16000,
    delay_ms_base=4,
    irq_block_delays_steps=False,
    queue_start_ticks=16,
    family="rp2040",
    task_rate_change=True,
    debug_led_half_period=50,
    console_usb=True,
    ram_bytes=270336,
    serial_reserved_bytes=16384,
    serial_rx_slots=16,
    serial_slot_payload=59,
    notes="2 PIO blocks with 4 state machines each; Serial is USB CDC",
)
RP2350 = replace(RP2040, name="rp2350", title="Raspberry Pi RP2350 (Pico 2), PIO",
                 f_cpu=150_000_000, max_steppers=4 * 3, ram_bytes=532480,
                 notes="3 PIO blocks with 4 state machines each; Serial is USB CDC")

# ---------------------------------------------------------------- upstream's PC tests
# The platform of FastAccelStepper's pc_based tests (pd_test): ESP32-like timing, a
# 16-entry queue, two queues.  Used by the ramp regression tests; not a chip, so it is
# not offered by --arch.
PC_TEST = replace(
    ESP32, name="pc_test", title="FastAccelStepper pc_based test platform (pd_test)",
    f_cpu=16_000_000, queue_len=16, max_steppers=2, delay_ms_base=1, family="test",
    drivers=(), driver_select=False, dynamic_allocation=False, idf_version=(0, 0),
    i2s_controllers=0, i2s_mux_slots=0, pulse_counter_units=0, task_rate_change=False,
    cpu_affinity=False, step_pin_groups=(tuple(range(256)),), notes="")

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
