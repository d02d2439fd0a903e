"""Every text the console prints, in one place.

Line ends follow the firmware: texts that the original sketch prints with its
internal message table end in a bare "\\n"; values printed with ``println`` end in
"\\r\\n".  The acknowledgements, error lines, status lines and the stepper table are
byte-for-byte those of StepperDemo, so that tools parsing its output keep working.
The usage texts are our own words; the normal-mode usage keeps the firmware's length
(2190 characters), because at 115200 baud its printing time decides when the first
command runs.
"""

from __future__ import annotations

NL = "\n"
CRLF = "\r\n"
VERSION = "py-fas-0.1.0"

BANNER_VERSION = "StepperDemo Version " + VERSION + NL
BANNER_F_CPU = "    F_CPU="
BANNER_TICKS = "    TICKS_PER_S="
BANNER_STEPPERS = "    Steppers="

SELECT_STEPPER = "Select stepper "
TOGGLE_MOTOR_INFO = "Toggle stepper info" + NL
TOGGLE_USAGE_INFO = "Toggle usage info" + NL
ENTER_TEST_MODE = "Enter test mode" + NL
ENTER_CONFIG_MODE = "Enter config mode" + NL
EXIT_TO_MAIN_MENU = "Exit to main menu" + NL
SET_ACCELERATION_TO = "set acceleration to "
SET_SPEED_TO_US = "set speed (us/step) to "
SET_SPEED_TO_HZ = "set speed (steps /s) to "
SET_SPEED_TO_MILLI_HZ = "set speed (steps /1000s) to "
MOVE_STEPS = "Move steps "
MOVE_TO_POSITION = "Move to position "
RETURN_CODE = "returncode = "
SET_POSITION = "set position "
SET_ENABLE_TIME = "set enable timeto "  # sic: the firmware joins "time" and "to "
SET_DISABLE_TIME = "set disable timeto "
LINEAR_ACCELERATION = "linear acceleration steps="
JUMP_START = "jump start steps="
OUTPUT_DRIVER_ON = "Output driver on" + NL
OUTPUT_DRIVER_OFF = "Output driver off" + NL
OUTPUT_DRIVER_AUTO = "Output driver automatic mode" + NL
STOP = "stop" + NL
KEEP_RUNNING = "Keep running" + NL
RUN_FORWARD = "run forward" + NL
RUN_BACKWARD = "run backward" + NL
IMMEDIATE_STOP = "immediate stop" + NL
UPDATE_SPEED_ACCELERATION = "Update speed  / acceleration " + NL
BLOCKING_WAIT = "Blocking wait for running stepper to stop" + NL
STOPPED = "STOPPED"
TEST_DIRECT_DRIVE = "test direct drive" + NL
STEPPED_FORWARD = "Stepped forward" + NL
STEPPED_BACKWARD = "Stepped backward" + NL
WAIT_MS = " ms wait" + NL
WAIT_COMPLETE = "Wait complete" + NL
SELECT_TEST_SEQUENCE = "Select test sequence: "
RUN_TESTS = "run test " + NL
FAILED_STATUS = "Failed status from test " + NL
PASS_STATUS = "test passed" + NL
TEST_COMPLETED = "test completed" + NL
ENABLE_LOW_PIN_IS_NOT_LOW = "Cannot set enable LOW pin to LOW " + NL
ENABLE_LOW_PIN_IS_NOT_HIGH = "Cannot set enable LOW pin to HIGH " + NL
ENABLE_HIGH_PIN_IS_NOT_LOW = "Cannot set enable HIGH pin to LOW " + NL
ENABLE_HIGH_PIN_IS_NOT_HIGH = "Cannot set enable HIGH pin to HIGH " + NL
CANNOT_SET_DIRECTION_PIN = "Cannot set direction pin to "
STEP_PIN_IS_NOT_LOW = "Cannot set step pin to LOW " + NL
STEP_PIN_IS_NOT_HIGH = "Cannot set step pin to HIGH " + NL
ERROR_INVALID_VALUE = "ERROR invalid value" + NL
MOVE_RESULT = {
    0: "OK" + NL,
    -1: "ERROR no direction pin => impossible move" + NL,
    -2: "ERROR speed is not defined" + NL,
    -3: "ERROR acceleration is not defined" + NL,
}
STRAY_DIGITAL_READ_TOGGLE = "Toggle erroneous digitalRead() to step pin " + NL
STRAY_DIGITAL_READ_ENABLED = "erroneous digitalRead() to step pin IS ON !!!" + NL
# The firmware means "100 µs", but its message table reads the two UTF-8 bytes of
# "µ" as references to two other table entries; this is what it really prints (and
# what its console timing is made of), so it is what StepperDemo users see.
_MICRO_GARBLED = "100 set acceleration to , counting s"
LONG_INTERRUPT_BLOCK_TOGGLE = "Toggle erroneous " + _MICRO_GARBLED + " ISR block" + NL
LONG_INTERRUPT_BLOCK_ENABLED = "erroneous " + _MICRO_GARBLED + " ISR BLOCK IS ON" + NL
SET_UNIDIRECTIONAL_STEPPER = "set unidirectional stepper" + NL
DIRECTION_PIN = "direction pin "
SET_TO_PIN = "set to pin "
DISABLED = "disabled" + NL
HIGH_COUNT_UP = "high counts up"
HIGH_COUNT_DOWN = "high counts down"
DELAY_IN_US = "delay in us = "
UNKNOWN_COMMAND = "Unknown command: "
ACCELERATION_STATUS = " acceleration  [steps/s^2]="
SPEED_STATUS_FREQ = " speed [mstep/s]="
SPEED_STATUS_TIME = " speed [us/step]="
ABORT_RAMP = "Abort ramp due to queue error res="
PULSE_COUNTER_ERROR = "ERROR attaching pulse counter " + NL
SEQ_PULSE_COUNTER_ERROR = "Error attaching to pulse counter"
ATTACH_PULSE_COUNTER = "attach pulse counter "
CLEAR_PULSE_COUNTER = "clear pulse counter " + NL

# status line pieces
STATUS_NONSTOP = " nonstop"
STATUS_TARGET = " => "
STATUS_QUEUE_END = " QueueEnd="
STATUS_V = " v="
STATUS_MSTEPS = "mSteps/s"
STATUS_US = "us/"
STATUS_TICKS = "ticks"
RAMP_STATE_TEXT = {0: " IDLE ", 2: " ACC  ", 4: " RED  ", 1: " COAST", 12: " REV  "}
STATUS_MANUAL = " MANU"
TABLE_SELECTED = ">> "
TABLE_OTHER = "   "

# test sequences
SPEED_CHANGES = "Speed changes 64us <=> "
NOT_ALL_RAW_EXECUTED = "not all raw commands executed"
STEPPER_POS = "stepper pos="
REAL_POS = "  real pos="
STEPS_NEEDED_FOR_STOP = "Steps needed for stop="
STEP_AFTER_STOP = "Step AFTER stop"
SEQ_SPEED = "speed="
SEQ_ACCEL = " accel="
SEQ_MOVE = " move="
SEQ_PREV_POS = " prev pos="
SEQ_OLD_POS = " old pos="
SEQ_CURR_POS = " curr pos="
SEQ_I = "i="

_USAGE_NORMAL_LINES = [
    "Enter commands separated by space, carriage return or newline:",
    "    M1/M2/..  ... choose the stepper the next commands act on",
    "    c         ... enter configuration mode (direction pins)",
    "    V<speed>  ... max speed of the chosen stepper, period in us/step",
    "    H<speed>  ... max speed of the chosen stepper in steps/s",
    "    h<speed>  ... max speed of the chosen stepper in steps/1000s",
    "    A<accel>  ... acceleration of the chosen stepper in steps/s^2",
    "    a<accel>  ... run by acceleration alone: + forward, - backward",
    "    J<steps>  ... raise the acceleration linearly over <steps>",
    "    j<steps>  ... jump start: begin the ramp at ramp step <steps>",
    "    U         ... apply new speed/acceleration to the running move",
    "    P<pos>    ... move the chosen stepper to position <pos>",
    "    R<n>      ... move the chosen stepper by <n> steps (+/-)",
    "    f         ... run forward without end, counting up",
    "    b         ... run backward without end, counting down",
    "    K         ... keep the chosen stepper running as it goes now",
    "    @<pos>    ... the current position is now <pos> (may be < 0)",
    "    E<us>     ... delay from driver enable to the first step",
    "    D<ms>     ... delay from the last step to driver disable",
    "    N         ... driver output on, no automatic enable",
    "    F         ... driver output off, no automatic enable",
    "    O         ... automatic driver enable/disable",
    "    S         ... stop the chosen stepper with its ramp",
    "    X         ... stop at once without ramp, position := 0",
    "    I         ... status lines while running: on/off",
    "    W         ... hold input until the chosen stepper stands still;"
    " waits for ever if it runs for ever",
    "    w<ms>     ... hold input for <ms> milliseconds",
    "    +         ... one step forward of the chosen stepper",
    "    -         ... one step backward of the chosen stepper",
    "    T         ... self test: drive the pins directly",
    "    t         ... test mode (built-in sequences 01..13)",
    "    u         ... drop the direction pin (until reset)",
    "    r         ... stray digitalRead() of step pins: on/off",
    "    e         ... 100us interrupt block in 64 of 256 ms: on/off",
    "    Q         ... usage after a stepper stops: on/off",
    "    ?         ... print this usage and stepper table",
]
USAGE_NORMAL = NL.join(_USAGE_NORMAL_LINES) + NL + NL
USAGE_NORMAL_LENGTH = 2190

