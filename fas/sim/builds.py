"""Firmware builds: the same firmware compiled another way runs with other CPU costs.

The conformance data comes from runs of the stock StepperDemo firmware built twice
(``docs/timing-model.md``, "Builds"): the runs ``d*``/``test_sd_*`` from one build,
the runs ``e01``-``e18`` from another, whose library and console code take fewer cycles
(its moves start ~0.3 ms sooner after the ramp task begins, its loop passes are ~20 %
shorter).  Upstream's timing tests build the library with ``SIMAVR_TIME_MEASUREMENT``
(port writes at the step interrupt's entry and exit).  A build is named here; the
rooms that hold CPU figures keep a table per build (:mod:`fas.sim.timing` for the
chip, its core and the library; ``stepperdemo.demo.build`` for StepperDemo's own code),
falling back to the default build's figures.
"""

from __future__ import annotations

DEFAULT_BUILD = "d"

BUILDS: dict[str, str] = {
    "d": "the build of the conformance runs d*, test_sd_*, dm* (default)",
    "d_time_measurement": "the default build with the library's SIMAVR_TIME_MEASUREMENT "
                          "(upstream's timing tests test_sd_04_timing_*)",
    "e": "the build of the conformance runs e01-e18 (the `e` injection during fast motion)",
    "upstream_time_measurement": "FastAccelStepper 1.2.7's own simulator-tested sketches "
                                 "(examples/Issue*, ExternalCall) as upstream builds them, "
                                 "with SIMAVR_TIME_MEASUREMENT",
}


def check_build(build: str | None) -> str:
    """The build's name (None: the default); a clear error for an unknown one."""
    if build is None:
        return DEFAULT_BUILD
    if build not in BUILDS:
        raise ValueError(f"unknown firmware build {build!r} (known: {', '.join(BUILDS)})")
    return build
