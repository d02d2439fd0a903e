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