USAGE_TEST = NL.join([
    "Enter commands separated by space, carriage return or newline:",
    "    M1/M2/..  ... choose the stepper that the next sequence number is for",
    "    01 .. 13  ... assign test sequence 01 .. 13 to the chosen stepper",
    "    R         ... run all assigned test sequences",
    "    I         ... status lines on or off while a sequence runs",
    "    W         ... hold further input until the running test has finished",
    "    x         ... leave test mode",
    "    Q         ... usage and table after a stepper stopped on or off",
    "    ?         ... print this help",
]) + NL + NL

USAGE_CONFIG = NL.join([
    "Enter commands separated by space, carriage return or newline:",
    "    M1/M2/..  ... choose the stepper to configure",
    "    d<p>      ... direction pin <p>, high level counts up",
    "    d<p,n>    ... direction pin <p>; n=1: high counts up, n=0: high counts down",
    "    d<p,n,t>  ... as above, plus <t> us pause between a direction change and",
    "                  the next step (0 = none)",
    "    dc        ... no direction pin (unidirectional stepper)",
    "    l0 / l1   ... planner: FastAccelStepper ramp / QuickStep (FIFO, plateaus)",
    "    q<n>      ... QuickStep FIFO depth 1..255 orders (4 bytes each)",
    "    p<n>      ... QuickStep plateaus 1..255 per acceleration/deceleration",
    "    b<us>     ... QuickStep base time in us, 0 = automatic; b<us,t> on timer t",
    "    x         ... leave configuration mode",
    "    ?         ... print this help",
]) + NL + NL

# How StepperDemo's firmware finds each text: its texts live in one compressed
# table that is read byte by byte from the start, and a text may refer to shared
# fragments that are looked up the same way.  Per text: bytes read and look-ups
# made before its first character goes out, then bytes read and look-ups in all.
# Counted on the 1.2.6 firmware build; the simulated loop charges them with
# ``DemoBuild.msg_scan_byte_ticks`` and ``DemoBuild.msg_lookup_ticks``.
TABLE_SCAN: dict[str, tuple[int, int, int, int]] = {
    SELECT_STEPPER: (581, 1, 906, 3), TOGGLE_MOTOR_INFO: (657, 2, 982, 4),
    TOGGLE_USAGE_INFO: (666, 2, 971, 3), ENTER_TEST_MODE: (876, 2, 1373, 4),
    SET_ACCELERATION_TO: (756, 2, 1000, 4), SET_SPEED_TO_US: (760, 2, 1056, 5),
    MOVE_STEPS: (628, 2, 978, 4), MOVE_TO_POSITION: (631, 2, 1052, 4),
    RETURN_CODE: (635, 1, 635, 1), SET_POSITION: (792, 2, 1170, 3),
    SET_ENABLE_TIME: (795, 2, 1080, 5), SET_DISABLE_TIME: (799, 2, 1092, 5),
    OUTPUT_DRIVER_ON: (667, 2, 667, 2), OUTPUT_DRIVER_OFF: (672, 2, 672, 2),
    OUTPUT_DRIVER_AUTO: (678, 2, 953, 3), STOP: (1089, 2, 1089, 2),
    KEEP_RUNNING: (689, 1, 689, 1), RUN_FORWARD: (873, 2, 1048, 3),
    RUN_BACKWARD: (877, 2, 1060, 3), IMMEDIATE_STOP: (711, 1, 1114, 2),
    UPDATE_SPEED_ACCELERATION: (724, 1, 1140, 3), BLOCKING_WAIT: (738, 1, 1509, 5),
    TEST_DIRECT_DRIVE: (992, 2, 992, 2), STEPPED_FORWARD: (977, 2, 1152, 3),
    STEPPED_BACKWARD: (981, 2, 1164, 3), WAIT_MS: (793, 1, 793, 1),
    SELECT_TEST_SEQUENCE: (803, 1, 1025, 2), EXIT_TO_MAIN_MENU: (822, 1, 865, 2),
    RUN_TESTS: (1009, 2, 1231, 3), WAIT_COMPLETE: (843, 1, 843, 1),
    FAILED_STATUS: (858, 1, 1488, 3), ENABLE_LOW_PIN_IS_NOT_LOW: (897, 2, 1219, 8),
    ENABLE_LOW_PIN_IS_NOT_HIGH: (903, 2, 1234, 8),
    ENABLE_HIGH_PIN_IS_NOT_LOW: (909, 2, 1236, 8),
    ENABLE_HIGH_PIN_IS_NOT_HIGH: (915, 2, 1251, 8), STEP_PIN_IS_NOT_LOW: (921, 2, 1507, 8),
    STEP_PIN_IS_NOT_HIGH: (925, 2, 1520, 8), CANNOT_SET_DIRECTION_PIN: (929, 2, 1115, 5),
    BANNER_VERSION: (913, 1, 913, 1), ATTACH_PULSE_COUNTER: (1083, 2, 1204, 3),
    PULSE_COUNTER_ERROR: (1025, 2, 1282, 4), ERROR_INVALID_VALUE: (1034, 2, 1034, 2),
    MOVE_RESULT[-3]: (1050, 2, 1405, 4), MOVE_RESULT[-2]: (1054, 2, 1423, 4),
    MOVE_RESULT[-1]: (1058, 2, 1201, 4), MOVE_RESULT[0]: (1010, 1, 1010, 1),
    STRAY_DIGITAL_READ_TOGGLE: (1080, 2, 2028, 8),
    STRAY_DIGITAL_READ_ENABLED: (1249, 2, 1969, 7),
    LONG_INTERRUPT_BLOCK_TOGGLE: (1102, 2, 2744, 8),
    LONG_INTERRUPT_BLOCK_ENABLED: (1285, 2, 2699, 7),
    SET_UNIDIRECTIONAL_STEPPER: (1226, 2, 1551, 4), CLEAR_PULSE_COUNTER: (1382, 2, 1503, 3),
    SET_SPEED_TO_HZ: (1249, 2, 1857, 6), PASS_STATUS: (1338, 2, 1338, 2),
    TEST_COMPLETED: (1347, 2, 1347, 2), ENTER_CONFIG_MODE: (1405, 2, 1680, 3),
    DIRECTION_PIN: (1258, 2, 1291, 3), SET_TO_PIN: (1294, 2, 1370, 4),
    DISABLED: (1257, 2, 1257, 2), HIGH_COUNT_UP: (1240, 2, 1240, 2),
    HIGH_COUNT_DOWN: (1244, 2, 1244, 2), DELAY_IN_US: (1529, 2, 1529, 2),
    UNKNOWN_COMMAND: (1179, 1, 1179, 1), SET_SPEED_TO_MILLI_HZ: (1340, 2, 1948, 6),
    ACCELERATION_STATUS: (1211, 1, 1450, 3), SPEED_STATUS_FREQ: (1224, 1, 1477, 3),
    SPEED_STATUS_TIME: (1234, 1, 1487, 3), LINEAR_ACCELERATION: (1244, 1, 1483, 3),
    JUMP_START: (1256, 1, 1294, 2), USAGE_NORMAL: (2061, 3, 87268, 355),
    USAGE_TEST: (1993, 1, 1993, 1), USAGE_CONFIG: (1994, 1, 1994, 1),
}

# console (REPL) texts, not part of the firmware
REPL_WELCOME = ("stepperdemo {version} on a simulated {profile} ({mode}). "
                "Type {title} commands, /help for console commands, Ctrl-D to quit.")
REPL_HELP = """Console commands (everything else goes to StepperDemo):
  /help              this text
  /quit              leave (Ctrl-D does the same)
  /arch [name]       show the profile, or restart on another one
  /stop              force-stop all steppers (Ctrl-C does the same)
  /time              simulated time and speed-up
  /speed <factor>    run the simulated clock <factor> times faster than real time
StepperDemo commands of the current mode: type ? for the firmware usage."""
REPL_STOPPED_ALL = "all steppers force-stopped"
REPL_UNKNOWN_META = "unknown console command {cmd!r} - try /help"
REPL_TIME = "simulated time {sim:.3f} s (x{scale:g} real time)"
REPL_PROFILE = "profile {name}: {title}, {steppers} steppers, {ticks} ticks/s"
REPL_SWITCHED = "restarted on profile {name}"
REPL_BAD_ARG = "{cmd}: {problem}"
REPL_BYE = "bye"
REPL_HISTORY_FAILED = "(history file not usable: {error})"

