"""The engine's allocator: step queues, multiplexer slots, pulse counters and timers.

One :class:`Allocator` per engine hands out every resource of the chip that two users
could want: the step generators (queues), slots of the I2S multiplexer, pulse counter
units, and timers (a user PWM output, QuickStep).  Its book is the one place that
says who has what.

Which queue (step channel) a new stepper gets follows the platforms'
``tryAllocateQueue``.

Each platform hands out its step generators differently, and users see the
difference (which pins work, how many steppers fit, which number a stepper gets):

* AVR: the pin decides the timer channel and so the queue (fixed mapping);
* SAM Due: each pin belongs to one of eight PWM channels, usable once; the six queues
  are given out in order;
* Raspberry Pi Pico: any GPIO below 32, one PIO state machine each;
* ESP32: any output GPIO, served by a pool of one driver type (MCPWM/PCNT, RMT, I2S).
  ESP-IDF 4 keeps the queues in a static table (MCPWM/PCNT first, then RMT) and the
  stepper's number is its queue; ESP-IDF 5 allocates dynamically - RMT first, then an
  I2S controller, then MCPWM/PCNT - and numbers steppers in connect order.  Pins
  or'ed with ``PIN_I2S_FLAG`` are slots of the I2S multiplexer (after
  ``init_i2s_mux``).

Timers are booked by name (AVR: "timer 2") for a user ("pwm", "quickstep") and a key
(the output, the QuickStep clock); one user may book a timer several times (two PWM
outputs on one timer), and a user asks :meth:`Allocator.timer_used_by_other` before
it takes a timer.
"""

from __future__ import annotations

from dataclasses import dataclass

from .arch import DriverPool, Profile
from .codes import PIN_EXTERNAL_FLAG, PIN_I2S_FLAG, FasDriver


@dataclass(frozen=True)
class Allocation:
    index: int  # the engine's stepper number (queue number)
    pool: DriverPool | None  # ESP32: the driver; None elsewhere


