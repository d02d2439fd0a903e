"""G-code parsing and interpretation: words, modal state, actions, bad input."""

import pytest

from stepperdemo.gcode.interp import Dwell, End, Interpreter, Move, Pause, SetOffset, SetOutput
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
    assert b.g == [1.0] and b.values == {"N": 10.0, "X": 10.5, "Y": -2.0}
    assert parse_line("  ").empty and parse_line("/G1 X9").values == {"X": 9.0}
    assert parse_line("G1X.5").values == {"X": 0.5}
    assert parse_line("G1 X1 (open").values == {"X": 1.0}  # Grbl: no error for it


def code_of(line: str, axes: int = 3) -> tuple[int, str]:
    with pytest.raises(GcodeError) as exc:
        run(interp(axes), line)
    return exc.value.code, str(exc.value)


@pytest.mark.parametrize("line, code, reason", [
    ("G1 X1 X2", 25, "word X twice in one line"),
    ("G1 Xabc", 2, "X needs a number"),
    ("G1 X", 2, "X needs a number"),
    ("HELLO WORLD", 2, "H needs a number: 'HELLOWORLD' is not G-code"),
    ("%", 1, "expected a letter at '%'"),
    ("1 X5", 1, "expected a letter"),
    ("D5", 20, "unknown word D5"),
    ("G1 F-5", 4, "F-5 must not be negative"),
    ("N99999999 G0", 27, "line number"),
    ("G1.5 X1", 23, "G1.5 needs a whole number"),
    ("M62.5 P1", 23, "M62.5 needs a whole number"),
    ("T300", 38, "tool T300 above T255"),
])
def test_malformed_lines_are_refused_with_grbls_number(line, code, reason):
    assert code_of(line)[0] == code
    assert reason in code_of(line)[1]


@pytest.mark.parametrize("line, code, reason", [
    ("G2 X1 Y1 I5", 22, "undefined feed rate: G2 needs F"),
    ("G64", 20, "unsupported command G64"),
    ("M3 M5", 21, "M3 and M5 in one line"),
    ("G0 G1 X1", 21, "G0 and G1 in one line"),
    ("G90 G91", 21, "G90 and G91 in one line"),
    ("M62 M63 P1", 21, "M62 and M63 in one line"),
    ("G1 X10", 22, "undefined feed rate"),
    ("G1 X10 F0", 22, "undefined feed rate"),
    ("G4", 28, "G4 needs P"),
    ("G4 P-1", 4, "must not be negative"),
    ("M62", 28, "M62 needs P"),
    ("M65 P4", 39, "output P4 out of range (0..3)"),
    ("M63 P1.5", 39, "out of range"),
    ("M67 E1", 28, "M67 needs Q"),
    ("M68 Q5", 28, "M68 needs E"),
    ("M67 E-1 Q5", 39, "output E-1 out of range"),
    ("G1 X1 F100 P3", 36, "unused word(s): P"),
    ("Q5", 36, "unused word(s): Q"),
    ("G1 X1 F100 I5", 36, "unused word(s): I"),
    ("G4 M62 P0", 28, "P used by both G4 and M62"),
    ("G92 G1 X5", 24, "G92 and G1 both want the axis words"),
    ("G92", 26, "G92 needs axis words"),
    ("A10", 20, "axis A: no stepper 4"),
])
def test_invalid_blocks_are_refused_with_grbls_number(line, code, reason):
    got, text = code_of(line)
    assert (got, reason in text) == (code, True), text


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
    assert [type(a) for a in run(it, "G92 X0")] == [SetOffset]
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
    assert [type(a) for a in run(it, "G92 X0 M0")] == [SetOffset, Pause]
    out = acts[0]
    assert (out.analog, out.number, out.value, out.synchronized) == (False, 1, 1.0, True)
    acts = run(it, "G4 P0.25 M68 E2 Q150")
    assert isinstance(acts[0], SetOutput) and isinstance(acts[1], Dwell)
    assert acts[0].value == 150 and not acts[0].synchronized and acts[1].seconds == 0.25