# stepperdemo run (scenario files)
TRANSCRIPT_LINE_DIFF = "line {line}: {ours!r}, reference {ref!r}"
TRANSCRIPT_LENGTH_DIFF = "{ours} lines, reference {ref}"
RUN_DESCRIPTION = ("Run scenario files (sequences/*.toml) on virtual time and compare "
                   "the result with their expectations.")
RUN_TABLE_TITLE = "scenario results"
RUN_REPORT_TITLE = "conformance report: step times against the reference"
RUN_BROKEN = "broken scenario file"
RUN_CHECKS_PASSED = "{n} checks"
RUN_PROGRESS = "running"
RUN_SUMMARY = "{total} scenarios, {failed} failed"
RUN_SUMMARY_SKIPPED = ", {n} skipped"
RUN_NO_FILE = "stepperdemo run: no such file or folder: {path}"
RUN_NOTHING = "stepperdemo run: no scenario files found"
RUN_TIMING_REPORT_HEAD = "--- timing report: {name} ---"

# command line
CLI_MAX_TIME = ("stopped after {seconds:g} s of simulated time (--max-time): "
                "a stepper was still running or the input was still held")
CLI_ERROR = "stepperdemo: {problem}"
CLI_INPUT_DROPPED = ("stepperdemo: {n} input characters dropped, as the firmware drops them: "
                     "its 256-byte input ring was full while a W held the line; "
                     "split lines longer than 256 characters")
CLI_BAD_NUMBER = "{option} {value:g}: give {what}"
LINK_NO_FOLDER = "--link {path}: no folder {folder} to make the link in"
LINK_IS_FOLDER = "--link {path}: a folder is in its place"

# ---------------------------------------------------------------------------------------
# Watching a run (issue 6): VCD trace, plots, timing report, step CSV.  Console texts,
# not part of the firmware.  Times in the report are microseconds ("us", as the firmware
# writes them), exact to 4 decimals.
VCD_COMMENT = "StepperDemo on a simulated {profile}; pins as in its demo wiring"
REPORT_TITLE = "timing report: {profile}, {start:.3f} s .. {end:.3f} s of simulated time"
REPORT_NOT_RECORDED = "timing report: the steps were not recorded"
REPORT_NO_STEPS = "  no stepper made a step or changed a pin"
REPORT_NONE = "-"
REPORT_STEPPER = "M{n}  step pin {step}{pins}"
REPORT_PIN = ", {role} pin {pin}"
REPORT_PULSES = ("  pulses       {pulses} (the channel counted {counted}), net {net:+d} steps,"
                 " position {position} by the pins")
REPORT_POSITION_DIFFERS = "  position     the library says {library} (set with @ or X?)"
REPORT_PERIOD = "  step period  min {min} us, median {median} us, max {max} us"
REPORT_SPEED = ("  peak speed   {speed:.0f} steps/s; acceleration up to {acc},"
                " deceleration up to {dec} steps/s^2")
REPORT_DEVIATION = ("  vs. plan     {compared} step intervals: {ontime} as planned,"
                    " {late} late (max +{late_max} us), {early} early (max -{early_max} us)")
REPORT_DEVIATION_NONE = "  vs. plan     all {compared} step intervals as planned"
REPORT_HIGH = "  pulse high   min {min} us, max {max} us"
REPORT_GAPS = "  gaps         {gaps} longer than {factor}x the period before (longest {longest} us)"
REPORT_GAPS_NONE = "  gaps         none longer than {factor}x the period before"
REPORT_QUEUE = ("  queue        {motions} motion(s), ran empty {dry}x, underruns {restarts},"
                " missed compares {missed}")
REPORT_DIR = "  direction    {changes} change(s), shortest dir-to-step {delay} us"
REPORT_ENABLE = ("  enable       {enables} activation(s), enable-to-first-step {min} .. {max} us,"
                 " {disabled} steps with the driver disabled")
REPORT_IRQ = "interrupts blocked  {windows} window(s), {ms:.1f} ms in total"
REPORT_STRAY = "stray digitalRead() {reads} of the step pins, {during} during a pulse"
REPORT_LATE_EDGES = "warning: {n} edges arrived out of order (clamped in the trace)"
PLOT_EXTRA_MISSING = ("PNG plots need matplotlib, which is not installed: pip install "
                      "matplotlib (in the stepperdemo checkout: pip install '.[plot]')")
PLOT_TITLE_POSITION = "position [steps]"
PLOT_TITLE_SPEED = "speed [steps/s]"
PLOT_AXIS_TIME = "time [s]"
PLOT_TERMINAL_HEADER = "M{n} {what}"
PLOT_NO_DATA = "nothing to plot: no steps recorded"
OBSERVE_BAD_SIZE = ("--plot-size {size!r}: give WIDTHxHEIGHT in pixels, e.g. 1200x800 "
                    "(200 .. 10000 a side, at most 40 million pixels)")
PLOT_BAD_FORMAT = "--plot {path}: a plot file ends in {formats}"
PLOT_NO_FOLDER = "no folder {folder}"
PLOT_IS_FOLDER = "it is a folder"
OBSERVE_NOT_INTERACTIVE = ("--vcd, --plot, --report and --steps-csv go with -c (or run); "
                           "the console records the recent motion by itself: /vcd, /plot, "
                           "/report (/trace on records all of it)")
OBSERVE_BAD_TIMESCALE = ("--vcd-timescale {timescale!r}: give 1, 10 or 100 and a unit "
                         "s, ms, us, ns, ps or fs, e.g. '1 us', or 'exact'")
REPL_VCD_BAD_UNIT = ("{unit!r} is no VCD time unit: give 1, 10 or 100 and s, ms, us, ns, ps "
                     "or fs, e.g. 1us, or exact")
REPL_VCD_USAGE = "give a file name and, if you like, a time unit: /vcd FILE [1us|100ns|exact]"
VCD_ZERO_WIDTH = ("{path}: {n} pulse(s) or gap(s) shorter than {unit} start and end at the "
                  "same time there (PulseView drops them); --vcd-timescale exact keeps every "
                  "tick")
REPL_VCD_ZERO_WIDTH = (" - {n} pulse(s) or gap(s) shorter than {unit} have no width in it "
                       "(/vcd {path} exact keeps every tick)")
OBSERVE_FILE_ERROR = "cannot write {path}: {error}"
OBSERVE_WROTE = "wrote {path}"
REPL_HELP_OBSERVE = """Watching the run - the console records the recent motion from the start: the
last {bound} pin edges (about {seconds:.1f} s of one stepper at 25 kHz), older ones dropped:
  /trace             what is being recorded
  /trace on          record everything from now on, without a bound
  /trace off         stop recording; the last recording stays for /vcd, /plot, /report
  /trace recent      record the recent motion again (the bounded recording)
  /vcd FILE [UNIT]   save the recorded pins as a VCD file (GTKWave, PulseView) in
                     the time unit UNIT (--vcd-timescale, else 1us; exact: every tick)
  /plot [FILE.png]   position and speed over time: in the terminal, or as PNG
  /report            timing report per stepper (periods, deviations, gaps, ...)"""
REPL_TRACE_ON = "trace on: recording the pins of every stepper from t={t:.3f} s"
REPL_TRACE_ALREADY = "trace is already on (since t={t:.3f} s)"
REPL_TRACE_OFF = "trace off: {edges} edges recorded (t={start:.3f} .. {end:.3f} s)"
REPL_TRACE_NOT_ON = "trace is off"
REPL_TRACE_STATUS = "trace {state}: {edges} edges so far (from t={start:.3f} s)"
REPL_TRACE_NOTHING = "nothing recorded: /trace recent or /trace on records the pins"
REPL_VCD_WROTE = "wrote {path}: {edges} edges, t={start:.3f} .. {end:.3f} s"

# ---------------------------------------------------------------------------------------
# serial backend (issue 7): stepperdemo --port, stepperdemo device, stepperdemo relay
REPL_WELCOME_SERIAL = ("stepperdemo {version} on a {profile} device at {port}. "
                       "Type {title} commands, /help for console commands, Ctrl-D to quit.")
REPL_HELP_SERIAL = """On a device (--port):
  /reconnect [port]  open the device again (after it was lost), or another port
  /link              link statistics (retransmissions, CRC errors) and device counters
  /estop             emergency stop: the device halts every motion at once"""
SERIAL_NOT_SERIAL = "{cmd}: only with a device (stepperdemo --port DEVICE)"
SERIAL_NOT_ON_DEVICE = "{cmd}: not on a device (its profile and clock are its own)"
SERIAL_LOST = "device lost: {reason} - /reconnect to restore the session"
SERIAL_RECONNECTED = "device back on {port} ({profile}, session {sessions})"
SERIAL_RECONNECT_FAILED = "reconnect failed: {error}"
SERIAL_ESTOP_DONE = "emergency stop: every motion halted, positions taken from the device"
SERIAL_ESTOP_NO_DEVICE = ("emergency stop: no device ({reason}) - nothing sent; a device that "
                          "loses its host stops by its watchdog; /reconnect")
