"""`stepperdemo run`: results, broken files, JSON, exit codes."""

import json

from rigs import ROOT
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


KNOWN = """
name = "known"
input = "M1 A1000 V100 R300 W"
[steppers.A]
position = 301
pulses = 300
step_high_total_us = 1500
step_high_max_us = 20
tol = { step_high_total_us = 60, step_high_max_us = 5 }
[known_deviation]
"A position" = { measured = 300, reason = "a test of the mechanism" }
"A pulse high max us" = { measured = 9 }
"""


def test_a_known_deviation_is_ok_while_it_is_there_and_fails_once_met(tmp_path, capsys):
    res = run_file(write(tmp_path, "known.toml", KNOWN))
    assert [c.what for c in res.checks if not c.ok] == ["A pulse high total us"]
    known = {c.what: c for c in res.checks if c.known}
    assert set(known) == {"A position", "A pulse high max us"}
    assert known["A position"].measured == 300 and known["A position"].named == 300
    # absolute tolerances of the pulse high time, as upstream's expect.txt states them:
    # 300 pulses of 3.75 us, some longer behind timer 0 (1138 us; the model's value since
    # build d's plain pulse of 60 ticks became the default, fiftieth pass: 1154 before,
    # 3.81 us a pulse; 1140 with the ramp task's sections K43 and T44 as well) against
    # 1500 +- 60; the longest 9 us against 20 +- 5
    total = next(c for c in res.checks if c.what == "A pulse high total us")
    assert total.measured == 1138 and total.tolerance == 60 and not total.ok
    assert known["A pulse high max us"].measured == 9
    assert main(["run", str(tmp_path / "known.toml")]) == EXIT_FAILED  # the total fails
    assert "known" in capsys.readouterr().out
    met = KNOWN.replace("position = 301", "position = 300").replace(
        "step_high_total_us = 1500", "step_high_total_us = 1140")
    res = run_file(write(tmp_path, "met.toml", met))
    assert not res.ok  # strict: "A position" is met now
    c = next(c for c in res.checks if c.what == "A position")
    assert c.known and not c.ok
    only_known = KNOWN.replace("step_high_total_us = 1500", "step_high_total_us = 1140")
    assert main(["run", str(write(tmp_path, "only.toml", only_known))]) == EXIT_OK
    assert "known deviation" in capsys.readouterr().out


def test_a_known_deviation_must_name_an_existing_check_and_a_measured_value(tmp_path):
    typo = GOOD + '[known_deviation]\n"A postion" = { measured = 3 }\n'
    res = run_file(write(tmp_path, "typo.toml", typo))
    assert not res.ok
    assert any(c.what == "known deviation A postion" and not c.ok for c in res.checks)
    bad = GOOD + '[known_deviation]\n"A position" = { reason = "no figure" }\n'
    try:
        load(write(tmp_path, "bad.toml", bad))
    except ScenarioError as exc:
        assert exc.key == "known_deviation.A position.measured"
    else:
        raise AssertionError("accepted a known deviation without its measured value")


def test_pin_config_answers_the_start_up_prompt(tmp_path):
    sc = GOOD.replace('input = "M1 A1000 V100 R300 W"',
                      'profile = "esp32_idf5"\npin_config = 1\ninput = "M3 A1000 V100 R300 W"'
                      ).replace("[steppers.A]", "[steppers.C]").replace(
        '"Move steps 300"]', '"Move steps 300", "Using config 1: Driver-Types", '
        '">> M3: @300 acceleration  [steps/s^2]=1000 speed [us/step]=100  MCPWM_PCNT"]')
    res = run_file(write(tmp_path, "cfg.toml", sc))
    assert res.ok, [c for c in res.checks if not c.ok]
    assert res.sim_s < 5  # the digit was on the line: no 5 s wait
    for text, key in (('pin_config = 1\nname = "x"\ninput = "M1"\n', "pin_config"),
                      ('pin_config = 2\nprofile = "esp32"\nname = "x"\ninput = "M1"\n',
                       "pin_config")):
        try:
            load(write(tmp_path, "badcfg.toml", text))
        except ScenarioError as exc:
            assert exc.key == key
        else:
            raise AssertionError(text)


def test_pcnt_sync_is_upstreams_rule():
    from stepperdemo.scenarios.transcript import pcnt_sync_problems

    ok = ("M1: @1000 [1040] => 30000\r\nM1: @40000 [7260] => x\r\n"
          ">> M1: @30000 [-2767] acceleration\r\nM2: @5 [900] other motor\r\n")
    assert pcnt_sync_problems(ok, "M1", 66) == []  # 40000 % 32767 = 7233: 27 off
    off = "M1: @1000 [1067] => 30000\r\n"
    assert pcnt_sync_problems(off, "M1", 66) == [
        "M1: @1000 [1067] => 30000 (position 1000, counter 1067)"]
    assert pcnt_sync_problems(">> M1: @100 [99] acc\r\n", "M1", 66)  # the table: exact
    # a run of the console: status lines while running and the table agree
    res = run_file(ROOT / "sequences" / "upstream" / "esp32_seq_02_dt_m2.toml")
    check = next(c for c in res.checks if c.what == "M2 position vs pulse counter")
    assert check.ok and check.measured == "in sync"
