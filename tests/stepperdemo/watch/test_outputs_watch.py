"""User outputs in the VCD, the report, the plots and scenario files."""

import pytest

from fas.sim import SimBackend
from rigs.vcd import read_vcd
from stepperdemo.front.cli import main
from stepperdemo.program import make_program
from stepperdemo.scenarios.runner import run_file
from stepperdemo.scenarios.scenario import ScenarioError, load
from stepperdemo.watch import observe, plots, report

TPS = 16_000_000
PROGRAM = "G1 X600 F600000\nM62 P1\nM67 E0 Q25\nG1 X0\nM63 P1\nG4 P0.05\n"


def watched(program: str = PROGRAM, arch: str = "atmega328p", tmp_path=None):
    backend = SimBackend(arch)
    obs = observe.attach(backend, vcd=str(tmp_path / "o.vcd") if tmp_path else None)
    app = make_program("gcode", backend, scripted=True)
    app.run_script(program, max_ticks=60 * TPS)
    obs.finish()
    return obs, app


def test_vcd_names_every_output_with_a_pin(tmp_path):
    obs, _ = watched(tmp_path=tmp_path)
    vcd = read_vcd(str(tmp_path / "o.vcd"))
    for name in ("Dout0", "Dout1", "Dout2", "Dout3", "Aout0", "Aout1"):
        assert name in vcd.ids
    assert "Aout2" not in vcd.ids  # no pin on the ATmega328P
    steps = vcd.rising("StepA")
    (rise,) = vcd.rising("Dout1")
    assert steps[599] < rise < steps[600]
    pwm = vcd.rising("Aout0")
    assert pwm[0] > steps[599]  # synchronized with the first move's end
    assert {b - a for a, b in zip(pwm, pwm[1:], strict=False)} == {2048 * 625}  # 7812.5 Hz


def test_report_has_a_line_per_output_that_changed():
    obs, _ = watched()
    lines = report.report_lines(obs)
    d1 = [ln for ln in lines if ln.startswith("Dout1 (pin 4)")]
    assert d1 and "1 rise(s), 1 fall(s)" in d1[0] and "ends low" in d1[0]
    a0 = [ln for ln in lines if ln.startswith("Aout0 (pin 3)")]
    assert a0 and "period 128 us (7812.5 Hz" in a0[0] and "duty mean 25.0000 %" in a0[0]
    assert not any(ln.startswith("Dout0") for ln in lines)  # never used


def test_plots_show_the_outputs(tmp_path):
    obs, _ = watched()
    outs = plots.outputs_of(obs)
    assert {o.name for o in outs} == {"Dout1", "Aout0"}
    text = "\n".join(plots.terminal_plot(plots.series_of(obs), width=40, outputs=outs))
    assert "Dout1 level" in text and "Aout0 duty [%]" in text
    if plots.png_available():
        png = tmp_path / "p.png"
        plots.write_png(plots.series_of(obs), str(png), outputs=outs)
        assert png.stat().st_size > 1000


def test_only_outputs_no_steps_still_reports(capsys, tmp_path):
    path = tmp_path / "p.gcode"
    path.write_text("M64 P0\nM68 E1 Q50\nG4 P0.01\n")
    assert main(["gcode", str(path), "--report"]) == 0
    out = capsys.readouterr().out
    assert "Dout0 (pin 2)  1 rise(s), 0 fall(s)" in out
    assert "no stepper made a step" not in out


SCENARIO = '''
name = "outs"
program = "gcode"
input = """
G1 X600 F600000
M62 P1
M67 E0 Q25
G1 X0
M63 P1
G4 P0.05
"""
[outputs.Dout1]
rises = 1
falls = 1
level = 0
first_change_after_step = ["A", 600]
[outputs.Aout0]
frequency_hz = 7812.5
duty_percent = 25
duty_mean_percent = 25
'''


def test_scenario_output_expectations_pass_and_fail(tmp_path):
    p = tmp_path / "outs.toml"
    p.write_text(SCENARIO)
    res = run_file(p)
    assert res.ok, [c for c in res.checks if not c.ok]
    assert {c.what for c in res.checks} >= {"Dout1 rises", "Aout0 frequency hz"}
    p.write_text(SCENARIO.replace('["A", 600]', '["A", 599]').replace("rises = 1", "rises = 2"))
    res = run_file(p)
    failed = {c.what for c in res.checks if not c.ok}
    assert failed == {"Dout1 rises", "Dout1 first change between steps 599 and 600 of A"}


@pytest.mark.parametrize("table, key", [
    ("[outputs.Dout9]\nrises = 1\n", "outputs.Dout9"),
    ("[outputs.Dout0]\nspeed = 1\n", "outputs.Dout0.speed"),
    ("[outputs.Dout0]\nlevel = 2\n", "outputs.Dout0.level"),
    ('[outputs.Dout0]\nfirst_change_after_step = ["Z", 1]\n',
     "outputs.Dout0.first_change_after_step"),
    ("[outputs.Aout0]\ntol = { level = 1 }\n", "outputs.Aout0.tol.level"),
])
def test_broken_output_tables_name_the_key(tmp_path, table, key):
    p = tmp_path / "bad.toml"
    p.write_text('name = "b"\nprogram = "gcode"\ninput = "G0 X1"\n' + table)
    with pytest.raises(ScenarioError) as exc:
        load(p)
    assert exc.value.key == key
