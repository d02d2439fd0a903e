"""Rigs: the set-ups that the tests (``tests/``) and the measurements (``bench/``) share.

A rig puts the library or a program into a known situation and hands back what it did:
a line of StepperDemo on the simulated chip, the same line through the serial backend
to a simulated device or to the firmware in simavr, a stepper on a recording
simulator, positions counted from recorded pins, the console on a virtual wall clock.
Each lives here once; a test and a bench script that need it import it from here.

``rigs`` sits at the top of the checkout beside ``fas`` and ``stepperdemo`` and is not
installed (``setup.py`` packages only those two): the rigs drive StepperDemo,
so they cannot live in ``fas`` (which never imports ``stepperdemo``), and they are
measuring set-ups (the issues' acceptance lines, a pytest skip) rather than part of a
program a user runs.  What a user needs to test their own motion is already in the
packages: ``SimBackend(record=True).recorder``, ``StepperDemo.run_script``,
``fas.device.loopback.Loopback``.  ``tests/conftest.py`` and every bench script put
the checkout's root first on ``sys.path``, so ``import rigs`` finds this folder.

Modules, one job each:

* :mod:`rigs.pins` - steps, positions and follower errors counted from pin edges;
* :mod:`rigs.sim` - one stepper on a recording simulated chip;
* :mod:`rigs.demo` - StepperDemo lines on the simulated chip, a cruising stepper;
* :mod:`rigs.serial` - lines through the serial backend to a simulated device;
* :mod:`rigs.firmware` - the same to the firmware in simavr, or frame by frame;
* :mod:`rigs.stepgen` - the firmware's step generator alone beside the Python one;
* :mod:`rigs.pc_based` - FastAccelStepper's pc_based test platform (a manual backend);
* :mod:`rigs.console` - the interactive console on a fake wall clock;
* :mod:`rigs.processes` - ``python -m stepperdemo`` as a real process, read line by line;
* :mod:`rigs.vcd` - a VCD reader of our own, to check the traces we write.
"""

from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
"""The checkout's root: where ``python -m stepperdemo`` runs in a subprocess test."""
