"""docs/api-coverage.md stays true: every upstream name is listed, every Python name it
gives exists, at the file and line the table says."""

from __future__ import annotations

import importlib.util
import re

import fas.arch
import fas.codes
import fas.drive
import fas.queue
import fas.stepper
import fas.timed
from fas import Engine, Stepper
from rigs import ROOT

SPEC = importlib.util.spec_from_file_location("api_coverage", ROOT / "tools" / "api_coverage.py")
api_coverage = importlib.util.module_from_spec(SPEC)
SPEC.loader.exec_module(api_coverage)

# the public names of FastAccelStepper 1.2.7's FastAccelStepper.h,
# FastAccelStepperEngine.h and result_codes.h
UPSTREAM = [
    "init", "stepperConnectToPin", "initI2sMux", "i2sMuxSetBit", "i2sMuxGetBit", "task_rate",
    "_task_rate", "setExternalCallForPin", "setDebugLed", "manageSteppers", "getStepPin",
    "setDirectionPin", "getDirectionPin", "directionPinHighCountsUp", "setEnablePin",
    "getEnablePinHighActive", "getEnablePinLowActive", "enableOutputs", "disableOutputs",
    "setAutoEnable", "setDelayToEnable", "setDelayToDisable", "getCurrentPosition",
    "setCurrentPosition", "isRunning", "getMaxSpeedInUs", "getMaxSpeedInTicks", "getMaxSpeedInHz",
    "getMaxSpeedInMilliHz", "setAbsoluteSpeedLimit", "setSpeedInUs", "setSpeedInTicks",
    "setSpeedInHz", "setSpeedInMilliHz", "getSpeedInUs", "getSpeedInTicks", "getSpeedInMilliHz",
    "getCurrentSpeedInUs", "getCurrentSpeedInMilliHz", "setAcceleration", "getAcceleration",
    "getCurrentAcceleration", "setLinearAcceleration", "setJumpStart", "applySpeedAcceleration",
    "move", "moveTo", "keepRunning", "isRunningContinuously", "runForward", "runBackward",
    "forwardStep", "backwardStep", "moveByAcceleration", "stopMove", "isStopping", "stepsToStop",
    "forceStop", "forceStopAndNewPosition", "targetPos", "setForwardPlanningTimeInMs", "moveTimed",
    "addQueueEntry", "isQueueEmpty", "isQueueFull", "isQueueRunning", "ticksInQueue",
    "hasTicksInQueue", "queueEntries", "getPositionAfterCommandsCompleted",
    "getPeriodInUsAfterCommandsCompleted", "getPeriodInTicksAfterCommandsCompleted",
    "setPositionAfterCommandsCompleted", "rampState", "isRampGeneratorActive", "detachFromPin",
    "reAttachToPin", "attachToPulseCounter", "readPulseCounter", "clearPulseCounter",
    "pulseCounterAttached", "driverType", "driverTypeString", "ExtDirPendingState",
    "AqeResultCode", "aqeRetry", "aqeIsOk", "toString", "MoveResultCode", "moveIsOk",
    "MoveTimedResultCode", "moveTimedIsOk", "tmrFrom", "DelayResultCode", "delayIsValid",
    "FasDriver", "RAMP_STATE_MASK", "RAMP_DIRECTION_MASK", "RAMP_STATE_IDLE",
    "RAMP_STATE_ACCELERATING_FLAG", "RAMP_DIRECTION_COUNT_UP", "PIN_UNDEFINED",
    "PIN_EXTERNAL_FLAG", "PIN_I2S_FLAG", "MAX_ON_DELAY_TICKS", "TICKS_FOR_STOPPED_MOTOR",
    "stepper_command_s", "actual_ticks_s", "queue_end_s", "AQE_OK", "MOVE_OK", "MOVE_TIMED_OK",
    "MOVE_TIMED_BUSY", "MOVE_TIMED_EMPTY", "DELAY_OK", "DRIVER_MCPWM_PCNT", "DRIVER_DONT_CARE",
]

OBJECTS = {"Stepper": Stepper, "Drive": fas.drive.Drive, "Engine": Engine,
           "Profile": fas.arch.Profile, "DriverPool": fas.arch.DriverPool,
           "StepperQueue": fas.queue.StepperQueue, "codes": fas.codes, "timed": fas.timed}


def test_every_upstream_name_is_in_the_table():
    doc = api_coverage.DOC.read_text()
    upstream_column = " ".join(m.group("up") for line in doc.splitlines()
                               if (m := api_coverage.ROW.match(line)))
    missing = [n for n in UPSTREAM if not re.search(rf"\b{re.escape(n)}\b", upstream_column)]
    assert not missing, missing


def test_every_python_name_exists_where_the_table_says():
    assert api_coverage.check() == []


def test_every_python_name_is_a_real_attribute():
    doc = api_coverage.DOC.read_text()
    refs = [r.strip().strip("`") for _, _, rs in api_coverage.rows(doc) for r in rs]
    assert len(refs) > 100
    for ref in refs:
        owner, *path = ref.split(".")
        obj = OBJECTS[owner]
        for part in path:
            fields = getattr(obj, "__dataclass_fields__", {})
            obj = fields[part] if part in fields else getattr(obj, part)
        assert obj is not None, ref