SERIAL_ESTOP_FAILED = "emergency stop: no answer, the device is lost ({reason}) - /reconnect"
SERIAL_NOT_CONNECTED = "no device ({reason}) - /reconnect first; the line was not sent"
SERIAL_LAST_REPORT = ("the device's figures below are its last report, from before the "
                      "connection ended")
SERIAL_LINK_STATS = ("link: {frames_sent} frames sent, {retransmissions} retransmitted, "
                     "{naks} NAKs; {frames_received} received, {crc_errors} CRC errors, "
                     "{framing_errors} framing errors; rtt {rtt_us} us; "
                     "{sessions} session(s)")
SERIAL_DEVICE_STATS = ("device: {entries} commands, {entries_lost} lost, "
                       "{entries_duplicated} duplicated, {underruns} underruns, "
                       "{late_starts} late starts; frames {frames_ok} ok, "
                       "{frames_duplicate} repeated, {frames_out_of_order} out of order, "
                       "{crc_errors} CRC errors; {watchdog_trips} watchdog stops")
SERIAL_STEPPER_STATS = "device M{n}: position {position}, {pulses} pulses, {underruns} underruns"
CLI_SERIAL_LOST = "stepperdemo: device lost: {reason}"
CLI_SERIAL_CONNECT = "stepperdemo: cannot use the device at {port}: {error}"
SERIAL_NO_OBSERVE = ("--vcd, --plot, --report and --steps-csv record the simulated pins; "
                     "with --port the pins are on the device")
DEVICE_LISTENING = ("device {profile} ({title}) on {path}{link}, clock x{speed:g}; "
                    "Ctrl-C ends")
DEVICE_EVENT = "device: {event}"
DEVICE_STEPPER_STATS = ("M{n}: position {position}, {pulses} pulses in the last session, "
                        "{edges} since the start")
DEVICE_COUNTERS = ("counters: {entries} commands, {entries_lost} lost, {entries_duplicated} "
                   "duplicated, {underruns} underruns, {late_starts} late starts, "
                   "{frames_ok} frames, {frames_duplicate} repeated, {frames_out_of_order} "
                   "out of order, {crc_errors} CRC errors, {framing_errors} framing errors, "
                   "{watchdog_trips} watchdog stops, {rejected} rejected")
RELAY_LISTENING = "relay: host side {path}{link} <-> device {device}; Ctrl-C ends"
RELAY_DEVICE_GONE = "relay: device side closed ({reason})"
RELAY_STATS = ("relay {direction}: {bytes_in} bytes in, {bytes_out} out, {dropped} dropped, "
               "{corrupted} corrupted, {duplicated} duplicated")
# --------------------------------------------------------------- end of serial texts

# ------------------------------------------------- issue 16: the console as people use it
RUN_FAILED_CHECKS = "FAIL ({n} failed)"
RUN_OK_KNOWN = "ok, {n} known deviation(s)"  # [known_deviation] entries still off
RUN_KNOWN = "known"  # a known deviation, still there
RUN_KNOWN_GONE = "MET: remove from known_deviation"  # strict: it passes now
# the console's recording of the recent motion (bounded, on by default; /trace recent)
REPL_TRACE_RECENT_ON = ("trace recent: recording the last {bound} pin edges (about {seconds:.1f} s "
                        "of one stepper at 25 kHz) from t={t:.3f} s")
REPL_TRACE_RECENT_ALREADY = "trace recent is already on: the last {bound} pin edges are kept"
REPL_TRACE_RECENT_STATUS = ("trace recent: {held} edges held, t={start:.3f} .. {end:.3f} s "
                            "(keeps the last {bound}{dropped})")
REPL_TRACE_RECENT_DROPPED = "; {dropped} older edges dropped"
REPL_TRACE_RECENT_OFF = ("trace off: recording stopped; the recent {held} edges "
                         "(t={start:.3f} .. {end:.3f} s) stay for /vcd, /plot and /report")
REPL_TRACE_OFF_KEPT = ("trace off: the last recording ({edges} edges, t={start:.3f} .. "
                       "{end:.3f} s) stays for /vcd, /plot and /report")
REPL_TRACE_BAD = "on, off or recent"
REPL_TRACE_ARCH_KEPT = ("trace off: the recording on the {profile} stays for /vcd, /plot and "
                        "/report; /trace recent or /trace on records the new chip")
REPL_VCD_START_DROPPED = " - the start was dropped: the recent recording keeps the last {bound}"
REPORT_RECENT_WINDOW = ("  (the recent recording: {held} pin edges kept, {dropped} older ones "
                        "dropped; positions carried forward)")
# ---------------------------------------------------------------------------------------
# The board console (issue 15): stepperdemo --board DEVICE, -c on a board, run --board,
# device --pty --console.  Console texts, not part of the firmware.
BOARD_WELCOME = ("stepperdemo {version} in front of the board at {port} ({baud} baud). "
                 "Type StepperDemo commands, /help for console commands, Ctrl-D to quit.")
BOARD_HELP = """Console commands (everything else goes to the board):
  /help              this text
  /quit              leave (Ctrl-D does the same)
  /stop              X to every stepper: stop at once (Ctrl-C does the same)
  /reset             restart the board (DTR pulse; a pty is closed and opened again)
  /reconnect [port]  open the board again after it was lost, or another port
  /state             what the board's answers say: mode, stepper, toggles, positions
  /time              session time and lines received
  /plot [FILE.png]   position and speed from the status lines: terminal, or PNG
  /report            report from the status lines per stepper
Input is sent one command at a time; after W it waits until the board's wait is over
(in test mode: until the test completed), as a W in a StepperDemo line means."""
BOARD_LOST = "board lost: {reason} - /reconnect restores the session"
BOARD_NOT_CONNECTED = "no board ({reason}) - /reconnect first; the line was not sent"
BOARD_SILENT_NOTHING = "no start banner, nothing received"
BOARD_SILENT_FOREIGN = "no start banner; {n} bytes received, no line of them StepperDemo's"
BOARD_NO_ANSWER = ("no answer from StepperDemo within {seconds:g} s of the first command "
                   "({why}): is the board running StepperDemo at {baud} baud? "
                   "(/reconnect PORT tries another port)")
BOARD_RESTARTED = "the board restarted (start banner): normal mode, M1 selected{dropped}"
BOARD_RESTART_DROPPED = "; {n} waiting command(s) dropped"
BOARD_RECONNECTED = "board back on {port}"
BOARD_RECONNECT_FAILED = "reconnect failed: {error}"
BOARD_RESET_SENT = "reset: {how}"
BOARD_RESET_DTR = "DTR pulsed"
BOARD_RESET_REOPEN = "port closed and opened again (no DTR line on it)"
BOARD_STOP_SENT = "stop: X sent to {steppers}{left}"
BOARD_STOP_LEFT_MODE = " (left {mode} mode first: X is a normal-mode command)"
BOARD_STOP_SPINNING = ("the board spins in W and reads nothing until the stepper stops; "
                       "/reset stops it now")
BOARD_NOT_ON_BOARD = "{cmd}: not on a board (its chip and clock are its own)"
BOARD_TIME = "session {t:.3f} s; {lines} lines received, {status} of them status lines"
BOARD_STATE = ("board: {mode} mode, M{selected} selected, status lines {verbose}, usage after "
               "stop {usage}; running: {running}; positions: {positions}")
BOARD_STATE_HELD = "input waits for the board: {why} ({n} command(s) queued)"
BOARD_ON = "on"
BOARD_OFF = "off"
BOARD_NONE = "-"
BOARD_TOOLBAR = " board {port} "
BOARD_TOOLBAR_STATUS = " {mode} mode | M{selected} | running {running} | {held}t={t:.1f}s | "
BOARD_TOOLBAR_HELD = "waits: {why} | "
BOARD_TOOLBAR_LOST = " LOST - /reconnect | "
LOG_HEADER = ("# stepperdemo {version} board log: {port} at {baud} baud, started {start}; "
              "seconds since the start, > sent, < received, # console")
LOG_SENT = "{t:10.3f} > {text}"
LOG_RECEIVED = "{t:10.3f} < {text}"
LOG_NOTE = "{t:10.3f} # {text}"
CLI_BOARD_CONNECT = "stepperdemo: cannot open the board at {port}: {error}"
CLI_BOARD_LOST = "stepperdemo: board lost: {reason}"
CLI_BOARD_NO_ANSWER = ("stepperdemo: no answer from StepperDemo at {port} within {seconds:g} s "
                       "of the first command ({why}): is the board running StepperDemo at "
                       "{baud} baud?")
CLI_BOARD_RESTARTED = "stepperdemo: the board restarted during the run (start banner)"
CLI_BOARD_INTERRUPTED = "stepperdemo: interrupted; stop sent (X to {steppers})"
CLI_BOARD_MAX_TIME = ("stepperdemo: stopped waiting after {seconds:g} s (--max-time): "
                      "the board was still busy ({why})")
CLI_BOARD_NO_PINS = ("--vcd and --steps-csv record the simulated pins; a board shows only "
                     "its text (--plot and --report work from its status lines)")
