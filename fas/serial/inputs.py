"""Inputs and limit switches on the device, as the host knows them (issue 13).

docs/serial-protocol.md, section 18.  The host remembers which pins it watches and
which limits it set (replayed in every new session of a device that has inputs,
Ident feature F_INPUTS), and the last value the device reported of each input.
"""

from __future__ import annotations

from .protocol import (
    L_CLEAR,
    L_UP,
    S_ANALOG,
    W_ANALOG,
    W_DIGITAL,
    W_PULLUP,
    Input,
    Limit,
    Message,
    SetInput,
    WatchInput,
)


class InputState:
    """Watched inputs, their values, and the limit switches (see module text)."""

    def __init__(self) -> None:
        self.watches: dict[int, WatchInput] = {}  # by pin (replayed)
        self.limits: dict[tuple[int, bool], Limit] = {}  # by (queue, up) (replayed)
        self.values: dict[int, int] = {}  # the last value reported of each input
        self.ticks: dict[int, int] = {}  # host tick at which the device read it

    def watch(self, pin: int, analog: bool = False, pullup: bool = True,
              period_ms: int = 0) -> WatchInput:
        mode = W_ANALOG if analog else (W_PULLUP if pullup else W_DIGITAL)
        watch = WatchInput(pin, mode, min(max(period_ms, 0), 255))
        self.watches[pin] = watch
        return watch

    def drive(self, pin: int, value: int) -> SetInput:
        """SetInput for a simulated device's world: a pot's value (0..1023) for a pin
        watched as analog, else a level - or, for a pin not watched, a pot if the
        value is above 1."""
        w = self.watches.get(pin)
        analog = w.mode == W_ANALOG if w is not None else value > 1
        value = min(max(int(value), 0), 1023) if analog else (1 if value else 0)
        return SetInput(pin, value, S_ANALOG if analog else 0)

    def limit(self, index: int, pin: int, level: int, up: bool,
              stop: tuple[int, ...] = ()) -> Limit:
        mask = 0
        for i in stop:
            mask |= 1 << i
        limit = Limit(index, pin, 1 if level else 0, L_UP if up else 0, mask)
        self.limits[(index, bool(up))] = limit
        return limit

    def clear_limit(self, index: int, up: bool) -> Limit | None:
        """The message that removes the limit (None: there is none)."""
        if self.limits.pop((index, bool(up)), None) is None:
            return None
        return Limit(index, 0, 0, (L_UP if up else 0) | L_CLEAR, 0)

    def reported(self, m: Input, tick: int) -> bool:
        """The device reported a watched input (read at host tick ``tick``); True if
        its value changed."""
        if m.pin not in self.watches:
            return False
        old = self.values.get(m.pin)
        self.values[m.pin] = m.value
        if old == m.value:
            return False
        self.ticks[m.pin] = tick
        return True

    def replay(self) -> list[Message]:
        """The messages a new session needs: the watches, then the limits."""
        return [*self.watches.values(), *self.limits.values()]
