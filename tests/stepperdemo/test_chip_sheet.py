"""StepperDemo's build per chip and the chip sheet that gathers every room (issue 22)."""

from __future__ import annotations

import subprocess
import sys

import pytest

from fas.arch import PROFILES, TEST_PROFILES, get_profile
from fas.codes import PIN_UNDEFINED
from fas.output_figures import NO_OUTPUTS
from fas.quickstep.figures import NO_QUICKSTEP
from rigs import ROOT
from stepperdemo import messages as msg
from stepperdemo.chip_sheet import chip_sheet, sheet_lines
from stepperdemo.demo.build import demo_build
from stepperdemo.program import EndReason

ALL = {**PROFILES, **TEST_PROFILES}


def test_every_profile_has_a_build_wired_to_its_own_step_pins():
    for name, p in ALL.items():
        build = demo_build(p)
        assert len(build.steppers) > 0 and build.steppers[0].step != PIN_UNDEFINED, name
        assert p.queue_for_step_pin(build.steppers[0].step) is not None, name
        for cfg in build.configs:
            assert len(cfg.steppers) <= p.max_steppers, (name, cfg.name)
        # the stray-read command exists where the Arduino core has the stray read
        assert build.has_stray_digital_read == (p.family == "avr"), name


def test_the_megas_wiring_follows_its_step_timer():
    for name in ("atmega2560", "atmega2560_timer1", "atmega2560_timer3", "atmega2560_timer5"):
        p = get_profile(name)
        steps = tuple((s.step,) for s in demo_build(p).steppers)
        assert steps == p.step_pin_groups, name


def test_a_profile_without_a_build_is_named_in_the_error():
    from dataclasses import replace

    with pytest.raises(ValueError, match="'esp32_custom'.*stepperdemo/demo/build.py"):
        demo_build(replace(get_profile("esp32"), name="esp32_custom"))


def test_the_sheet_gathers_every_room_of_a_chip():
    sheet = chip_sheet("atmega328p")
    assert sheet.chip is get_profile("atmega328p")
    assert sheet.quickstep.timer().number == 2
    assert sheet.outputs.user_digital_pins == (2, 4, 12, 14)
    assert sheet.sim.uart_byte_ticks == 1496
    # (R: build d's replica's 465, fortieth pass; the figure fitted before it 552)
    assert sheet.demo.cmd_ticks["R"] == 465 and sheet.demo.debug_led_pin == 13
    bare = chip_sheet("rp2040")
    assert bare.quickstep is NO_QUICKSTEP and bare.outputs is NO_OUTPUTS
    lines = sheet_lines(bare)
    assert msg.CHIP_SHEET_NONE.format(room="quickstep") in lines
    assert msg.CHIP_SHEET_FIGURE.format(field="debug_led_pin", value=25) in lines


def _run(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "stepperdemo.chip_sheet", *args], cwd=ROOT,
                          capture_output=True, text=True, timeout=60)


def test_the_sheet_from_the_command_line():
    listing = _run()
    assert listing.returncode == 0
    assert [line.split()[0] for line in listing.stdout.splitlines()] == list(PROFILES)
    one = _run("esp32c3")
    assert one.returncode == 0 and one.stderr == ""
    out = one.stdout.splitlines()
    assert out[0] == msg.CHIP_SHEET_HEADER.format(name="esp32c3", title=PROFILES["esp32c3"].title)
    rooms = [line for line in out if line.startswith("[")]
    assert rooms == ["[chip] fas.arch", "[sim] fas.sim.timing",
                     "[quickstep] fas.quickstep.figures", "[outputs] fas.output_figures",
                     "[demo] stepperdemo.demo.build"]
    assert "  debug_led_pin = 8" in out
    bad = _run("z80")
    assert bad.returncode == 2 and bad.stdout == ""
    assert len(bad.stderr.splitlines()) == 1 and "unknown architecture 'z80'" in bad.stderr


def test_a_new_chip_is_a_profile_and_its_stepperdemo_build(monkeypatch):
    """The recipe of fas/arch.py: a Profile (here a variant of the RP2040) in PROFILES
    and a DemoBuild; the simulator times it as its family, and it has no QuickStep and
    no user outputs until their tables list it."""
    from dataclasses import replace

    from rigs.demo import run
    from stepperdemo.demo import build
    from stepperdemo.demo.build import ESP32_COSTS, DemoStepper

    chip = replace(get_profile("rp2040"), name="rp2040_two", title="RP2040, two steppers",
                   max_steppers=2)
    monkeypatch.setitem(PROFILES, chip.name, chip)
    monkeypatch.setitem(build.BY_PROFILE, chip.name, replace(ESP32_COSTS, steppers=(
        DemoStepper(step=2, enable_low_active=3, direction=4, on_delay_us=0, off_delay_ms=0),)))
    app, reason = run("M1 A10000 V100 R300 W", arch=chip.name, record=True)
    assert reason == EndReason.IDLE
    assert "Steppers=2" in app.transcript.decode()
    assert len(app.backend.recorder.rising(2)) == 300  # the build's step pin
    sheet = chip_sheet(chip.name)
    assert sheet.sim is chip_sheet("rp2040").sim
    assert sheet.quickstep is NO_QUICKSTEP and sheet.outputs is NO_OUTPUTS