CLI_BOARD_NOT_DEMO = "--board: the board runs StepperDemo, not {program!r}"
CLI_BOARD_AND_PORT = "--board and --port exclude each other"
CLI_BOARD_TIMES = "--quiet-ms must be at least 50, --boot-wait not negative"
CLI_CONSOLE_NO_PORT = "--console serves a new pty: leave out --port"
BOARD_BUSY_WHY = {
    "input": "input still waiting to be sent", "W": "a W waits for the board's answer",
    "W stop": "a W waits for the stepper to stop", "W test": "a W waits for the test",
    "T": "the direct-drive test runs", "answer": "a command waits for its answer",
    "spinning": "the board spins in W", "pausing": "a w<ms> pause", "test": "a test runs",
    "motion": "a stepper runs: the table after its stop has not come",
    "output": "the board is printing",
}

# status-line plots and report (/plot, /report, --plot, --report on a board)
STATUS_REPORT_TITLE = ("status-line report: {source}, {start:.3f} .. {end:.3f} s, {lines} status "
                       "lines (one per 100 ms while a stepper runs and I is on)")
STATUS_REPORT_NONE = "  no status lines yet"
STATUS_REPORT_STEPPER = "M{n}  {lines} status lines, first {first:.3f} s, last {last:.3f} s"
STATUS_REPORT_POSITION = "  position     {start} -> {end} (net {net:+d}){final}"
STATUS_REPORT_FINAL = "; {final} in the last stepper table"
STATUS_REPORT_SPEED = ("  speed        peak {speed:.0f} steps/s planned (v=); acceleration up "
                       "to {acc}, deceleration up to {dec} steps/s^2 (slope of v= over the "
                       "lines of each ACC and RED stretch)")
STATUS_REPORT_RAMP = "  ramp         {states} (status lines per ramp state)"
STATUS_REPORT_RUNS = ("  runs         {runs}; {gaps} pause(s) of more than {gap_ms} ms between "
                      "lines while running (the board was busy: W, T, long prints)")

# stepperdemo run --board: scenario files on a board, and the twin check
RUN_NO_FOLDER = ("{option} {folder}: no folder {parent} to make it in (run makes the folder "
                 "itself, not the ones above it)")
RUN_BAD_FOLDER = "{option} {folder}: not a folder for the files: {error}"
RUN_NOT_A_FOLDER = "a file is there"
RUN_BOARD_HELP = ("run the scenario files on a board running StepperDemo (reset by DTR "
                  "between files) and compare with the simulation (twin check)")
RUN_BOARD_SKIPPED = "the board runs StepperDemo, not program {program!r}"
RUN_BOARD_OTHER_CHIP = ("{name}: skipped: written for {profile} (F_CPU={f_cpu} "
                        "TICKS_PER_S={ticks} Steppers={steppers}); the board's banner says "
                        "F_CPU={board_f_cpu} TICKS_PER_S={board_ticks} Steppers={board_steppers}")
RUN_BOARD_NO_ANSWER = ("stopped: no answer from StepperDemo at {port} ({why}) - is the board "
                       "running StepperDemo at this baud rate?")
BOARD_LOST_RUN = "board lost: {reason}"
RUN_BOARD_NO_BANNER = "no start banner within {seconds:g} s of the reset"
RUN_BOARD_PROFILE = "board banner F_CPU={f_cpu} TICKS_PER_S={ticks} Steppers={steppers}"
RUN_BOARD_NO_WATCH = ("--vcd, --steps-csv, --plot, --report and --timing-report read the "
                      "simulated pins; with --board there are none")
RUN_BOARD_PINS_NOTE = ("pulses, direction and enable counts, pulse and enable times are not "
                       "checked: a board shows only its text")
RUN_BOARD_MATCHES_NOTE = ("whole-transcript references are of the built-in-input firmware; "
                          "on a board (interactive firmware) only contains/not_contains apply")
RUN_TWIN_TITLE = "twin check: the board and the simulation for the same input"
RUN_TWIN_COLUMNS = ("scenario", "M", "board", "sim", "diff", "lines", "first dt", "last dt",
                    "max dt")
RUN_TWIN_CAPTION = ("positions in steps; lines: status lines on the board/simulation; dt: "
                    "status-line time board - simulation in s, from the first command sent "
                    "(first line, last line, largest of the pairs)")
RUN_TWIN_SUMMARY = ("twin check: {steppers} stepper(s), largest position difference {pos}, "
                    "largest status-line time difference {dt:.3f} s")
RUN_BOARD_END = {"idle": "idle", "max_time": "max time reached", "lost": "board lost",
                 "reset": "board restarted", "no_answer": "no answer from StepperDemo"}

# stepperdemo device --pty --console: the simulated StepperDemo firmware on a pty
CONSOLE_DEVICE_LISTENING = ("console device {profile} ({title}) on {path}{link}, clock "
                            "x{speed:g}: StepperDemo's text console, restarted whenever a host "
                            "opens the port; Ctrl-C ends")
CONSOLE_DEVICE_EVENT = "console: {event}"
CONSOLE_DEVICE_OPENED = "host opened the port: firmware restarted"
CONSOLE_DEVICE_CLOSED = "host closed the port"
CONSOLE_DEVICE_STATS = ("console: {resets} start(s), {rx} characters received ({dropped} lost: "
                        "receive buffer full), {tx} sent ({tx_unsent} not yet taken by the host)")
CONSOLE_DEVICE_POSITIONS = "console: positions {positions}"
# ------------------------------------------------------------ end of board console texts
# QuickStep planner (issue 14): config commands l/q/p/b, status and table additions,
# the input hold of a move that waits for FIFO room, report lines.  Console texts, not
# part of the firmware.
QS_PLANNER_FAS = "planner M{n}: FastAccelStepper ramp" + NL
QS_PLANNER_QS = ("planner M{n}: QuickStep, FIFO {depth} orders, {plateaus} plateaus, "
                 "base time {base} on timer {timer}" + NL)
QS_DEPTH = "FIFO depth M{n} = {depth} orders ({ram} of {avail} bytes of RAM in use)" + NL
QS_PLATEAUS = "plateaus M{n} = {plateaus}" + NL
QS_BASE_AUTO = "automatic"
QS_BASE_US = "{us} us"
QS_BASE_SET = "base time = {base} on timer {timer} ({bits} bit, {lo} .. {hi} us)" + NL
QS_ERR_NOT_AVAILABLE = "ERROR QuickStep needs a timer of its own: profile {profile} has none" + NL
QS_ERR_NO_TIMER = "ERROR timer {timer} cannot run QuickStep here (timers: {timers})" + NL
QS_ERR_BASE = ("ERROR base time {us} us outside timer {timer}'s {lo} .. {hi} us"
               " (0 = automatic)" + NL)
QS_ERR_DEPTH = "ERROR FIFO depth {value} outside 1 .. 255" + NL
QS_ERR_PLATEAUS = "ERROR plateaus {value} outside 1 .. 255" + NL
QS_ERR_RAM = ("ERROR FIFOs of {need} bytes (4 bytes x orders, all QuickStep steppers) exceed"
              " the {avail} bytes of RAM {profile} leaves for them" + NL)
QS_ERR_RUNNING = "ERROR M{n} is running: stop it first" + NL
QS_ERR_BUSY = "ERROR a QuickStep stepper is running: the base time changes at rest only" + NL
QS_ERR_SYNTAX = "ERROR {cmd}: give {what}" + NL
QS_HOLD = ("QuickStep FIFO of M{n} full: input held until the move is queued"
           " ({pending} orders waiting)" + NL)
QS_RELEASED = "QuickStep move queued" + NL
QS_STATUS = " QS {label}"
QS_TABLE = " planner=QuickStep fifo={used}/{depth} plateaus={plateaus} base={base}"
REPORT_PLATEAUS = "  plateaus     {n} order(s) at {periods} distinct period(s): {list}"
REPORT_PLATEAU_ITEM = "{steps}x{us}us"
REPORT_QS_TIMER = ("  QuickStep    timer {timer}, base time {base} us, {lost} period interrupt(s)"
                   " lost, {starts} start(s) from rest")
# ------------------------------------------------------------- end of QuickStep texts

# ---------------------------------------------------------------------------------------
# user outputs and G-code (issue 12): report and plot lines, the G-code program, its
# console mode and its command line.  Console texts, not part of the firmware.
REPORT_OUTPUT_DIGITAL = ("{name} (pin {pin})  {rises} rise(s), {falls} fall(s), high "
                         "{high_ms:.3f} ms in total, first change at {first} s, ends {level}")
REPORT_OUTPUT_PWM = ("{name} (pin {pin})  {periods} PWM periods: period {period} us "
                     "({hz:.6g} Hz, {pmin} .. {pmax} us), duty mean {duty:.4f} % "
                     "({dmin:.4f} .. {dmax:.4f} %), last {last:.4f} %")
REPORT_OUTPUT_PWM_FEW = ("{name} (pin {pin})  {rises} rise(s), {falls} fall(s), no complete "
                         "PWM period; ends {level}")
