"""A chip's figures split by who uses them (issue 22): each room's table answers for
every profile, variants keep their rooms, and the library's tables see nothing above
them."""

from __future__ import annotations

import re
import subprocess
import sys
from dataclasses import replace

import pytest

from fas.arch import ATMEGA328P, ESP32, PROFILES, TEST_PROFILES, get_profile
from fas.output_figures import NO_OUTPUTS, output_figures
from fas.quickstep.figures import NO_QUICKSTEP, quickstep_figures
from fas.sim.timing import sim_timing
from rigs import ROOT

ALL = {**PROFILES, **TEST_PROFILES}


def test_every_profile_has_a_simulated_timing_and_a_usb_console_costs_no_line_time():
    for name, p in ALL.items():
        t = sim_timing(p)
        assert t.isr_latency_ticks and t.millis_overflow_ticks > 0, name
        # the chip's USB console (32U4, Pico) and the simulator's line agree
        assert (t.uart_byte_ticks == 0) == p.console_usb, name


def test_the_atmega32u4_has_its_own_timing_beside_its_family():
    # (the AVR family's figures as fitted on build d: the ATmega328P's build d reads its
    # replica's since the fortieth pass, the 32U4 has no replica)
    from fas.sim.timing import AVR_TIMING as avr

    usb = sim_timing(get_profile("atmega32u4"))
    assert usb != avr
    assert (usb.char_ticks, usb.uart_byte_ticks) == (40, 0)
    # its USB CDC driver costs a little per write call, its start-up code is larger;
    # otherwise it is an ATmega328P
    assert usb.console_call_ticks > 0 and usb.boot_ticks > avr.boot_ticks
    assert replace(usb, char_ticks=avr.char_ticks, uart_byte_ticks=avr.uart_byte_ticks,
                   console_call_ticks=0, boot_ticks=avr.boot_ticks) == avr


def test_a_firmware_build_changes_only_the_figures_it_lists():
    from fas.sim.builds import BUILDS
    from fas.sim.timing import BY_BUILD

    assert set(BY_BUILD) <= set(BUILDS)
    assert sim_timing(ATMEGA328P, "d") is sim_timing(ATMEGA328P)
    assert sim_timing(get_profile("esp32"), "e") is sim_timing(get_profile("esp32"))
    e = sim_timing(ATMEGA328P, "e")
    # its code is leaner (against build d's entry as fitted, in the same terms: build d's
    # 328P reads its entry, exit and idle task apart since the fortieth pass)
    from fas.sim.timing import AVR_TIMING

    assert e.fill_entry_ticks < AVR_TIMING.fill_entry_ticks
    with pytest.raises(ValueError, match="unknown firmware build 'x'"):
        sim_timing(ATMEGA328P, "x")


def test_a_variant_the_tables_do_not_list_times_as_its_family_and_has_no_extras():
    variant = replace(ESP32, name="esp32_custom")
    assert sim_timing(variant) is sim_timing(ESP32)
    assert quickstep_figures(variant) is NO_QUICKSTEP
    assert output_figures(variant) is NO_OUTPUTS
    with pytest.raises(ValueError, match="'z80'.*family 'z80'.*fas/sim/timing.py"):
        sim_timing(replace(ESP32, name="z80", family="z80"))


@pytest.mark.parametrize("name", ["atmega328p", "atmega2560", "esp32", "sam_due"])
def test_a_serial_devices_deeper_queue_keeps_the_chips_rooms(name):
    p = get_profile(name)
    deep = p.with_queue_len(128)
    assert deep.queue_len == 128 and deep.api_queue_len == p.queue_len
    assert sim_timing(deep) is sim_timing(p)
    assert quickstep_figures(deep) is quickstep_figures(p)
    assert output_figures(deep) is output_figures(p)


def test_quickstep_never_offers_the_timer_that_steps_the_motors():
    offered = {name for name, p in ALL.items() if quickstep_figures(p).timers}
    assert offered == {"atmega328p", "atmega2560", "atmega2560_timer1", "atmega2560_timer3",
                       "atmega2560_timer5"}
    for name in offered:
        p, qs = ALL[name], quickstep_figures(ALL[name])
        assert qs.timer() is qs.timers[0] and qs.timer().number == 2, name  # the default
        assert all(t.number != p.timer_module for t in qs.timers), name
        assert qs.timer(p.timer_module) is None, name
        assert 0 < qs.ram_bytes < p.ram_bytes, name


def test_the_esp32_outputs_are_the_same_under_every_esp_idf():
    tables = {name: output_figures(p) for name, p in PROFILES.items()
              if name.split("_idf")[0] == "esp32"}
    assert set(tables) == {"esp32", "esp32_idf5", "esp32_idf6"}
    assert len(set(map(id, tables.values()))) == 1
    assert output_figures(get_profile("esp32s3")) is NO_OUTPUTS


def test_variants_are_their_base_with_the_figures_that_differ():
    mega = get_profile("atmega2560")
    for timer in (1, 3, 5):
        v = get_profile(f"atmega2560_timer{timer}")
        assert v.timer_module == timer
        assert replace(v, name=mega.name, title=mega.title, step_pin_groups=mega.step_pin_groups,
                       timer_module=4, step_vectors_after_timer0=True) == mega
        # the vector table: timer 1's compares come before timer 0's overflow and
        # USART0's, timers 3, 4, 5's after them
        assert v.step_vectors_after_timer0 == (timer != 1)
    assert mega.step_vectors_after_timer0
    assert not get_profile("atmega328p").step_vectors_after_timer0
    assert not get_profile("atmega32u4").step_vectors_after_timer0
    rp2350 = get_profile("rp2350")
    assert replace(rp2350, name="rp2040", title=get_profile("rp2040").title, f_cpu=133_000_000,
                   max_steppers=8, ram_bytes=270336) == get_profile("rp2040")


def test_the_library_knows_no_console_figure():
    """No StepperDemo figure (``demo_*``, command letters) in any module of fas/."""
    found = []
    for path in sorted((ROOT / "fas").rglob("*.py")):
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if re.search(r"demo_|sim_cmd_ticks|\bcmd_ticks\b", line):
                found.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()}")
    assert found == []


def test_the_librarys_tables_load_neither_the_simulator_nor_the_console():
    code = ("import sys, fas, fas.arch, fas.quickstep.figures, fas.output_figures\n"
            "print(sorted(m for m in sys.modules if m.startswith(('fas.sim', 'stepperdemo'))))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True,
                         text=True, check=True).stdout
    assert out.strip() == "[]"