class Allocator:
    def __init__(self, profile: Profile) -> None:
        self.profile = profile
        self.used_groups: set[int] = set()
        self.used_indices: set[int] = set()
        self.step_pins: list[int] = []
        self.per_driver: dict[int, int] = {}
        self.i2s_in_use = 0  # I2S controllers taken (I2S_DIRECT steppers, the multiplexer)
        self.i2s_mux_ready = False
        self.i2s_mux_slots: set[int] = set()
        self.count = 0
        self.pcnt_units: dict[int, object] = {}  # unit -> who counts on it
        self.timers: dict[str, set[tuple[str, object]]] = {}  # name -> {(user, key)}

    # ---------------------------------------------------------------- helpers
    def _valid_gpio(self, pin: int) -> bool:
        return any(pin in group for group in self.profile.step_pin_groups)

    def _first_free(self) -> int | None:
        for i in range(self.profile.max_steppers):
            if i not in self.used_indices:
                return i
        return None

    def _take(self, index: int, pin: int, pool: DriverPool | None) -> Allocation:
        self.used_indices.add(index)
        self.step_pins.append(pin)
        self.count += 1
        if pool is not None:
            self.per_driver[pool.driver] = self.per_driver.get(pool.driver, 0) + 1
        return Allocation(index, pool)

    # ------------------------------------------------------------- allocate
    def allocate(self, pin: int, driver: int = FasDriver.DONT_CARE) -> Allocation | None:
        p = self.profile
        if p.family == "esp32":
            return self._esp32(pin, int(driver))
        if driver != FasDriver.DONT_CARE:
            return None  # only ESP32 builds know driver types
        if p.fixed_queue_mapping:  # AVR
            group = p.queue_for_step_pin(pin)
            if group is None or group in self.used_indices:
                return None
            return self._take(group, pin, None)
        if p.step_pin_channel_groups:  # SAM
            group = p.queue_for_step_pin(pin)
            if group is None or group in self.used_groups or self.count >= p.max_steppers:
                return None
            index = self._first_free()
            if index is None:
                return None
            self.used_groups.add(group)
            return self._take(index, pin, None)
        # Pico, pc_test: any valid pin, the next free state machine
        if not self._valid_gpio(pin) or self.count >= p.max_steppers:
            return None
        index = self._first_free()
        return None if index is None else self._take(index, pin, None)

    def _esp32(self, pin: int, driver: int) -> Allocation | None:
        p = self.profile
        if pin & PIN_EXTERNAL_FLAG:
            return None
        if p.has_i2s and pin & PIN_I2S_FLAG:
            return self._i2s_mux(pin)
        if not self._valid_gpio(pin):
            return None
        if not p.dynamic_allocation and pin in self.step_pins:
            return None  # the static table refuses a pin twice
        if driver == FasDriver.DONT_CARE:
            for pool in p.drivers:
                if pool.driver == FasDriver.I2S_MUX:
                    continue
                got = self._from_pool(pool, pin)
                if got is not None:
                    return got
            return None
        if driver == FasDriver.I2S_MUX:
            return None  # mux steppers are chosen by an I2S-flagged pin
        chosen = p.driver_pool(driver)
        return None if chosen is None else self._from_pool(chosen, pin)

    def _from_pool(self, pool: DriverPool, pin: int) -> Allocation | None:
        p = self.profile
        used = self.per_driver.get(pool.driver, 0)
        if used >= pool.queues:
            return None
        if pool.driver == FasDriver.I2S_DIRECT and self.i2s_in_use >= p.i2s_controllers:
            return None
        if p.dynamic_allocation:
            index = self.count
        else:  # static table (ESP-IDF 4, 6): the pools' queues one after the other
            offset = 0
            for other in p.drivers:
                if other.driver == pool.driver:
                    break
                offset += other.queues
            index = offset + used
        if index >= p.max_steppers:
            return None
        if pool.driver == FasDriver.I2S_DIRECT:
            self.i2s_in_use += 1
        return self._take(index, pin, pool)

    def _i2s_mux(self, pin: int) -> Allocation | None:
        slot = pin & 0x1F
        if not self.i2s_mux_ready or slot in self.i2s_mux_slots:
            return None
        pool = self.profile.driver_pool(FasDriver.I2S_MUX)
        if pool is None or self.count >= self.profile.max_steppers:
            return None
        self.i2s_mux_slots.add(slot)
        return self._take(self.count, pin, pool)

    # ------------------------------------------------------------ I2S mux
    def claim_i2s_mux(self) -> bool:
        """``init_i2s_mux``: one I2S controller becomes the 32-slot multiplexer."""
        if not self.profile.has_i2s or self.i2s_mux_ready:
            return False
        if self.i2s_in_use >= self.profile.i2s_controllers:
            return False
        self.i2s_in_use += 1
        self.i2s_mux_ready = True
        return True

    def claim_mux_slot(self, slot: int) -> bool:
        """A direction pin on a mux slot: upstream marks the slot as taken (once)."""
        if slot >= 32 or slot in self.i2s_mux_slots:
            return False
        self.i2s_mux_slots.add(slot)
        return True

    # -------------------------------------------------------- pulse counters
    def claim_pulse_counter(self, unit: int, owner: object) -> bool:
        """A pcnt unit for ``owner`` (a stepper's ``attach_to_pulse_counter``).
        MCPWM/PCNT steppers use one each (ESP-IDF 4: unit n for the n-th of them);
        ESP-IDF 5 picks a free one itself (an owner attached again keeps its unit)."""
        p = self.profile
        units = self.pcnt_units
        mcpwm = self.per_driver.get(FasDriver.MCPWM_PCNT, 0)
        taken = {u for u, o in units.items() if o is not owner}
        if p.dynamic_allocation:
            if any(o is owner for o in units.values()):
                return True
            if mcpwm + len(taken) >= p.pulse_counter_units:
                return False
            unit = max(units, default=mcpwm - 1) + 1
        elif not 0 <= unit < p.pulse_counter_units or unit < mcpwm or unit in taken:
            return False
        for u in [u for u, o in units.items() if o is owner]:
            del units[u]
        units[unit] = owner
        return True

    # ---------------------------------------------------------------- timers
    def hold_timer(self, timer: str, user: str, key: object) -> None:
        """Book ``timer`` for ``user`` (ask :meth:`timer_used_by_other` first)."""
        self.timers.setdefault(timer, set()).add((user, key))

    def release_timer(self, timer: str, user: str, key: object) -> None:
        held = self.timers.get(timer)
        if held is not None:
            held.discard((user, key))
            if not held:
                del self.timers[timer]

    def timer_users(self, timer: str) -> set[str]:
        return {user for user, _ in self.timers.get(timer, ())}

    def timer_used_by_other(self, timer: str, user: str) -> bool:
        """Is ``timer`` booked by a user other than ``user``?"""
        return any(u != user for u, _ in self.timers.get(timer, ()))


QueueAllocator = Allocator  # (its name before it handed out more than queues)