REPORT_LEVEL_HIGH = "high"
REPORT_LEVEL_LOW = "low"
PLOT_TITLE_OUTPUTS = "outputs [Dout level, Aout duty %]"
PLOT_TITLE_FEED = "feed along the path [units/min]"
PLOT_TERMINAL_OUTPUT = "{name} {what}"
PLOT_OUTPUT_LEVEL = "level"
PLOT_OUTPUT_DUTY = "duty [%]"
# the G-code program: Grbl 1.1's answers (issue 24: "ok", "error:N", "ALARM:N", the
# reason of a refusal in a [MSG:...] line before it; no reason text may contain "ok",
# "error:" or "ALARM:" - bCNC counts any line with those as an answer)
GCODE_BANNER = "Grbl 1.1h ['$' for help]"
GCODE_OK = "ok"
GRBL_ERROR = "error:{code}"
GRBL_ALARM = "ALARM:{code}"
GRBL_MSG = "[MSG:{text}]"
GRBL_HELP = "[HLP:$$ $# $G $I $N $x=val $Nx=line $J=line $SLP $C $X $H ~ ! ? ctrl-x]"
GRBL_UNLOCK_HINT = "[MSG:'$H'|'$X' to unlock]"
GCODE_UNLOCKED = GRBL_UNLOCKED = "[MSG:Caution: Unlocked]"
GRBL_ENABLED = "[MSG:Enabled]"
GRBL_DISABLED = "[MSG:Disabled]"
GRBL_CHECK_DOOR = "[MSG:Check Door]"
GRBL_PGM_END = "[MSG:Pgm End]"
GRBL_RESTORING = "[MSG:Restoring defaults]"
GRBL_SLEEPING = "[MSG:Sleeping]"
GRBL_ABORTED = "stopped at once by the console; the position may be lost"
GRBL_RESET_MOVING = "reset while moving; the position may be lost"
GCODE_DUTY = "[MSG:Aout{number} {duty:.4f}% ({count}/{counts} at {hz:.6g} Hz)]"
GCODE_MOTION_FAILED = "the library refused a queue command ({code}); stopping"
GCODE_ERR_LONG = "line longer than {n} characters"
GCODE_ERR_EXPECTED_LETTER = "expected a letter at '{text}'"
GCODE_ERR_BAD_NUMBER = "{letter} needs a number: '{text}' is not G-code"
GCODE_ERR_UNKNOWN_WORD = "unknown word {word}"
GCODE_ERR_NOT_INTEGER = "{word} needs a whole number"
GCODE_ERR_NEGATIVE = "{word} must not be negative"
GCODE_ERR_LINE_NUMBER = "line number beyond N9999999"
GCODE_ERR_REPEATED = "word {letter} twice in one line"
GCODE_ERR_UNSUPPORTED = "unsupported command {code}"
GCODE_ERR_MODAL = "{a} and {b} in one line (same modal group)"
GCODE_ERR_NO_AXIS = "axis {letter}: no stepper {n} (axes here: {axes})"
GCODE_ERR_AXIS_CONFLICT = "{a} and {b} both want the axis words"
GCODE_ERR_UNUSED = "unused word(s): {words}"
GCODE_ERR_P_CONFLICT = "P used by both {a} and {b}"
GCODE_ERR_DWELL_P = "G4 needs P (seconds)"
GCODE_ERR_G92_AXES = "G92 needs axis words"
GCODE_ERR_NO_FEED = "undefined feed rate: {code} needs F"
GCODE_ERR_G43 = "G43.1 takes the Z word only (the tool length offset is on Z)"
GCODE_ERR_G80_AXES = "axis words while G80 (no motion mode) is in effect"
GCODE_ERR_G53 = "G53 needs G0 or G1, not {code}"
GCODE_ERR_PROBE_AXES = "{code} needs axis words"
GCODE_ERR_PROBE_TARGET = "probe target is the present position"
GCODE_ERR_NO_PROBE = "{code}: {profile} has no probe input"
GCODE_PROBE_INITIAL = "probe fail: the probe is already in the state the cycle looks for"
GCODE_PROBE_NO_CONTACT = "probe fail: no contact by the end of the move"
GCODE_ERR_G10_AXES = "G10 needs axis words"
GCODE_ERR_G10_PL = "G10 needs L (2 or 20) and P (0..6)"
GCODE_ERR_G10_P = "G10 P{p}: coordinate systems are P0 (active), P1..P6 (G54..G59)"
GCODE_ERR_G10_L = "G10 L{l}: only L2 and L20"
GCODE_ERR_G10_R = "G10 L2 R (rotation) is not supported"
GCODE_ERR_ARC_PLANE = "arc in {plane}: this machine has axes {axes}"
GCODE_ERR_ARC_AXES = "an arc needs axis words"
GCODE_ERR_ARC_PLANE_AXES = "an arc in {plane} needs {a} or {b}"
GCODE_ERR_ARC_R_TARGET = "an R arc needs a target other than the start (a full circle needs I/J/K)"
GCODE_ERR_ARC_RADIUS = "arc radius R{r} is less than half the distance to the target ({d})"
GCODE_ERR_ARC_OFFSETS = "an arc in {plane} needs {a} or {b} (or R)"
GCODE_ERR_ARC_IJK = "arc radius to the start {r0} and to the target {r1} differ"
GCODE_ERR_RANGE = "{letter} target beyond the 32-bit step range"
GCODE_ERR_NEEDS_P = "{code} needs P (digital output 0..3)"
GCODE_ERR_NEEDS_EQ = "{code} needs {missing} (E: analog output 0..3, Q: duty in %)"
GCODE_ERR_OUTPUT_RANGE = "output {letter}{value} out of range (0..{last})"
GCODE_ERR_TOOL = "tool T{tool} above T{most}"
GCODE_ERR_ALARM = "alarm lock: $X to unlock (or ctrl-x)"
GCODE_ERR_JOGGING = "G-code waits while jogging (0x85 cancels the jog)"
GCODE_ERR_JOG_FORM = "a jog is $J=<axis words> F<rate>"
GCODE_ERR_JOG_STATE = "jogging only when Idle or jogging, not in {state}"
GCODE_ERR_JOG_CODE = "{code} is not allowed in a jog"
GCODE_ERR_JOG_AXES = "a jog needs axis words"
GCODE_ERR_JOG_FEED = "a jog needs F (units/min)"
GCODE_ERR_NO_OUTPUT_PIN = "{name} has no pin on {profile} (set one with ${setting})"
GCODE_ERR_OUTPUT_PIN_USED = "{name}: pin {pin} is used by {user}"
GCODE_ERR_NOT_PWM_PIN = "pin {pin} has no PWM timer on {profile}"
GCODE_ERR_FREQUENCY = "{timer} makes {low} .. {high} Hz, not {hz} Hz"
GCODE_ERR_OUTPUT_BUSY = "a synchronized change of {name} still waits: set its frequency after it"
GCODE_ERR_OUTPUT = "{name}: {code}"
GCODE_ERR_NO_DIR_PIN = "axis {letter} has no direction pin: it cannot move backward"
GCODE_ERR_SHARED_DIR = ("axes {a} and {b} share direction pin {pin}: they cannot move in "
                        "opposite directions in one line")
GCODE_ERR_DOLLAR = "unknown $ command '{text}' ($ for help)"
GCODE_ERR_SETTING_VALUE = "setting value '{text}' is not a number"
GCODE_ERR_NOT_IDLE = "not now: the machine is in {state}"
GCODE_ERR_SETTING_RANGE = "${n} must be {range}"
GCODE_ERR_SETTING_FIXED = "${n} is fixed at {value} on this machine"
GCODE_ERR_NO_SETTING = "no setting ${n}"
GCODE_ERR_STORED_LONG = "longer than {n} characters"
GCODE_ERR_STARTUP_DOLLAR = "a startup line is G-code, not a $ command"
GCODE_ERR_HOMING = "homing is not available: {profile} has no limit inputs here"
GCODE_ERR_SOFT_LIMITS = "soft limits need homing"
GCODE_ERR_LASER = "laser mode needs a spindle PWM output: {profile} has none (docs/gcode.md)"
GCODE_CLI_BAD_SET = "--set {text!r}: expected '$N=VALUE'"
GCODE_TCP_BUSY = "busy: another host is connected"
GCODE_TCP_BAD = "--tcp {text!r}: expected [HOST:]PORT"
GCODE_ENDPOINT_LISTENING = ("gcode: Grbl 1.1h on {path}{link}, {profile} ({title}), axes "
                            "{axes}, clock x{speed:g}; a host opening it resets it; Ctrl-C ends")
GCODE_ENDPOINT_DEVICE = ("gcode: Grbl 1.1h on {path}{link}, queue commands on the device at "
                         "{port} ({profile}), axes {axes}; Ctrl-C ends")
