"""The helix winder's figures: the numbers of its design notes (seed 002), named.

Where the notes give a number it is quoted; where they are silent the choice is ours
and says why.  Pin and timing figures of the chips stay in :mod:`fas.arch`.
"""

from __future__ import annotations

# --- time base ------------------------------------------------------------------
# "The timer0 prescaler gives us 4USec per pulse": periods are counted in 4 us counts
COUNT_US = 4
# "So we limit our period to 9 counts. Period range is thus 9 - 65535."
PERIOD_MIN_COUNTS = 9
PERIOD_MAX_COUNTS = 65535
COUNTS_PER_S = 1_000_000 // COUNT_US  # 250 000: steps/s = COUNTS_PER_S / period

# --- potentiometers -------------------------------------------------------------
POT_MAX = 1023  # a 10-bit A/D converter
POT_CENTRE = 512  # the simulated pots start centred
# "for A/D in range 462 - 562 we are off.  Less than 462 is false direction, >562 is
# true direction"
DEAD_ZONE_LOW = 462
DEAD_ZONE_HIGH = 562
# "Not interest in speeds below about ten Hz" ... "speeds up to 20K steps/sec", on a
# log scale ("1-10, 10-100, 100-1000, 1000-10000") from the dead-zone edge to the end
POT_SPEED_MIN = 10
POT_SPEED_MAX = 20_000
POT_SAMPLE_MS = 50  # the pots are read every 50 ms (SPEC 7.2)

# --- link commands --------------------------------------------------------------
# "StepperMove() command with a step count up to 65535.  65535 will be infinite move."
MOVE_MAX = 65535
MOVE_FOREVER = 65535
RATIO_MAX = 65535  # ratio n:m, 1 <= n <= m <= RATIO_MAX
# Our choices where the notes are silent:
# link speed until a `period` command: 250 counts = 1 ms = 1000 steps/s
DEFAULT_PERIOD_COUNTS = 250
# speed changes ramp with this acceleration (steps/s^2): 0 -> 20 000 steps/s in 0.4 s
# (the issue asks for "within 0.5 s")
DEFAULT_ACCEL = 50_000
ACCEL_MAX = 10_000_000
DEFAULT_RATIO = (1, 1)

# --- traverse (the notes' "continuous movement cycle on S2") --------------------------
# "Thinking of updating at maybe every 50 msec (20 Hz)"
TRAVERSE_INTERVAL_MS = 50
# the pull-in period of the notes' example table: 2000 counts = 8 ms = 125 steps/s
TRAVERSE_START_COUNTS = 2000
# commands queued ahead of the traverse stepper: the ramp's forward-planning time
# (20 ms) plus two ramp tasks of slack
TRAVERSE_AHEAD_MS = 28

# --- inputs ---------------------------------------------------------------------
# "Using A0, A1, A6, A7 as analog inputs ... A2, A3, A4, A5 as digital inputs for
# limit detectors"; SPEC 7.2: A0 -> S1, A1 -> S2, A2 lower and A3 upper limit of S2,
# A4 closed at power-up = fixture mode.  Index = Arduino A-number.
POT_INPUTS = (0, 1)  # S1, S2
LIMIT_LOW = 2
LIMIT_HIGH = 3
FIXTURE = 4
SPARE = 5
SWITCHES = (LIMIT_LOW, LIMIT_HIGH, FIXTURE, SPARE)
# a switch closes to ground against the pin's pull-up: closed reads LOW
SWITCH_CLOSED_LEVEL = 0
LIMIT_STOP_MS = 5  # a limit stops S2 within this (SPEC 7.2); measured in the tests
