"""The pot rule: an A/D value 0..1023 -> direction and step period.

Dead zone 462..562 is off.  Outside it the speed grows on a log scale from 10
steps/s at the dead-zone edge to 20 000 steps/s at the end of the pot (above the
dead zone forward, below it backward), and becomes a step period in 4 us counts,
rounded to the nearest count and clamped to 9..65535 - as the notes compute it
("we compute period in float").
"""

from __future__ import annotations

from dataclasses import dataclass

from . import figures as fig

_SPAN_UP = fig.POT_MAX - fig.DEAD_ZONE_HIGH  # 461 counts above the dead zone
_SPAN_DOWN = fig.DEAD_ZONE_LOW  # 462 counts below it
_RANGE = fig.POT_SPEED_MAX / fig.POT_SPEED_MIN


@dataclass(frozen=True)
class PotCommand:
    direction: int  # +1 forward, -1 backward, 0 off (dead zone)
    period_counts: int  # 0 when off
    speed: float  # the rule's steps/s before quantization (0 when off)

    @property
    def active(self) -> bool:
        return self.direction != 0

    @property
    def steps_per_s(self) -> float:
        """What the quantized period really gives."""
        return fig.COUNTS_PER_S / self.period_counts if self.period_counts else 0.0


def rule_speed(value: int) -> float:
    """Steps/s of the log rule for pot ``value`` (0 in the dead zone)."""
    if value > fig.DEAD_ZONE_HIGH:
        frac = (value - fig.DEAD_ZONE_HIGH) / _SPAN_UP
    elif value < fig.DEAD_ZONE_LOW:
        frac = (fig.DEAD_ZONE_LOW - value) / _SPAN_DOWN
    else:
        return 0.0
    return fig.POT_SPEED_MIN * _RANGE ** min(frac, 1.0)


def period_counts(speed: float) -> int:
    """A speed (steps/s) as a period in 4 us counts: nearest count, clamped."""
    counts = int(fig.COUNTS_PER_S / speed + 0.5)
    return min(max(counts, fig.PERIOD_MIN_COUNTS), fig.PERIOD_MAX_COUNTS)


def pot_command(value: int) -> PotCommand:
    speed = rule_speed(value)
    if speed == 0.0:
        return PotCommand(0, 0, 0.0)
    direction = 1 if value > fig.DEAD_ZONE_HIGH else -1
    return PotCommand(direction, period_counts(speed), speed)


def in_dead_zone(value: int) -> bool:
    return fig.DEAD_ZONE_LOW <= value <= fig.DEAD_ZONE_HIGH