GCODE_ENDPOINT_EVENT = "gcode: {event}"
GCODE_HOST_OPENED = "host opened the port: reset"
GCODE_HOST_CLOSED = "host closed the port"
GCODE_ENDPOINT_STATS = ("gcode: {hosts} host(s), {lines} line(s), {errors} error(s), {alarms} "
                        "alarm(s); received {rx} bytes ({dropped} dropped: receive buffer full, "
                        "{high} dropped: >= 0x80), sent {tx} ({tx_dropped} with no host); "
                        "the chip fell {lag:.3f} s behind the clock")
GCODE_ENDPOINT_POSITIONS = "gcode: MPos {mpos}, state {state}"
GCODE_CLI_ENDPOINT_FILE = "--pty/--tcp serve senders: give no FILE (they send the program)"
GCODE_CLI_TOML = ("{path} is a scenario file, not G-code: run it with 'stepperdemo run {path}'"
                  "{program}")
GCODE_CLI_TOML_PROGRAM = " (its G-code: {file})"
GCODE_ERR_TIMER_QUICKSTEP = "{name}: {timer} runs the QuickStep planner (l0 frees it)"
GCODE_ERR_QUICKSTEP_AXIS = ("axis {letter} runs the QuickStep planner: G-code moves need "
                            "FastAccelStepper's queue (l0 in config mode)")
ENTER_GCODE_MODE = ("Enter G-code mode (Grbl 1.1: a block ends at a line end; x alone on a "
                    "line leaves)" + NL)
GCODE_UNENDED_LINE = ("not executed: '{text}' has no line end (a block ends at LF or CR; "
                      "in -c write $'...\\n...')")
QS_ERR_TIMER_PWM = "ERROR timer {timer} makes the PWM of a user output: no QuickStep on it" + NL
# ----------------------------------------------------------- end of issue 12 texts

# ------------------------------------------------ issue 11: the firmware in simavr
DEVICE_SIMAVR_TITLE = "firmware {elf} in simavr, {baud} baud"
DEVICE_SIMAVR_SUMMARY = "{line}"
DEVICE_SIMAVR_BUILD_FAILED = "stepperdemo device --simavr: {error}"
DEVICE_SIMAVR_BUILDING = ("stepperdemo device --simavr: building the {what} in {where} "
                          "(the first time only; a few seconds)")
DEVICE_SIMAVR_OPTION = "--{option} applies to the simulated device (--pty/--port), not --simavr"
# ------------------------------------------------- end of issue 11 texts
# ---------------------------------------------------------------------------------------
# serial link planning and stops (issue 18)
SERIAL_PLANNING = ("planning: {extra_ms} ms beyond the library's ({how}: round trip "
                   "{rtt_ms:.1f} ms, {rounds} retransmission round(s), {loss_pct:.1f} % "
                   "frames lost); device queue {queue_len} entries, {window} frames of "
                   "{payload} bytes in flight")
SERIAL_BAD_PLANNING = "{ms} is not a time of 0 .. 10000 ms"
SERIAL_DEVICE_REPAIRS = ("device: {frames_held} frames held after a gap, {cuts} queue cuts "
                         "({cuts_refused} refused), {halts} halts, {discarded} discarded")
# ------------------------------------------------------------ end of issue 18 texts

# ---------------------------------------------------------------------------------------
# issue 17: StepperDemo on the other platforms of FastAccelStepper 1.2.7
# start-up prompt for a pin configuration (ESP32, Pico), byte-exact as the firmware
SELECT_PIN_CONFIG = "Select pin configuration:"
# --pin-config / a scenario's pin_config (issue 23): refused with one line
PIN_CONFIG_HELP = ("answer StepperDemo's start-up prompt (ESP32, Pico) with this pin "
                   "configuration, as upstream's hardware tests do: 0 Test-HW, 1 Driver-Types "
                   "(default: no answer; -c waits the 5 s and takes 0)")
PIN_CONFIG_NONE = ("--pin-config: StepperDemo for {arch} offers no pin configurations "
                   "(only the ESP32 and Pico builds ask)")
PIN_CONFIG_RANGE = "--pin-config {index}: StepperDemo for {arch} offers {names}"
PIN_CONFIG_PROGRAM = "--pin-config: only StepperDemo has pin configurations, not {program}"
CONFIG_ENTRY_INDENT = "  "
CONFIG_ENTRY_SEP = ": "
PRESS_NUMBER_TO_SELECT = "Press number to select, else 0"
USING_CONFIG = "Using config "
ESP32_LOG_START = "LOG start\r\n"  # printf() through the ESP-IDF console (CR LF)
ESP_IDF = "ESP-IDF: "
ESP_RESTART = "ESP restart"
ESP_RESET = "ESP reset"
# status line and stepper table (ESP32)
PCNT_OPEN = " ["
PCNT_CLOSE = "]"
DRIVER_TYPE_SEP = " "
# the console could not do what the firmware does (e.g. restart a device behind --port)
RESTART_UNSUPPORTED = "(restart is not possible on this backend: {reason})"

# usage lines of the other builds, our words (the AVR text above keeps its length)
_USAGE_ESP32_LINES = [
    "    r         ... restart the chip (ESP.restart())",
    "    reset     ... reset the chip by its watchdog",
    "    p<n>      ... attach pulse counter n (n<=7)",
    "    p<n>,l,h  ... attach pulse counter n (n<=7), limits low,high",
    "    pc        ... clear the pulse counter",
]
_SMALL_BUILD_DROPS = ("    W ", "    w<ms>", "    + ", "    - ", "    T ", "    t ", "    u ")
_AVR_ONLY = ("    r         ... stray",)


def usage_normal(*, esp32: bool, avr: bool, small: bool) -> str:
    """The normal-mode usage of one build of the firmware (the AVR text is
    :data:`USAGE_NORMAL`).  As in the firmware, ESP32 builds list the pulse-counter
    commands even where the chip has none."""
    if avr and not small:
        return USAGE_NORMAL
    lines = []
    for line in _USAGE_NORMAL_LINES:
        if small and line.startswith(_SMALL_BUILD_DROPS):
            continue
        if not avr and line.startswith(_AVR_ONLY):
            continue
        if esp32 and line.startswith("    t "):
            lines.extend(_USAGE_ESP32_LINES)
        lines.append(line)
    return NL.join(lines) + NL + NL

# issue 13: the helix winder (stepperdemo winder), seed 002.  Its own texts, not the
# firmware's: plain lines, errors begin with "ERROR".
WINDER_BANNER = ("Helix winder {version} on {profile}: S1 spindle step {s1_step} dir {s1_dir}, "
                 "S2 traverse step {s2_step} dir {s2_dir}")
WINDER_INPUTS = ("inputs: pots A0 (pin {a0}) -> S1, A1 (pin {a1}) -> S2; limits of S2: "
                 "A2 (pin {a2}) lower, A3 (pin {a3}) upper; A4 (pin {a4}) fixture; "
                 "A5 (pin {a5}) spare")
WINDER_FIXTURE_MODE = "A4 closed at power-up: fixture mode, the pots drive S1 and S2"
WINDER_LINK_MODE = "A4 open at power-up: link mode, the pots rest until 'pots'"
WINDER_BAD_PROFILE = "the winder needs {why}; profile {profile} does not have them"
WINDER_UNKNOWN = "ERROR unknown command '{text}' (help: ?)"
WINDER_NEEDS = "ERROR {usage}: missing value"
WINDER_ERROR = "ERROR {cmd}: {problem}"
WINDER_BAD_STEPPER = "stepper '{word}' is not 1 or 2"
WINDER_BAD_COUNT = "count '{word}' is not a whole number -{max}..{max}"
WINDER_BAD_PERIOD = "period '{word}' is not {lo}..{hi} counts of 4 us"
WINDER_BAD_ACCEL = "acceleration '{word}' is not 1..{hi} steps/s^2"
WINDER_BAD_BOOL = "'{word}' is not 0 or 1"
WINDER_BAD_RATIO = "'{word}' is not n:m with 1 <= n <= m <= {hi}"
WINDER_BAD_POT = "value '{word}' is not 0..{hi}"
WINDER_BAD_SWITCH = "'{word}' is not a switch: A2, A3, A4 or A5"
WINDER_BAD_POSITION = "'{words}' are not two positions"
WINDER_TRAVERSE_SAME = "the two ends are the same position"
WINDER_BLOCKED = "{name} is at its {which} limit (A{a} closed); it may only move away"
WINDER_INPUTS_ARE_PINS = "on a device the {what} are its pins; turn or press the real ones"
WINDER_UPPER = "upper"
WINDER_LOWER = "lower"
WINDER_MOVE = ("{name} move {count:+d} steps to {target} at period {counts} "
               "({speed:.0f} steps/s), link control")
WINDER_MOVE_RUN = ("{name} runs {way} until told at period {counts} ({speed:.0f} steps/s), "
                   "link control")
