"""Grbl 1.1's answer numbers: ``error:N`` for a refused line, ``ALARM:N`` for an alarm.

Senders map these numbers to their own tables (bCNC, cncjs, UGS, LaserGRBL), so a
refusal carries Grbl's number for the same cause; the readable reason goes in a
``[MSG:...]`` line before it (:mod:`stepperdemo.messages`).  Numbers as in Grbl 1.1h's
``doc/markdown/interface.md``; 39 is Grbl_ESP32's (an output number out of range).
"""

from __future__ import annotations

from enum import IntEnum


class Err(IntEnum):
    """``error:N``."""

    EXPECTED_COMMAND_LETTER = 1  # a word must start with a letter
    BAD_NUMBER_FORMAT = 2  # a number missing or malformed
    INVALID_STATEMENT = 3  # a $ command not recognised, no such setting, bad value
    NEGATIVE_VALUE = 4  # F N P S T, settings: must not be negative
    SETTING_DISABLED = 5  # $H while homing is off
    SETTING_STEP_PULSE_MIN = 6  # $0 below 3 us
    IDLE_ERROR = 8  # the $ command needs Idle (or Alarm)
    SYSTEM_GC_LOCK = 9  # G-code locked in Alarm or Jog
    SOFT_LIMIT_ERROR = 10  # soft limits need homing
    OVERFLOW = 11  # line too long
    CHECK_DOOR = 13  # safety door open
    LINE_LENGTH_EXCEEDED = 14  # a startup line / build info too long to store
    TRAVEL_EXCEEDED = 15  # jog beyond the travel (soft limits)
    INVALID_JOG_COMMAND = 16  # $J without '=' or with a G/M code it does not allow
    SETTING_DISABLED_LASER = 17  # laser mode needs a PWM spindle
    UNSUPPORTED_COMMAND = 20  # a G/M code or word letter this does not do
    MODAL_GROUP_VIOLATION = 21  # two codes of one modal group
    UNDEFINED_FEED_RATE = 22  # G1 with F0 or no F; a jog without F
    COMMAND_VALUE_NOT_INTEGER = 23  # M3.5, G1.5
    AXIS_COMMAND_CONFLICT = 24  # two codes in one block want the axis words
    WORD_REPEATED = 25
    NO_AXIS_WORDS = 26  # a code that needs axis words has none
    INVALID_LINE_NUMBER = 27  # N beyond 9 999 999
    VALUE_WORD_MISSING = 28  # P, E, Q ... required
    UNSUPPORTED_COORD_SYS = 29
    G53_INVALID_MOTION_MODE = 30
    AXIS_WORDS_EXIST = 31
    NO_AXIS_WORDS_IN_PLANE = 32
    INVALID_TARGET = 33  # a target the machine cannot reach (wiring)
    ARC_RADIUS_ERROR = 34
    NO_OFFSETS_IN_PLANE = 35
    UNUSED_WORDS = 36  # value words no command in the block uses
    G43_DYNAMIC_AXIS_ERROR = 37
    MAX_VALUE_EXCEEDED = 38  # e.g. a tool number above 255
    PARAMETER_OUT_OF_RANGE = 39  # Grbl_ESP32: P/E of M62..M68 beyond its outputs


class Alarm(IntEnum):
    """``ALARM:N``."""

    HARD_LIMIT = 1
    SOFT_LIMIT = 2
    ABORT_CYCLE = 3  # reset (or a stop) while moving: the position may be lost
    PROBE_FAIL_INITIAL = 4
    PROBE_FAIL_CONTACT = 5
    HOMING_FAIL_RESET = 6
    HOMING_FAIL_DOOR = 7
    HOMING_FAIL_PULLOFF = 8
    HOMING_FAIL_APPROACH = 9