# AVRStepperPins.h (1.2.7): the compare-output pins of each 16-bit timer
AVR_STEP_PINS = {
    "stepPinStepper1A": 9, "stepPinStepper1B": 10,  # ATmega168/328, ATmega32U4
    "stepPinStepper3A": 5, "stepPinStepper3B": 2, "stepPinStepper3C": 3,  # ATmega2560
    "stepPinStepper4A": 6, "stepPinStepper4B": 7, "stepPinStepper4C": 8,
    "stepPinStepper5A": 46, "stepPinStepper5B": 45, "stepPinStepper5C": 44,
}
# enum class members as result_codes.h numbers them: (upstream member, value)
UPSTREAM_MEMBERS = {
    "AqeResultCode": [("OK", 0), ("QueueFull", 1), ("DirPinIsBusy", 2),
                      ("WaitForEnablePinActive", 3), ("DeviceNotReady", 4),
                      ("DirPin2msPauseAdded", 5), ("ErrorTicksTooLow", -1),
                      ("ErrorEmptyQueueToStart", -2), ("ErrorNoDirPinToToggle", -3)],
    "MoveResultCode": [("OK", 0), ("ErrorNoDirectionPin", -1), ("ErrorSpeedIsUndefined", -2),
                       ("ErrorAccelerationIsUndefined", -3)],
    "MoveTimedResultCode": [("OK", 0), ("QueueFull", 1), ("DirPinIsBusy", 2),
                            ("WaitForEnablePinActive", 3), ("DeviceNotReady", 4),
                            ("DirPin2msPauseAdded", 5), ("MoveBusy", 6), ("MoveEmpty", 7),
                            ("ErrorTicksTooLow", -1), ("ErrorEmptyQueueToStart", -2),
                            ("ErrorNoDirPinToToggle", -3), ("ErrorMoveTooLarge", -4)],
    "DelayResultCode": [("OK", 0), ("TOO_LOW", -1), ("TOO_HIGH", -2)],
    "FasDriver": [("MCPWM_PCNT", 0), ("RMT", 1), ("I2S_DIRECT", 2), ("I2S_MUX", 3),
                  ("DONT_CARE", 255)],
}


def _doc_rows() -> list[tuple[str, str, str]]:
    doc = api_coverage.DOC.read_text()
    return [(m["up"].strip(), m["py"].strip(), m["rest"].strip())
            for line in doc.splitlines() if (m := api_coverage.ROW.match(line))]


def test_every_enum_member_is_listed_with_its_value():
    """Each upstream member has a row naming our member, and the values agree."""
    rows = {up.strip("`"): py.strip("`") for up, py, _ in _doc_rows()}
    for enum, members in UPSTREAM_MEMBERS.items():
        for name, value in members:
            ours = rows.get(f"{enum}::{name}")
            assert ours is not None, f"{enum}::{name} not in the table"
            _, cls, member = ours.split(".")
            assert getattr(fas.codes, cls)[member] == value, (enum, name, ours)


def test_avr_step_pin_names_are_listed_and_agree_with_the_profiles():
    from fas.arch import PROFILES

    upstream_column = " ".join(up for up, _, _ in _doc_rows())
    for name in (*AVR_STEP_PINS, "stepPinStepper1C", "stepPinStepperA", "stepPinStepperB",
                 "stepPinStepperC", "FAS_TIMER_MODULE"):
        stem = name[:-1] if name[-1] in "BC" and name[-2].isdigit() else name
        assert name in upstream_column or stem + "A" in upstream_column, name
    for timer, profile in ((3, "atmega2560_timer3"), (4, "atmega2560"), (5, "atmega2560_timer5")):
        pins = tuple(AVR_STEP_PINS[f"stepPinStepper{timer}{c}"] for c in "ABC")
        assert PROFILES[profile].step_pin_groups == tuple((p,) for p in pins)
        assert PROFILES[profile].timer_module == timer
    assert PROFILES["atmega328p"].step_pin_groups == ((9,), (10,))
    assert PROFILES["atmega32u4"].step_pin_groups == ((9,), (10,), (11,))
    assert PROFILES["atmega2560_timer1"].step_pin_groups == ((11,), (12,), (13,))
    # the notes column states the pins: they must be the profile's
    for up, _, rest in _doc_rows():
        for profile, pins in re.findall(r"`(atmega\w+)`(?: \(timer \d\))?: ([\d, ]+)", rest):
            if "stepPinStepper" in up:
                want = tuple(int(p) for p in pins.split(","))
                assert PROFILES[profile].step_pin_groups == tuple((p,) for p in want), up


def test_every_strict_xfail_of_upstreams_sketches_is_listed():
    """The tests that hold an upstream expectation not met yet are named in the
    document, and the known-deviation table is that of the scenario files."""
    import ast

    tree = ast.parse((ROOT / "tests" / "fas" / "test_upstream_sketches.py").read_text())
    names = [f.name for f in tree.body if isinstance(f, ast.FunctionDef)
             and any("xfail" in ast.unparse(d) and "strict=True" in ast.unparse(d)
                     for d in f.decorator_list)]
    doc = api_coverage.DOC.read_text()
    assert all(f"`{n}`" in doc for n in names), names
    # ... and the document's table of them names no test that passes by now
    section = doc.split("## Not met yet", 1)[1].split("Scenario files", 1)[0]
    listed = re.findall(r"^\| `(test_\w+)` \|", section, re.M)
    assert sorted(listed) == sorted(names), (listed, names)
    assert api_coverage.known_table() in doc