WINDER_MOVE_STOP = "{name} stops"
WINDER_PERIOD = "{name} period {counts} counts = {us} us ({speed:.0f} steps/s)"
WINDER_ACCEL = "{name} acceleration {accel} steps/s^2"
WINDER_LINK_CONTROL = "{name}: link control (pots again with 'pots')"
WINDER_POTS = "pots in control: A0 drives S1, A1 drives S2"
WINDER_INTERLOCK_ON = "interlock on: S2 follows S1 at {n}:{m} while A1 is centred"
WINDER_INTERLOCK_OFF = "interlock off"
WINDER_INTERLOCK_OFF_BY_LINK = "interlock off: S2 is under link control"
WINDER_INTERLOCK_ENGAGED = ("interlock engaged: S2 follows S1 at {n}:{m} "
                            "(from S1 @{x0}, S2 @{s2})")
WINDER_INTERLOCK_RELEASED = "interlock released: S2 moves on its own"
WINDER_INTERLOCK_FAILED = "ERROR interlock: {why}; interlock off"
WINDER_RATIO = "ratio {n}:{m} (S2 steps per S1 steps)"
WINDER_POT = "A{a} = {value}: {what}"
WINDER_POT_OFF = "{name} off (dead zone 462..562)"
WINDER_POT_RULE = ("{name} {way} {speed:.1f} steps/s -> period {counts} counts "
                   "({real:.1f} steps/s)")
WINDER_SWITCH = "A{a} {state} ({role})"
WINDER_SWITCH_ROLES = {2: "S2 lower limit", 3: "S2 upper limit", 4: "fixture switch",
                       5: "spare input"}
WINDER_SWITCH_NAMES = {2: "LimitLow", 3: "LimitHigh", 4: "Fixture", 5: "Spare"}
WINDER_STOPPED = "{name} stopped at {position}"
WINDER_HELD_AT_LIMIT = "{name} held: its limit A{a} is closed"
WINDER_HOLD = "{name} waits for A{a} to be centred before its pot drives it again"
WINDER_LIMIT_STOP = "A{a}: S2 stopped at its {which} limit, position {position}{then}"
WINDER_LIMIT_TURN = "; the traverse turns round"
WINDER_LIMIT_STOP_BOTH = ("A{a}: S2 stopped at its {which} limit, interlocked S1 with it "
                          "(S1 @{s1}, S2 @{s2}); interlock off")
WINDER_TRAVERSE = ("traverse: S2 between {a} and {b}, start {start:.0f} steps/s, "
                   "acceleration {accel} steps/s^2, top {top:.0f} steps/s, replanned every 50 ms")
WINDER_TRAVERSE_DONE = "traverse ended at {position}"
WINDER_CTL_FOLLOW = "interlock {n}:{m}"
WINDER_CTL_TRAVERSE = "traverse"
WINDER_CTL_POT = "pot A{a}"
WINDER_CTL_HOLD = " (held until centred)"
WINDER_CTL_LINK = "link"
WINDER_ENGAGED = " (engaged)"
WINDER_STATUS_AXIS = ("{name} {role:<8} @{position:<10} {speed:>9.1f} steps/s  control {control}"
                      "  period {counts}  accel {accel}")
WINDER_STATUS_INPUTS = "inputs: {pots}  {switches}"
WINDER_STATUS_MODE = "power-up mode {mode}; interlock {interlock}, ratio {n}:{m}{engaged}"
WINDER_HELP_HEAD = "Helix winder commands (s = stepper 1 or 2; several per line):"
WINDER_HELP_MOVE = "move s by count steps (+-65535: run until told, 0: stop)"
WINDER_HELP_PERIOD = "link step period of s in 4 us counts, 9..65535"
WINDER_HELP_ACCEL = "acceleration of s for all its speed changes"
WINDER_HELP_INTERLOCK = "S2 follows S1 at the ratio while A1 is centred"
WINDER_HELP_RATIO = "S2 steps per S1 steps, 1 <= n <= m"
WINDER_HELP_POTS = "give both steppers back to the pots"
WINDER_HELP_TRAVERSE = "S2 end to end continuously (stop: move 2 0)"
WINDER_HELP_STATUS = "positions, speeds, control, inputs"
WINDER_HELP_POT = "simulation: turn pot A0 (s=1) or A1 (s=2)"
WINDER_HELP_SWITCH = "simulation: close (1) or open (0) a switch"
WINDER_HELP_RESET = "power cycle (A4 read again, positions 0)"
WINDER_HELP_HELP = "this list"
WINDER_HELP_WAIT = "wait ms before the next command"
WINDER_REPORT_INTERLOCK = ("interlock    {spans} stretch(es) at {ratios}: max |S2 - ratio x S1| = "
                           "{error:.3f} steps by the pins ({instants} step instants, worst at "
                           "{at}); {commands} S2 commands + {pauses} pauses, {late} step(s) "
                           "outside their window")
WINDER_REPORT_NO_INTERLOCK = "interlock    not engaged in this run"
WINDER_CLI_DESCRIPTION = """\
The helix winder on the fas library: S1 (spindle) and S2 (traverse), two pots,
four switches and a link.

Without -c: an interactive console (history, completion, a toolbar with the pots,
switches, control and interlock).  With -c: one line of commands on virtual time,
e.g.  stepperdemo winder -c "pots pot 1 1023 w2000 pot 1 512 w1000" --report
(a pipe or a file on standard input runs the same way).

Commands (s = stepper 1 or 2; several per line, separated by spaces):
  move s count      link move, -65535..65535 (+-65535 until told, 0 stops)
  period s counts   link step period in 4 us counts, 9..65535 (default 250)
  accel s a         acceleration for all speed changes (default 50000 steps/s^2)
  interlock 0|1     S2 follows S1 at the ratio while A1 is centred
  ratio n:m         S2 steps per S1 steps, 1 <= n <= m
  pots              the pots drive again (a link command makes link control sticky)
  traverse from to  S2 end to end continuously (trapezoid replanned every 50 ms)
  status, ?, reset, w<ms>
  pot s 0..1023     simulation: turn A0 (S1) or A1 (S2); dead zone 462..562,
                    log scale 10 .. 20 000 steps/s as a 4 us period
  switch An 0|1     simulation: A2/A3 S2's lower/upper limit, A4 fixture (read at
                    power-up / reset), A5 spare

On a device (--port) the pots and switches are its pins A0..A5, reported by the
device; the limits stop S2 on the device itself.  A simulated device (stepperdemo
device --pty or --simavr) takes pot and switch on its simulated pins; a board
refuses them.

exit codes: 0 ok, 2 bad arguments, 3 --max-time reached, 5 device lost"""
DEVICE_INPUT_SET = "device: input {text}"
WINDER_WAY = {True: "forward", False: "backward"}
WINDER_SWITCH_STATE = {True: "closed", False: "open"}
WINDER_ON_OFF = {True: "on", False: "off"}
WINDER_MODE = {True: "fixture", False: "link"}
WINDER_ROLES = ("spindle", "traverse")
WINDER_STATUS_POT = "A{a} {value}"
WINDER_STATUS_SWITCH = "A{a} {state}"
WINDER_HELP_LINE = "  {text:<22} {hint}"
WINDER_TOOLBAR_POT = "A{a}={value}"
WINDER_TOOLBAR_SWITCH = "A{a}{mark}"  # mark: # closed, - open
WINDER_TOOLBAR_AXIS = "{name}:{control}"
WINDER_TOOLBAR_LOCK = "interlock {state} {n}:{m}{engaged}"
WINDER_TOOLBAR_ENGAGED = " engaged"
WINDER_TOOLBAR = "{pots} | {switches} | {axes} | {lock}"
WINDER_VCD_SWITCH = "A{a}_{name}"
# ------------------------------------------------------------- end of winder texts

# ---------------------------------------------------------------------------------------
# issue 22: the chip sheet (python -m stepperdemo.chip_sheet): one chip's figures by room
CHIP_SHEET_LIST = "{name:<20} {title}"
CHIP_SHEET_HEADER = "{name}: {title}"
CHIP_SHEET_ROOM = "[{room}] {module}"
CHIP_SHEET_FIGURE = "  {field} = {value}"
CHIP_SHEET_NONE = "  (none: this chip has no {room} table)"
CHIP_SHEET_ERROR = "chip_sheet: {error}"
# ----------------------------------------------------------- end of issue 22 texts

# ---------------------------------------------------- subcommands (stepperdemo.subcommands)
# per subcommand: how the help lists it, and what it does (lines beside it)
SUBCOMMAND_WINDER = ("stepperdemo winder [options]",
                     "the helix winder: two steppers, pots, switches (--help)")
SUBCOMMAND_RUN = ("stepperdemo run FILES|FOLDERS ...",
                  "run scenario files (sequences/*.toml);\n"
                  "--board DEVICE: on a board, with the twin check")
SUBCOMMAND_DEVICE = ("stepperdemo device --pty",
                     "a simulated device on a new pty (--help);\n"
                     "--console: the simulated StepperDemo firmware")
SUBCOMMAND_RELAY = ("stepperdemo relay DEVICE", "a fault-injecting relay to a device (--help)")
SUBCOMMAND_GCODE = ("stepperdemo gcode FILE|-", "run G-code (user outputs M62-M68; --help)")
SUBCOMMAND_LINE = "  {usage:<35} {text}"  # a line of the help's list (further ones: no usage)
