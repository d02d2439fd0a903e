"""The interrupts-off sections of upstream's example sketches' own waiting loops.

Upstream's simulator-tested sketches (``examples/Issue208``, ``Issue280``, ...; build
``upstream_time_measurement``) wait in two kinds of loop: Arduino's ``delay()``, which
reads ``micros()`` over and over (timer 0's overflow count read with interrupts off), and
busy loops that poll the stepper, some of them through a call that reads the queue with
interrupts off (``getCurrentSpeedInMilliHz()``).  A step interrupt requested inside such
a section enters after it and the instruction after it: its pulse is that much longer
(docs/timing-model.md, "The upstream sketches' loop sections").

The figures are read from the sketches rebuilt and run cycle by cycle
(``bench/replica/sketch_replica.py``, FastAccelStepper 1.2.7 with the Arduino core's
``micros()``, ATmega328P): a poll as (pass length in the loop's own CPU ticks,
((offset in the pass, ticks a request there can wait at most), ...)) - the
:meth:`fas.sim.machine.Machine.poll_begin` form.

* ``delay``: ``micros()`` keeps interrupts off for 13 ticks from its ``cli`` to its SREG
  restore, one instruction (1 tick) follows; a pass every 64 ticks (mean 64.07 over the
  136 911 passes of Issue208 with no interrupt inside: 64, 75 where a millisecond is
  counted); the first ``cli`` ends 24 ticks after ``delay()``'s entry (both of
  Issue208's delays).
* ``speed_read``: Issue208's busy loop, ``rampState()`` then
  ``getCurrentSpeedInMilliHz(false)``: the queue's speed read 14 ticks from ``cli`` to the
  SREG restore, 1 tick after; a pass every 688 ticks (mean of the 57 649 passes with no
  interrupt inside, 662-720: the division's length varies with the speed); where the
  first pass's section falls is not read (offset 0).

(Passes timed as wall time less the interrupts' entry-to-``reti`` spans come out 1-2 %
longer - 64.8 and 691.5 / 695.4 - since each interrupt's entry and the instruction after
its ``reti`` count as the loop's there; the model's interrupt costs hold them.)

Issue280's busy loop (``rampState()``) and its ``isRunning()`` reads have no such
section.  Followed only where a caller asks (off by default: not landed).  With them Issue208's
Total High comes to 922 046 us against upstream's 923 729 +- 700. With the ramp task's
per-command sections as well (``SimTiming.fill_cmd_mask_sections``), it comes to 923 263;
the rebuilt sketch itself makes 922 944.
"""

from __future__ import annotations

Poll = tuple[int, tuple[tuple[int, int], ...]]

SKETCH_LOOP_POLLS: dict[str, dict[str, dict[str, Poll]]] = {
    "upstream_time_measurement": {
        "atmega328p": {
            "delay": (64, ((24, 13 + 1),)),
            "speed_read": (688, ((0, 14 + 1),)),
        },
    },
}


def sketch_loop_poll(build: str, profile: str, loop: str) -> Poll | None:
    """The poll of a sketch's ``loop`` ("delay", "speed_read") in ``build`` on the chip
    ``profile``; None where it is not measured."""
    return SKETCH_LOOP_POLLS.get(build, {}).get(profile, {}).get(loop)
