"""`dobwind generate --target px4|ardupilot` (codegen/targets.py, issue #32): the PX4 module and the
ArduPilot library compile with the autopilots' own flags (g++ and clang++ on the host,
arm-none-eabi-g++ for a Cortex-M4F; -Werror) against the stand-in headers in tests/standins/, whose
uORB header for the project's own message is written from the generated .msg (so the module and its
message cannot drift apart); the DataFlash message's format matches its packet; the folders are
deterministic and self-contained."""
from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from dobwind.codegen.generate import generate_code, write_files
from dobwind.harness.build import run
from dobwind.harness.flagsets import FLAG_SETS, Toolchain, available_toolchains
from dobwind.model.airframe import parse_airframe
from dobwind.model.errors import CheckFailed, InputError
from dobwind.model.airframe_toml import dumps
from dobwind.codegen.targetdocs import PAGES, generated_files, shown_blocks
from tests.helpers import M300, airframe_dict

STANDINS = Path(__file__).resolve().parent / "standins"
_MSG_C_TYPES = {"uint64": "uint64_t", "uint32": "uint32_t", "float32": "float", "bool": "bool", "uint8": "uint8_t"}

# The airframe variants the integrations differ by: rpm or collective thrust, NED acceleration,
# accelerometer specific force or none (the observer differentiates the velocity).
VARIANTS = {
    "m300 (rpm, NED acceleration)": None,
    "collective, specific force": airframe_dict(**{"thrust": {"source": "collective"},
                                                   "observer.acceleration": "specific_force"}),
    "six rotors, no acceleration": airframe_dict(**{"thrust.rotors": 6, "observer.acceleration": "velocity"}),
}


def _airframe(variant: str):
    from dobwind.model.airframe import load_airframe

    doc = VARIANTS[variant]
    return load_airframe(M300) if doc is None else parse_airframe(dumps(doc), "<test>")


def msg_header(msg: str, topic: str) -> str:
    """A uORB topic header from a .msg file, as PX4's generator would write the struct."""
    lines = []
    for raw in msg.splitlines():
        text = raw.split("#", 1)[0].strip()
        if not text:
            continue
        ctype, name = text.split()
        array = re.fullmatch(r"(\w+)\[(\d+)\]", ctype)
        base = array.group(1) if array else ctype
        lines.append(f"\t{_MSG_C_TYPES[base]} {name}{f'[{array.group(2)}]' if array else ''};")
    body = "\n".join(lines)
    return (f"#pragma once\n#include <stdbool.h>\n#include <uORB/uORB.h>\nstruct {topic}_s {{\n{body}\n}};\n"
            f"ORB_DECLARE({topic});\n")


def _generated(af, target: str, folder: Path) -> Path:
    write_files(generate_code(af, "single", target=target).files, folder)
    return folder


def _toolchains() -> list[Toolchain]:
    return [t for t in available_toolchains() if shutil.which(t.cxx)]


def _compile_cxx(toolchain: Toolchain, flags: tuple[str, ...], source: Path, includes: list[Path], out: Path,
                 defines: tuple[str, ...] = ()) -> None:
    run([toolchain.cxx, *toolchain.adapt(flags), *defines, *[f"-I{i}" for i in includes], "-c", str(source),
         "-o", str(out)])


# px4_add_module defines the module's name for its sources.
PX4_DEFINES = ('-DMODULE_NAME="dobwind_m300"',)


@pytest.mark.parametrize("variant", VARIANTS)
def test_px4_module_compiles_with_px4_flags(tmp_path, variant):
    folder = _generated(_airframe(variant), "px4", tmp_path / "gen") / "px4"
    topics = tmp_path / "msg" / "uORB" / "topics"
    topics.mkdir(parents=True)
    (topics / "dob_wind.h").write_text(msg_header((folder / "msg" / "DobWind.msg").read_text(), "dob_wind"))
    includes = [folder, tmp_path / "msg", STANDINS / "px4"]
    for toolchain in _toolchains():
        _compile_cxx(toolchain, FLAG_SETS["px4"].cxx, folder / "DobWind.cpp", includes, tmp_path / "module.o",
                     PX4_DEFINES)
        name = next(folder.glob("*_wind.c")).name
        run([toolchain.cc, *toolchain.adapt(FLAG_SETS["px4"].c), "-c", str(folder / name), "-o", str(tmp_path / "step.o")])


