"""Fuzzing every console program on every profile: random input, invariants after
every run, nothing may raise.

* :mod:`.demo` - StepperDemo: its normal, test and config modes, the ``g`` mode, noise;
* :mod:`.gcode` - the G-code program: lines and bytes (real-time, >= 0x80, control),
  driven through the program interface only;
* :mod:`.winder` - the helix winder, on the profiles that host it (the others must
  refuse it with one line);
* :mod:`.common` - results, exceptions as findings, positions counted from the pins,
  driving a program on virtual time;
* :mod:`.targets` - the targets by program name, seeded runs, replay.

``python bench/fuzz.py --program all --lines N`` runs them on all cores; the suite
runs a small seeded amount (``tests/stepperdemo/test_fuzz.py``).
"""

from .common import Case, FuzzResult
from .demo import check_line, fuzz, gmode_line, grammar_line, raw_line
from .targets import TARGETS, fuzz_program, replay

__all__ = ["TARGETS", "Case", "FuzzResult", "check_line", "fuzz", "fuzz_program",
           "gmode_line", "grammar_line", "raw_line", "replay"]
