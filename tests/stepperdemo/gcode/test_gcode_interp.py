"""G-code parsing and interpretation: words, modal state, actions, bad input."""

import pytest

from stepperdemo.gcode.interp import Dwell, End, Interpreter, Move, SetOutput
from stepperdemo.gcode.parser import GcodeError, parse_line
from stepperdemo.gcode.settings import GcodeSettings


def interp(axes: int = 3, **settings) -> Interpreter:
    st = GcodeSettings()
    for key, value in settings.items():
        setattr(st, key, value)
    return Interpreter(axes, st)


def run(it: Interpreter, line: str):
    return it.interpret(parse_line(line))


def test_words_ignore_case_spaces_comments_and_line_numbers():
    b = parse_line("n10 g1x 10.5 (move) y-2 ; the rest")
    assert b.g == [1.0] and b.values == {"X": 10.5, "Y": -2.0}
    assert parse_line("%").empty and parse_line("  ").empty and parse_line("/G1 X9").empty
    assert parse_line("G1X.5").values == {"X": 0.5}


@pytest.mark.parametrize("line, reason", [
    ("G1 X1 X2", "word X twice in one line"),
    ("G1 Xabc", "X needs a number"),
    ("G1 X", "X needs a number"),
    ("S1000", "unknown word S1000"),
    ("G1 X1 (open", "comment not closed"),
    ("G1 X1 N10", "N (line number) must come first"),
    ("1 X5", "expected a letter"),
    ("X" + "1" * 300, "line longer than 256"),
])
def test_malformed_lines_are_refused_with_a_reason(line, reason):
    with pytest.raises(GcodeError) as exc:
        run(interp(), line)
    assert reason in str(exc.value)


@pytest.mark.parametrize("line, reason", [
    ("G2 X1", "unsupported command G2"),
    ("M3", "unsupported command M3"),
    ("G20", "G20 (inches) is not supported"),
    ("G0 G1 X1", "G0 and G1 in one line"),
    ("G90 G91", "G90 and G91 in one line"),
    ("M62 M63 P1", "M62 and M63 in one line"),
    ("G1 X10", "undefined feed rate"),
    ("G1 X10 F0", "F must be positive"),
    ("G4", "G4 needs P"),
    ("G4 P-1", "must not be negative"),
    ("M62", "M62 needs P"),
    ("M65 P4", "output P4 out of range (0..3)"),
    ("M63 P1.5", "out of range"),
    ("M67 E1", "M67 needs Q"),
    ("M68 Q5", "M68 needs E"),
    ("M67 E-1 Q5", "output E-1 out of range"),
    ("G1 X1 F100 P3", "unused word(s): P"),
    ("Q5", "unused word(s): Q"),
    ("G4 M62 P0", "P used by both G4 and M62"),
    ("G92 G1 X5", "G92 and G1 both want the axis words"),
    ("G92", "G92 needs axis words"),
    ("A10", "axis A: no stepper 4"),
])
def test_invalid_blocks_are_refused(line, reason):
    with pytest.raises(GcodeError) as exc:
        run(interp(), line)
    assert reason in str(exc.value)


def test_a_refused_block_changes_no_modal_state():
    it = interp()
    run(it, "G1 X10 F600")
    with pytest.raises(GcodeError):
        run(it, "G91 F50 M65 P9")
    assert it.absolute and it.feed == 600 and it.position_steps == [10, 0, 0]


def test_absolute_incremental_and_modal_motion():
    it = interp()
    (m,) = run(it, "G0 X100 Y50")
    assert isinstance(m, Move) and m.rapid and m.target == (100, 50, 0)
    assert run(it, "G91") == []
    (m,) = run(it, "X-30")  # modal G0, incremental
    assert m.target == (70, 50, 0) and m.start == (100, 50, 0) and m.rapid
    (m,) = run(it, "G1 Z5 F1200")
    assert not m.rapid and m.feed == 1200 and m.target == (70, 50, 5)
    assert run(it, "G90 X70") == []  # no motion: already there


def test_steps_per_unit_rounds_to_the_nearest_step():
    it = interp(steps_per_unit=[80.0, 80.0, 400.0, 1, 1, 1])
    (m,) = run(it, "G0 X1.2345 Z-0.0013")
    assert m.target == (99, 0, -1)  # 98.76 -> 99, -0.52 -> -1


def test_g92_sets_the_current_position_as_an_offset():
    it = interp()
    run(it, "G0 X100")
    assert run(it, "G92 X0") == []
    (m,) = run(it, "G0 X10")  # work 10 = machine 110
    assert m.target == (110, 0, 0)
    assert it.work_position([110, 0, 0]) == [10.0, 0.0, 0.0]
    run(it, "G92.1")
    (m,) = run(it, "X10")
    assert m.target == (10, 0, 0)


def test_actions_come_in_execution_order():
    it = interp()
    acts = run(it, "G1 X5 F100 M62 P1 M2")
    assert [type(a) for a in acts] == [SetOutput, Move, End]
    out = acts[0]
    assert (out.analog, out.number, out.value, out.synchronized) == (False, 1, 1.0, True)
    acts = run(it, "G4 P0.25 M68 E2 Q150")
    assert isinstance(acts[0], SetOutput) and isinstance(acts[1], Dwell)
    assert acts[0].value == 150 and not acts[0].synchronized and acts[1].seconds == 0.25


def test_end_of_program_resets_distance_mode_and_offsets():
    it = interp()
    run(it, "G91 G92 X5")
    run(it, "M30")
    assert it.absolute and it.offset == [0.0, 0.0, 0.0] and it.motion == 1


def test_the_check_hook_can_refuse_a_block_before_it_takes_effect():
    it = interp()

    def refuse(action):
        if isinstance(action, Move):
            raise GcodeError("no")

    it.check = refuse
    with pytest.raises(GcodeError):
        run(it, "G91 G0 X5")
    assert it.absolute and it.position_steps == [0, 0, 0]
