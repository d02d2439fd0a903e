"""The replica's build settings (``bench/replica/replica.py``; docs/timing-model.md,
"twenty-seventh pass"): the default build is the Arduino IDE's (the runs e01-e18),
``--build d`` the one of the d*/test_sd_* runs (no link-time optimisation, the input's
define on every compile, one byte more of initialised data); each option reaches the
compile and link commands."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[3]
sys.path.insert(0, str(ROOT / "bench" / "replica"))

import replica  # noqa: E402

BASE = ["--fas", "F", "--simavr", "S"]


def flags(*opts: str) -> replica.Flags:
    return replica.flags_of(replica.parser().parse_args([*BASE, *opts, "steps", "d01"]))


def test_default_is_the_arduino_ide_build() -> None:
    f = flags()
    assert f.default() and f.tag() == ""
    assert f.cflags() == ["-c", "-g", "-Os", "-w", "-std=gnu11", "-ffunction-sections",
                          "-fdata-sections", "-flto", "-fno-fat-lto-objects"]
    assert f.cxxflags() == ["-c", "-g", "-Os", "-w", "-std=gnu++11", "-fpermissive",
                            "-fno-exceptions", "-ffunction-sections", "-fdata-sections",
                            "-fno-threadsafe-statics", "-Wno-error=narrowing", "-flto"]
    assert f.ldflags() == ["-w", "-Os", "-g", "-flto", "-fuse-linker-plugin",
                           "-Wl,--gc-sections"]
    assert "-flto" in f.asflags() and f.tool("avr-gcc") == "avr-gcc"


def test_build_d_is_no_lto_with_the_input_everywhere() -> None:
    f = flags("--build", "d")
    assert not f.lto and f.input_everywhere and f.opt == "-Os" and f.sections
    assert f.data_pad == 1 and flags("--build", "d", "--data-pad", "0").data_pad == 0
    assert not f.default() and f.tag() == "Os-nolto-inall-pad1"
    for line in (f.cflags(), f.cxxflags(), f.asflags(), f.ldflags()):
        assert not any("lto" in x for x in line)
    assert "-Wl,--gc-sections" in f.ldflags()
    same = flags("--no-lto", "--input-everywhere", "--data-pad", "1")
    assert (same.lto, same.input_everywhere, same.tag()) == (False, True, f.tag())


def test_each_option() -> None:
    assert flags("--opt", "O2").opt == "-O2" == flags("--opt=-O2").opt
    assert "-O2" in flags("--opt", "O2").ldflags()
    with pytest.raises(ValueError, match="-O9"):
        flags("--opt", "O9")
    nosec = flags("--no-sections")
    assert not any("sections" in x for x in nosec.cflags() + nosec.cxxflags() + nosec.ldflags())
    d = flags("-D", "SIMAVR_FOC_WORKAROUND", "--define", "X=1")
    assert d.cxxflags()[-2:] == ["-DSIMAVR_FOC_WORKAROUND", "-DX=1"]
    assert d.cflags()[-2:] == ["-DSIMAVR_FOC_WORKAROUND", "-DX=1"]
    assert d.tag().startswith("Os-") and d.tag() != flags("-D", "Y").tag()
    with pytest.raises(ValueError, match="0 or more"):
        flags("--data-pad", "-1")
    assert flags("--data-pad", "0").default() and flags("--build", "e").default()
    t = flags("--toolchain", "/opt/avr7/bin")
    assert t.tool("avr-g++") == "/opt/avr7/bin/avr-g++" and not t.default()


def _commands(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
              f: replica.Flags) -> list[list[str]]:
    fas = tmp_path / "fas"
    (fas / "src" / "pd_avr").mkdir(parents=True, exist_ok=True)
    (fas / "src" / "Lib.cpp").write_text("")
    (fas / "src" / "pd_avr" / "q.cpp").write_text("")
    (fas / "examples" / "StepperDemo").mkdir(parents=True, exist_ok=True)
    (fas / "examples" / "StepperDemo" / "StepperDemo.ino").write_text("void setup(){}\n")
    monkeypatch.setattr(replica, "CORE", tmp_path / "no-core")
    seen: list[list[str]] = []
    monkeypatch.setattr(replica, "run", lambda cmd, **kw: seen.append(cmd))
    replica.build_firmware(fas, "M1 W ", replica.UNO, tmp_path / "work", f)
    return seen


def test_the_input_define_reaches_the_library_only_with_input_everywhere(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    define = '-DSIM_TEST_INPUT="M1 W "'
    for f, lib_has_it in ((replica.Flags(), False),
                          (replica.Flags(lto=False, input_everywhere=True), True)):
        cmds = _commands(tmp_path / f.tag(), monkeypatch, f)
        lib = [c for c in cmds if any(x.endswith("Lib.cpp") or x.endswith("q.cpp") for x in c)]
        sketch = [c for c in cmds if any(x.endswith("StepperDemo.ino.cpp") for x in c)]
        assert len(lib) == 2 and len(sketch) == 1
        assert all((define in c) == lib_has_it for c in lib)
        assert define in sketch[0]
        link = cmds[-1]
        assert link[0] == "avr-gcc" and ("-flto" in link) == f.lto


def test_builds_are_cached_apart(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    outs = set()
    for f in (replica.Flags(), replica.Flags(lto=False), replica.Flags(input_everywhere=True)):
        cmds = _commands(tmp_path, monkeypatch, f)  # one source tree, one work folder
        outs.add(Path(cmds[-1][cmds[-1].index("-o") + 1]).parent)
    assert len(outs) == 3


def test_data_pad_and_core_reach_the_build(tmp_path: Path,
                                           monkeypatch: pytest.MonkeyPatch) -> None:
    cmds = _commands(tmp_path, monkeypatch, replica.Flags(data_pad=3, core="/opt/core"))
    pad = [c for c in cmds if c[-3].endswith("data_pad.c")]  # ... SOURCE -o OBJECT
    assert len(pad) == 1
    assert (Path(pad[0][-3]).read_text()
            == "volatile char replica_data_pad[3] = {1};\n")
    assert "-Wl,--undefined=replica_data_pad" in cmds[-1]
    assert any(x.endswith("data_pad.o") for x in cmds[-1])
    sketch = next(c for c in cmds if c[-3].endswith("StepperDemo.ino.cpp"))
    assert "-I/opt/core/cores/arduino" in sketch and "-I/opt/core/variants/standard" in sketch
    plain = _commands(tmp_path / "plain", monkeypatch, replica.Flags())
    assert not any(x.endswith(("data_pad.c", "data_pad.o")) or "replica_data_pad" in x
                   for c in plain for x in c)


def test_a_case_s_defines_join_its_build(tmp_path: Path) -> None:
    (tmp_path / "defines.txt").write_text("-DSIMAVR_TIME_MEASUREMENT\n")
    assert replica.case_defines(tmp_path) == ("-DSIMAVR_TIME_MEASUREMENT",)
    assert replica.case_defines(tmp_path / "none") == ()


def test_run_names() -> None:
    def name(*opts: str) -> str:
        args = replica.parser().parse_args([*BASE, *opts, "steps", "test_seq_sd_02_328p"])
        return replica.run_name("test_seq_sd_02_328p", args)
    assert name() == "test_seq_sd_02_328p"  # the default build keeps its names
    assert name("--build", "d") == "test_seq_sd_02_328p-Os-nolto-inall-pad1"
    assert name("--no-lto") == "test_seq_sd_02_328p-Os-nolto"
