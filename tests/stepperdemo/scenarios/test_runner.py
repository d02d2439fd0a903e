"""`stepperdemo run`: results, broken files, JSON, exit codes."""

import json

from stepperdemo.front.cli import main
from stepperdemo.scenarios.runner import EXIT_FAILED, EXIT_OK, run_file
from stepperdemo.scenarios.scenario import ScenarioError, load

GOOD = """
name = "good"
input = "M1 A1000 V100 R300 W"
[steppers.A]
position = 300
pulses = 300
[transcript]
contains = ["Move steps 300"]
"""

WRONG = """
name = "wrong"
input = "M1 A1000 V100 R300 W"
[steppers.A]
position = 301
tol = { position = 0 }
"""


def write(tmp_path, name, text):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_good_scenario_passes(tmp_path):
    res = run_file(write(tmp_path, "good.toml", GOOD))
    assert res.ok and res.error is None
    assert {c.what for c in res.checks} >= {"A position", "A pulses", "transcript contains"}


def test_the_program_key_names_the_program_that_runs_the_input(tmp_path):
    sc = load(write(tmp_path, "prog.toml", 'program = "demo"\n' + GOOD))
    assert sc.program == "demo"
    assert run_file(sc.path).ok


def test_wrong_expectation_fails_with_the_deviation(tmp_path):
    res = run_file(write(tmp_path, "wrong.toml", WRONG))
    assert not res.ok
    check = [c for c in res.checks if c.what == "A position"][0]
    assert check.measured == 300 and check.deviation == -1


def test_broken_files_name_file_and_key(tmp_path):
    cases = {
        "nokey.toml": ('name = "x"\n', "input"),
        "badkey.toml": ('name = "x"\ninput = "M1"\nspeed = 3\n', "speed"),
        "badtype.toml": ('name = "x"\ninput = "M1"\n[steppers.A]\nposition = "far"\n',
                         "steppers.A.position"),
        "badtoml.toml": ('name = "x\n', "-"),
        "badprofile.toml": ('name = "x"\ninput = "M1"\nprofile = "z80"\n', "profile"),
        "badprogram.toml": ('name = "x"\ninput = "M1"\nprogram = "tetris"\n', "program"),
    }
    for fname, (text, key) in cases.items():
        p = write(tmp_path, fname, text)
        try:
            load(p)
        except ScenarioError as exc:
            assert exc.key == key and fname in str(exc)
        else:
            raise AssertionError(f"{fname} loaded")


def test_cli_runs_folders_reports_json_and_keeps_going_after_a_broken_file(tmp_path, capsys):
    write(tmp_path, "a_good.toml", GOOD)
    write(tmp_path, "b_broken.toml", 'name = "b"\n')
    write(tmp_path, "c_good.toml", GOOD.replace('"good"', '"good2"'))
    rc = main(["run", str(tmp_path), "--json"])
    out = json.loads(capsys.readouterr().out)
    assert rc == EXIT_FAILED
    assert [r["name"] for r in out] == ["good", "b_broken", "good2"]
    assert out[0]["ok"] and out[2]["ok"] and not out[1]["ok"]
    assert "b_broken.toml: input: missing" in out[1]["error"]


def test_cli_exit_code_zero_when_all_pass(tmp_path, capsys):
    write(tmp_path, "good.toml", GOOD)
    assert main(["run", str(tmp_path / "good.toml")]) == EXIT_OK
    assert "1 scenarios, 0 failed" in capsys.readouterr().out


def test_run_writes_one_vcd_per_scenario(tmp_path, capsys):
    write(tmp_path, "good.toml", GOOD)
    out = tmp_path / "vcd"
    assert main(["run", str(tmp_path / "good.toml"), "--vcd", str(out), "--timing-report"]) == 0
    text = (out / "good.vcd").read_text()
    assert "StepA" in text and "$enddefinitions" in text
    assert "timing report: good" in capsys.readouterr().out


def test_each_move_alignment_splits_at_reversals_and_bounds_each_start_shift():
    from stepperdemo.scenarios.evaluate import compare_steps
    ref = [0.0, 10.0, 20.0, 1000.0, 1010.0, 2000.0, 2010.0]
    dirs = [1, 1, 1, 0, 0, 1, 1]  # three moves, no long pause between them
    ours = [0.0, 10.0, 20.0, 5096.0, 5106.0, 10192.0, 10202.0]  # moves 2, 3 one slot late
    c = compare_steps(ours, ref, "each_move", dirs)
    assert c.max_abs_us == 0 and c.offset_us == 5096 - 1000  # each start moved by one slot
    assert compare_steps(ours, ref, "each_move").max_abs_us == 8192  # no directions: 1 move
    assert compare_steps(ours, ref, "absolute").max_abs_us == 8192
