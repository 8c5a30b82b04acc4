"""Airframe files: every bad file is refused with exit status 2 and one line naming file and key."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from dobwind.cli.app import main
from dobwind.model.airframe import load_airframe, parse_airframe
from dobwind.model.airframe_toml import dump_airframe, dumps
from tests.helpers import M300, airframe_dict, all_modes

BAD = [
    # (id, document or raw text, text expected in the message)
    ("syntax", "name = \"x\"\nmass = = 3\n", "TOML syntax error"),
    ("unknown_top", airframe_dict(mas=3.0), "mas: unknown key"),
    ("unknown_nested", airframe_dict(**{"observer.gain": [1.0, 1.0, 1.0]}), "observer.gain: unknown key"),
    ("missing_mass", airframe_dict(mass=None), "mass: missing required key"),
    ("missing_table", airframe_dict(filter=None), "filter: missing required key"),
    ("mass_string", airframe_dict(mass="8"), "mass: expected a finite number"),
    ("mass_zero", airframe_dict(mass=0.0), "mass: must be > 0"),
    ("mass_negative", airframe_dict(mass=-1.0), "mass: must be > 0"),
    ("mass_bool", airframe_dict(mass=True), "mass: expected a finite number"),
    ("gravity_nan", "", "gravity: expected a finite number"),
    ("name_upper", airframe_dict(name="M300"), "name: must match"),
    ("name_digit", airframe_dict(name="3dr"), "name: must match"),
    ("speeds_flat", airframe_dict(**{"filter.speeds": [0.0, 4.0, 4.0]}), "filter.speeds: must be strictly increasing"),
    ("speeds_down", airframe_dict(**{"filter.speeds": [0.0, 5.0, 2.0]}), "filter.speeds: must be strictly increasing"),
    ("cutoffs_length", airframe_dict(**{"filter.cutoffs": [0.3, 0.6]}), "filter.cutoffs: has 2 values for 3 speeds"),
    ("cutoff_nyquist", airframe_dict(**{"filter.cutoffs": [0.3, 0.6, 40.0]}), "filter.cutoffs: must stay below"),
    ("coeff_length", airframe_dict(**{"force_air.horizontal.coefficients": [1.0]}),
     "force_air.horizontal.coefficients: has 1 values for 6 terms"),
    ("term_unparsable", airframe_dict(**{"force_air.vertical.terms": ["fz^^2", "fz"]}), "term 'fz^^2'"),
    ("term_variable", airframe_dict(**{"force_air.vertical.terms": ["q", "fz"]}), "unknown variable 'q'"),
    ("term_abs_open", airframe_dict(**{"force_air.vertical.terms": ["abs(fz", "fz"]}), "term 'abs(fz'"),
    ("term_signed_root", airframe_dict(**{"force_air.vertical.terms": ["fz^0.5", "fz"]}), "write abs(fz)^0.5"),
    ("terms_empty", airframe_dict(**{"force_air.vertical.terms": []}), "force_air.vertical.terms: expected a non-empty"),
    ("gains_six", airframe_dict(**{"observer.gains": [1.0] * 6}), "observer.gains: expected 3 numbers, got 6"),
    ("gains_negative", airframe_dict(**{"observer.gains": [1.0, -1.0, 1.0]}), "observer.gains: every value must be > 0"),
    ("discretization", airframe_dict(**{"observer.discretization": "bilinear"}), "observer.discretization: must be one of"),
    ("acceleration", airframe_dict(**{"observer.acceleration": "imu"}), "observer.acceleration: must be one of"),
    ("rotors_zero", airframe_dict(**{"thrust.rotors": 0}), "thrust.rotors: expected a whole number from 1 to 16"),
    ("rotors_many", airframe_dict(**{"thrust.rotors": 17}), "thrust.rotors: expected a whole number"),
    ("rotors_float", airframe_dict(**{"thrust.rotors": 4.5}), "thrust.rotors: expected a whole number"),
    ("collective_rotors", airframe_dict(thrust={"source": "collective", "rotors": 4}), "thrust.rotors: only used with"),
    ("source", airframe_dict(**{"thrust.source": "esc"}), "thrust.source: must be one of"),
    ("tilt", airframe_dict(**{"limits.max_tilt_deg": 95.0}), "limits.max_tilt_deg: must be below 90"),
    ("max_dt_small", airframe_dict(**{"limits.max_dt": 0.001}), "limits.max_dt: must be at least"),
    ("offset_two", airframe_dict(**{"observer.force_offset": [0.0, 0.0]}), "observer.force_offset: expected 3"),
    ("bias_time_negative", airframe_dict(**{"observer.acceleration_bias_time": -1.0}),
     "observer.acceleration_bias_time: must be >= 0"),
    ("bias_time_velocity", airframe_dict(**{"observer.acceleration_bias_time": 10.0, "observer.acceleration": "velocity"}),
     "observer.acceleration_bias_time: needs an acceleration input"),
]


def _write(tmp_path: Path, case_id: str, doc) -> Path:
    path = tmp_path / f"{case_id}.toml"
    if case_id == "gravity_nan":
        text = dumps(airframe_dict()).replace("mass = 2.5", "mass = 2.5\ngravity = nan")
    else:
        text = doc if isinstance(doc, str) else dumps(doc)
    path.write_text(text)
    return path


@pytest.mark.parametrize("case_id,doc,expected", BAD, ids=[b[0] for b in BAD])
def test_bad_airframe_is_refused_with_one_line(tmp_path, capsys, case_id, doc, expected):
    path = _write(tmp_path, case_id, doc)
    assert main(["check", str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1, err
    assert str(path) in err
    assert expected in err


def test_missing_file_is_refused(tmp_path, capsys):
    assert main(["check", str(tmp_path / "nope.toml")]) == 2
    err = capsys.readouterr().err
    assert "nope.toml" in err and err.count("\n") == 1


def test_installed_command_prints_no_traceback(tmp_path):
    path = _write(tmp_path, "mass_zero", airframe_dict(mass=0.0))
    exe = Path(sys.executable).with_name("dobwind")
    done = subprocess.run([str(exe), "check", str(path)], capture_output=True, text=True)
    assert done.returncode == 2
    assert "Traceback" not in done.stderr and done.stderr.count("\n") == 1


def test_usage_error_is_one_line(capsys):
    with pytest.raises(SystemExit) as exc:
        main(["generate"])
    assert exc.value.code == 2
    assert capsys.readouterr().err.count("\n") == 1


def test_help_lists_every_command(capsys):
    with pytest.raises(SystemExit):
        main(["--help"])
    out = capsys.readouterr().out
    for command in ("generate", "verify", "analyze", "fit", "replay", "simulate", "demo"):
        assert command in out


def test_reference_airframe_loads_with_the_papers_numbers():
    af = load_airframe(M300)
    assert af.mass_kg == 8.0
    assert af.thrust.coefficients == (0.01315, 11.34, 207.0)
    assert af.horizontal.coefficients == (0.90, 0.06, 0.16, 0.09, 0.07)
    assert af.horizontal.term_texts == ("1", "m", "n", "m^2", "n^2")


@pytest.mark.parametrize("doc", all_modes()[::5] + [airframe_dict()], ids=lambda d: d["name"])
def test_dump_and_load_round_trip(doc):
    af = parse_airframe(dumps(doc), "<a>")
    again = parse_airframe(dump_airframe(af), "<b>")
    assert again.__class__ is af.__class__
    assert {k: v for k, v in vars(again).items() if k != "content_sha256"} == \
           {k: v for k, v in vars(af).items() if k != "content_sha256"}


def test_defaults_for_optional_keys():
    doc = airframe_dict(limits=None, **{"observer.force_offset": None})
    af = parse_airframe(dumps(doc), "<x>")
    assert af.limits.max_dt_s == 0.1 and af.limits.max_tilt_deg == 60.0
    assert af.observer.force_offset_n == (0.0, 0.0, 0.0)
    assert af.observer.acceleration_bias_time_s == 0.0 and not af.observer.estimates_acceleration_bias
    assert af.gravity_mps2 == pytest.approx(9.80665) or "gravity" in doc