@pytest.mark.parametrize("variant", VARIANTS)
def test_ardupilot_library_compiles_with_ardupilot_flags(tmp_path, variant):
    folder = _generated(_airframe(variant), "ardupilot", tmp_path / "gen") / "AP_DOBWind"
    includes = [folder, folder.parent, STANDINS / "ardupilot"]  # folder.parent: ArduPilot's libraries/
    for toolchain in _toolchains():
        for source in ("AP_DOBWind.cpp", next(folder.glob("*_wind_step.cpp")).name):
            _compile_cxx(toolchain, FLAG_SETS["ardupilot"].cxx, folder / source, includes, tmp_path / f"{source}.o")


def test_the_dataflash_message_joins_ardupilots_log_table(tmp_path):
    """As docs/ardupilot.md says to add it: AP_Logger/LogStructure.h includes the library's LogStructure.h
    before its LogMessages enum (as it does every library's), lists LOG_IDS_FROM_DOBWIND in the enum, and a
    vehicle's table takes LOG_STRUCTURE_FROM_DOBWIND. A LOG_DOBW_MSG macro in the library's header would
    replace the enumerator by a number there and stop the build."""
    folder = _generated(_airframe("m300 (rpm, NED acceleration)"), "ardupilot", tmp_path / "gen") / "AP_DOBWind"
    vehicle = tmp_path / "Log.cpp"
    vehicle.write_text(
        "#include <AP_Logger/LogStructure.h>\n"
        "static_assert(LOG_DOBW_MSG > LOG_FORMAT_MSG && LOG_DOBW_MSG < _LOG_LAST_MSG_, \"an id of the enum\");\n"
        "extern const struct LogStructure log_structure[];\n"
        "const struct LogStructure log_structure[] = {\n    LOG_STRUCTURE_FROM_DOBWIND\n};\n")
    for toolchain in _toolchains():
        _compile_cxx(toolchain, FLAG_SETS["ardupilot"].cxx, vehicle, [folder.parent, STANDINS / "ardupilot"],
                     tmp_path / "Log.o")


def test_a_module_that_drifts_from_its_message_fails_to_compile(tmp_path):
    """The check above has teeth: a field the module writes but the message lacks is an error."""
    folder = _generated(_airframe("m300 (rpm, NED acceleration)"), "px4", tmp_path / "gen") / "px4"
    topics = tmp_path / "msg" / "uORB" / "topics"
    topics.mkdir(parents=True)
    msg = (folder / "msg" / "DobWind.msg").read_text().replace("wind_speed_up", "wind_speed_upward")
    (topics / "dob_wind.h").write_text(msg_header(msg, "dob_wind"))
    gcc = Toolchain("gcc", "gcc", "g++")
    with pytest.raises(CheckFailed, match="wind_speed_up"):
        _compile_cxx(gcc, FLAG_SETS["px4"].cxx, folder / "DobWind.cpp", [folder, tmp_path / "msg", STANDINS / "px4"],
                     tmp_path / "module.o", PX4_DEFINES)


def test_a_px4_module_for_more_rotors_than_esc_status_holds_does_not_build(tmp_path, capsys):
    """esc_status holds 8 ESC reports (EscStatus.msg CONNECTED_ESC_MAX, the stand-in's esc[8]): a nine-rotor
    module would read NaN for the ninth and reject every sample, so its build stops at a static_assert, and
    generate says why on stderr (a warning: a PX4 fork may hold more). Eight rotors build (the check above)."""
    from dobwind.cli.app import main

    doc = airframe_dict(**{"thrust.rotors": 9})
    folder = _generated(parse_airframe(dumps(doc), "<test>"), "px4", tmp_path / "gen") / "px4"
    topics = tmp_path / "msg" / "uORB" / "topics"
    topics.mkdir(parents=True)
    (topics / "dob_wind.h").write_text(msg_header((folder / "msg" / "DobWind.msg").read_text(), "dob_wind"))
    gcc = Toolchain("gcc", "gcc", "g++")
    with pytest.raises(CheckFailed, match="fewer ESC reports"):
        _compile_cxx(gcc, FLAG_SETS["px4"].cxx, folder / "DobWind.cpp", [folder, tmp_path / "msg", STANDINS / "px4"],
                     tmp_path / "module.o", PX4_DEFINES)
    (tmp_path / "nine.toml").write_text(dumps(doc))
    assert main(["generate", str(tmp_path / "nine.toml"), "--target", "px4", "-o", str(tmp_path / "c")]) == 0
    err = capsys.readouterr().err
    assert "thrust.rotors = 9" in err and "holds 8 ESC reports" in err and len(err.strip().splitlines()) == 1
    assert main(["generate", str(M300), "--target", "px4", "-o", str(tmp_path / "c8")]) == 0
    assert "ESC reports" not in capsys.readouterr().err


