"""Scenario checks for `e` (issue 23): firmware builds, gaps per window, known deviations."""

import gzip

import pytest

from stepperdemo.front.cli import main
from stepperdemo.scenarios.evaluate import gaps_per_window, wrap_gaps
from stepperdemo.scenarios.runner import EXIT_FAILED, EXIT_OK, run_file
from stepperdemo.scenarios.scenario import ScenarioError, load

LINE = "M1 A1000000 V40 e R20000 W"  # conformance d35: 80 gaps, 16 in each of 5 windows


def reference(tmp_path, gaps_in_window_1: int = 16):
    """A reference folder whose steps make ``gaps_in_window_1`` gaps in window 1."""
    ref = tmp_path / "ref"
    ref.mkdir()
    t, lines = 256_500.0, []
    for i in range(400):
        t += 4136.0 if i % 5 == 2 and i // 5 < gaps_in_window_1 else 40.0
        lines.append(f"{t:.3f}\t1\n")
    with gzip.open(ref / "steps_A.tsv.gz", "wt") as f:
        f.writelines(lines)
    return ref


def test_gaps_are_the_long_intervals_between_fast_steps_counted_per_256_ms_window():
    times, t = [], 0.0
    for start in (0.0, 260_000.0, 340_000.0):  # fast steps, one wrap, fast steps
        while t < start:  # slow steps between (no gaps: not fast)
            times.append(t)
            t += 3000.0
        for dt in (40.0, 40.0, 4136.0, 40.0, 40.0):
            times.append(t)
            t += dt
    gaps = wrap_gaps(times)
    assert len(gaps) == 3 and gaps[1] > 260_000.0
    # the third comes 84 ms after its window's start: outside every window
    assert gaps_per_window(gaps) == {0: 1, 1: 1}
    # slow steps (the start of a ramp) make no gaps
    assert wrap_gaps([0.0, 5000.0, 10_000.0, 12_000.0]) == []


def test_a_run_that_ends_on_a_wrap_counts_that_gap():
    # e07 B's firmware run ends on a wrap: its last interval is 4 150.9 us after fast steps
    times = [0.0, 40.0, 80.0, 120.0, 4270.9]
    assert wrap_gaps(times) == [120.0]
    assert gaps_per_window(wrap_gaps(times)) == {0: 1}


def scenario(tmp_path, body: str) -> str:
    return (f'name = "x"\ninput = "{LINE}"\nend = "firmware"\nbuild = "d"\n'
            f'reference = "{tmp_path / "ref"}"\n' + body)


def test_the_gaps_check_compares_each_window_within_its_tolerance(tmp_path):
    reference(tmp_path, 16)
    path = tmp_path / "g.toml"
    path.write_text(scenario(tmp_path, '[gaps]\nsteppers = ["A"]\nper_window = 1\n'))
    res = run_file(path)
    check = next(c for c in res.checks if c.what == "A gaps per window")
    assert check.expected.split()[0] == "16" and check.measured.split()[0] == "16"
    assert not check.ok  # the model's windows 2.. have gaps the fake reference has not
    assert check.deviation == 16


def test_a_known_gaps_deviation_is_ok_while_it_fails_and_fails_the_day_it_passes(
        tmp_path, capsys):
    reference(tmp_path, 16)
    path = tmp_path / "x.toml"
    known = ('[known_deviation]\n"A gaps per window" = { measured = "16 16 16 16 16", '
             'reason = "the reference here has none in windows 2..5" }\n')
    path.write_text(scenario(tmp_path, '[gaps]\nsteppers = ["A"]\n' + known))
    res = run_file(path)
    assert res.ok
    assert [c.known for c in res.checks if c.what == "A gaps per window"] == [True]
    assert main(["run", str(path)]) == EXIT_OK
    assert "known deviation" in capsys.readouterr().out
    # strict: where the check passes, the scenario fails
    path.write_text(scenario(tmp_path, '[steppers.A]\npulses = 20000\n[known_deviation]\n'
                                       '"A pulses" = { measured = 20000, reason = "r" }\n'))
    assert not run_file(path).ok
    assert main(["run", str(path)]) == EXIT_FAILED
    assert "MET" in capsys.readouterr().out


@pytest.mark.parametrize("body, key", [
    ('build = "x"\n', "build"),
    ('[gaps]\nsteppers = ["A"]\n', "gaps"),
])
def test_broken_e_keys_name_file_and_key(tmp_path, body, key):
    path = tmp_path / "b.toml"
    path.write_text(f'name = "b"\ninput = "M1"\n{body}')
    with pytest.raises(ScenarioError) as err:
        load(path)
    assert err.value.key == key


def test_the_build_key_runs_the_firmware_build_it_names(tmp_path):
    from fas.sim import SimBackend
    from stepperdemo.program import make_program

    line = "M1 A30000 V45 R100 W"
    firsts = {}
    for build in ("d", "e"):
        path = tmp_path / f"{build}.toml"
        path.write_text(f'name = "{build}"\ninput = "{line}"\nbuild = "{build}"\n'
                        '[steppers.A]\nposition = 100\n')
        assert load(path).build == build and run_file(path).ok
        backend = SimBackend("atmega328p", record=True, build=build)
        make_program("demo", backend, scripted=True).run_script(line)
        firsts[build] = backend.recorder.rising(9)[0]
    # the move starts sooner after the ramp task in build e (its code is leaner):
    # conformance e02 against d08's build, ~0.3 ms
    assert 2000 < firsts["d"] - firsts["e"] < 8000