def test_end_of_program_resets_distance_mode_and_keeps_the_offsets_as_grbl():
    it = interp()
    run(it, "G91 G92 X5")
    run(it, "M30")
    assert it.absolute and it.offset == [-5.0, 0.0, 0.0] and it.motion == 1


def test_the_check_hook_can_refuse_a_block_before_it_takes_effect():
    it = interp()

    def refuse(action):
        if isinstance(action, Move):
            raise GcodeError(33, "no")

    it.check = refuse
    with pytest.raises(GcodeError):
        run(it, "G91 G0 X5")
    assert it.absolute and it.position_steps == [0, 0, 0]


def test_jogs_take_only_their_words_and_change_no_modal_state():
    it = interp()
    run(it, "G1 X5 F100")
    move = it.jog(parse_line("G91 X10 Y-3 F3000"))
    assert move.jog and move.target == (15, -3, 0) and move.feed == 3000
    assert it.absolute and it.feed == 100 and it.motion == 1
    assert it.jog(parse_line("G53 X0 Y0 F100")).target == (0, 0, 0)  # machine coordinates
    for words, code in (("X1", 22), ("F100", 26), ("G1 X1 F100", 16), ("M3 X1 F9", 16),
                        ("X1 F100 S5", 36), ("G20 G21 X1 F1", 21)):
        with pytest.raises(GcodeError) as exc:
            it.jog(parse_line(words))
        assert exc.value.code == code, words


def test_spindle_speed_and_tool_are_kept_for_the_report():
    it = interp()
    assert run(it, "S1000 T3") == []
    assert (it.spindle_speed, it.tool) == (1000, 3)
    it.reset()
    assert (it.spindle_speed, it.tool, it.feed, it.motion) == (0, 0, 0, 0)


def test_the_plain_move_shortcuts_read_a_line_as_the_general_path_does():
    """parse_line's words written out (a G/M code that is a whole number) and
    Interpreter._plain_move (G0/G1 with axis words, F, N) are shortcuts of the general
    reading: the same block, the same actions (equal Move blocks), the same errors and
    modal state as with the shortcut off - G20, G91, G54 offsets, G92, N, bad feeds."""
    import random

    lines = ["G21 G90", "G1 X10 Y5 F600", "X20", "G0 Y-3.5", "G91 X1.5 Y1", "G90", "N10 G1 X5",
             "G20", "G1 X1 F10", "Y0.5 Z0.25", "G21", "G10 L2 P1 X5 Y5", "G54 G1 X1 F300",
             "G92 X0 Y0", "G1 X2", "G92.1", "G1 X-4 F0", "G1 X1 X2", "G1.00001 X3",
             "G0.5 X1", "G1 X99999999999", "G93 G1 X5 F2", "G94 G1 X6 F100", "M2"]
    rng = random.Random(7)
    for _ in range(200):
        lines.append(rng.choice(["G0", "G1", ""]) + "".join(
            f" {a}{rng.uniform(-50, 50):.4f}" for a in rng.sample("XYZ", rng.randint(1, 3)))
            + (f" F{rng.choice([0, 300, 6000])}" if rng.random() < 0.3 else ""))

    def outcome(it: Interpreter, line: str):
        try:
            actions = run(it, line)
        except GcodeError as exc:
            return ("error", exc.code, str(exc))
        return actions, it.position_steps, it.position, it.feed, it.motion, it.offset

    fast, general = interp(), interp()
    # the shortcut off: every line read word by word
    general._plain_move = lambda block: None  # type: ignore[method-assign]  # noqa: SLF001 - the shortcut under test
    taken = 0
    plain = fast._plain_move  # noqa: SLF001 - counted: the shortcut under test

    def counted(block):
        nonlocal taken
        actions = plain(block)
        taken += actions is not None
        return actions

    fast._plain_move = counted  # type: ignore[method-assign]  # noqa: SLF001 - (as above)
    for line in lines:
        assert outcome(fast, line) == outcome(general, line), line
    assert taken > 150  # the shortcut was taken for most of them
    # the G/M words: the same block as _take_word makes of them
    assert parse_line("G1.00001X2").g == [1.0] and parse_line("M3S5").m == [3.0]
    with pytest.raises(GcodeError) as exc:
        parse_line("G0.5X1")
    assert exc.value.code == 23