_SIZES = {"Q": 8, "f": 4, "I": 4}
_C_SIZES = {"uint64_t": 8, "float": 4, "uint32_t": 4}


def test_dataflash_format_matches_its_packet():
    """ArduPilot checks a message's format, labels, units and multipliers against each other at run
    time; here against the packet struct too: same count, same order of sizes."""
    files = generate_code(_airframe("m300 (rpm, NED acceleration)"), "single", target="ardupilot").files
    text = files["AP_DOBWind/LogStructure.h"]
    entry = re.search(r'"DOBW", "(\w+)", "([\w,]+)", "([\w-]+)", "([\w-]+)"', text)
    assert entry is not None
    fmt, labels, units, multipliers = entry.groups()
    assert len(fmt) == len(labels.split(",")) == len(units) == len(multipliers)
    struct = text[text.index("struct PACKED log_DOBW"):]
    members = re.findall(r"^\s+(uint64_t|float|uint32_t) \w+;", struct[:struct.index("};")], re.M)
    assert [_SIZES[c] for c in fmt] == [_C_SIZES[m] for m in members]
    assert units[0] == "s" and multipliers[0] == "F"  # TimeUS: microseconds
    assert units[labels.split(",").index("WDir")] == "h"  # a heading in degrees


def test_target_folders_are_deterministic_and_self_contained():
    af = _airframe("m300 (rpm, NED acceleration)")
    for target, folder in (("px4", "px4"), ("ardupilot", "AP_DOBWind")):
        first = generate_code(af, "single", target=target).files
        assert first == generate_code(af, "single", target=target).files
        assert first[f"{folder}/m300_wind.c"] == first["m300_wind.c"]  # a copy of the step beside the code
        assert first[f"{folder}/m300_wind.h"] == first["m300_wind.h"]
    plain = generate_code(af, "single").files
    assert set(plain) == {"m300_wind.c", "m300_wind.h", "m300_wind_selftest.c", "CMakeLists.txt"}


def test_targets_are_single_precision():
    with pytest.raises(InputError, match="single precision"):
        generate_code(_airframe("m300 (rpm, NED acceleration)"), "double", target="px4")


@pytest.mark.parametrize("target, must_show", [
    ("px4", {"px4/CMakeLists.txt", "px4/module.yaml", "px4/msg/DobWind.msg", "px4/DobWind.hpp", "px4/DobWind.cpp"}),
    ("ardupilot", {"AP_DOBWind/AP_DOBWind.h", "AP_DOBWind/AP_DOBWind.cpp", "AP_DOBWind/LogStructure.h"}),
])
def test_integration_page_shows_the_generated_files(target, must_show):
    """docs/px4.md and docs/ardupilot.md show exactly what generate writes (and the tests above compile);
    refresh them with `python -m dobwind.codegen.targetdocs`."""
    shown = shown_blocks(PAGES[target].read_text(encoding="utf-8"))
    assert must_show <= set(shown)
    files = generated_files(target)
    for path, text in shown.items():
        assert text == files[path].rstrip("\n") + "\n", f"{PAGES[target].name}: {path} is stale"


def test_a_stale_page_block_is_seen():
    page = PAGES["ardupilot"].read_text(encoding="utf-8").replace("get_velocity_NED(velocity)", "get_velocity(velocity)", 1)
    shown = shown_blocks(page)
    files = generated_files("ardupilot")
    assert any(text != files[path].rstrip("\n") + "\n" for path, text in shown.items())


def test_generate_target_from_the_command_line(tmp_path, capsys):
    from dobwind.cli.app import main

    assert main(["generate", str(M300), "--target", "px4", "-o", str(tmp_path / "c")]) == 0
    assert (tmp_path / "c" / "px4" / "DobWind.cpp").is_file() and (tmp_path / "c" / "m300_wind.c").is_file()
    # Regenerating replaces the folder it wrote (its px4/ is its own), with another target too.
    assert main(["generate", str(M300), "--target", "ardupilot", "-o", str(tmp_path / "c")]) == 0
    assert (tmp_path / "c" / "AP_DOBWind" / "AP_DOBWind.cpp").is_file() and not (tmp_path / "c" / "px4").exists()
    assert main(["generate", str(M300), "--target", "px4", "--precision", "double", "-o", str(tmp_path / "d")]) == 2
    assert "single precision" in capsys.readouterr().err and not (tmp_path / "d").exists()


def test_verify_refuses_double_precision_with_ardupilot_flags(capsys):
    from dobwind.cli.app import main

    assert main(["verify", str(M300), "--flags", "ardupilot", "--precision", "double"]) == 2
    err = capsys.readouterr().err
    assert str(M300) in err and "-fsingle-precision-constant" in err
