"""Every airframe value is bounded to a physical range and to single precision before anything is
built (issue #16): the reproductions from the issue, the corners of each range, and the terms.

A value outside its range must give exit 2 and one stderr line naming the file and the dotted key,
from `check` and `generate` alike. A value at a corner of its range must check, generate C that a
strict compiler accepts, and analyse, without a traceback.
"""
from __future__ import annotations

import shutil
import subprocess
import warnings
from pathlib import Path

import pytest

from dobwind.cli.app import main
from dobwind.model.airframe import parse_airframe
from dobwind.model.airframe_toml import dumps
from dobwind.model.errors import InputError
from dobwind.model.ranges import FLT_MAX, FLT_MIN, RANGES, single_precision_ok
from dobwind.model.terms import parse_term, range_problem, single_precision_problem
from tests.helpers import airframe_dict
from tests.render_cache import _render_memo, shared_renders  # noqa: F401  (each corner's C rendered once per precision)

# (case, changes, the dotted key the message must name). The first group is the list.
OUT_OF_RANGE = [
    ("gravity 1e300", {"gravity": 1e300}, "gravity"),
    ("gravity 1e-300", {"gravity": 1e-300}, "gravity"),
    ("max_rpm 1e154", {"thrust.max_rpm": 1e154}, "thrust.max_rpm"),
    ("max_rpm 1e300", {"thrust.max_rpm": 1e300}, "thrust.max_rpm"),
    ("max_rpm 1e-160", {"thrust.max_rpm": 1e-160}, "thrust.max_rpm"),
    ("max_rpm 1e-300", {"thrust.max_rpm": 1e-300}, "thrust.max_rpm"),
    ("80 thrust coefficients", {"thrust.coefficients": [1.0] * 80}, "thrust.coefficients"),
    ("m^1e308", {"force_air.horizontal.terms": ["1", "m^1e308"], "force_air.horizontal.coefficients": [1.0, 1.0]},
     "force_air.horizontal.terms"),
    ("fh^-400", {"force_air.horizontal.terms": ["1", "fh^-400"], "force_air.horizontal.coefficients": [1.0, 1.0]},
     "force_air.horizontal.terms"),
    ("speeds 1e300", {"filter.speeds": [0.0, 1e300, 1e301]}, "filter.speeds"),
    ("tiny breakpoint gap", {"filter.speeds": [0.0, 4.0, 4.0000000000001]}, "filter.speeds"),
    ("breakpoint gap 1e-300", {"filter.speeds": [0.0, 1e-300, 2e-300]}, "filter.speeds"),
    ("name of 240 characters", {"name": "a" * 240}, "name"),
    ("gains 1e300", {"observer.gains": [1e300] * 3}, "observer.gains"),
    ("gains 1e-300", {"observer.gains": [1e-300] * 3}, "observer.gains"),
    # Every other range, at both ends.
    ("mass 1e-300", {"mass": 1e-300}, "mass"),
    ("mass 1e300", {"mass": 1e300}, "mass"),
    ("scale 1e300", {"thrust.scale": 1e300}, "thrust.scale"),
    ("thrust coefficient 1e300", {"thrust.coefficients": [0.0, 1.0, 1e300]}, "thrust.coefficients"),
    # c / max_rpm^k below float's normal range (the step folds it into one constant).
    ("thrust coefficient 1e-300", {"thrust.coefficients": [0.0, 1.0, 1e-300]}, "thrust.coefficients"),
    ("max_rpm^7 underflow", {"thrust.max_rpm": 1e6, "thrust.coefficients": [1.0] * 8}, "thrust.coefficients"),
    ("force-air coefficient 1e300", {"force_air.vertical.coefficients": [1e300, 0.05]}, "force_air.vertical.coefficients"),
    ("force-air coefficient 1e-300", {"force_air.vertical.coefficients": [1e-300, 0.05]}, "force_air.vertical.coefficients"),
    ("sample_time 1e-300", {"observer.sample_time": 1e-300}, "observer.sample_time"),
    ("sample_time 1e300", {"observer.sample_time": 1e300, "limits.max_dt": 1e300}, "observer.sample_time"),
    ("force_offset 1e300", {"observer.force_offset": [1e300, 0.0, 0.0]}, "observer.force_offset"),
    ("bias time 1e300", {"observer.acceleration_bias_time": 1e300}, "observer.acceleration_bias_time"),
    ("bias time 1e-300", {"observer.acceleration_bias_time": 1e-300}, "observer.acceleration_bias_time"),
    ("cutoff 1e-300", {"filter.cutoffs": [1e-300, 0.6, 1.0]}, "filter.cutoffs"),
    ("max_dt 1e300", {"limits.max_dt": 1e300}, "limits.max_dt"),
    ("max_tilt 1e-300", {"limits.max_tilt_deg": 1e-300}, "limits.max_tilt_deg"),
    ("power 0", {"force_air.vertical.terms": ["fz^0", "fz"]}, "force_air.vertical.terms"),
    ("power 4.5", {"force_air.vertical.terms": ["fz^4.5", "fz"]}, "force_air.vertical.terms"),
    ("degree 12", {"force_air.vertical.terms": ["fz^4*m^4*n^4", "fz"]}, "force_air.vertical.terms"),
    ("33 terms", {"force_air.vertical.terms": ["fz"] * 33, "force_air.vertical.coefficients": [0.1] * 33},
     "force_air.vertical.terms"),
    # Unbounded at zero force: the 1e-3 N floor, not the physics, would set the airflow at hover.
    ("m^-2", {"force_air.horizontal.terms": ["1", "m^-2"], "force_air.horizontal.coefficients": [1.0, 1.0]},
     "force_air.horizontal.terms"),
    ("fh^-0.5", {"force_air.horizontal.terms": ["1", "fh^-0.5"], "force_air.horizontal.coefficients": [1.0, 1.0]},
     "force_air.horizontal.terms"),
    ("m*n^-1", {"force_air.horizontal.terms": ["1", "m*n^-1"], "force_air.horizontal.coefficients": [1.0, 1.0]},
     "force_air.horizontal.terms"),
    ("drag 1e300", {"force_air": {"model": "drag", "drag": {"l0": 1e300, "q0": 0.1}}}, "force_air.drag.l0"),
    ("envelope 1e300", {"envelope": {"force_h_max": 1e300, "force_z": [-1.0, 1.0], "airflow_h_max": 5.0}},
     "envelope.force_h_max"),
    ("uncertainty 1e300", {"uncertainty": {"speeds": [0.0, 1e300], "sigma_h": [0.1, 0.1], "sigma_up": [0.1, 0.1]}},
     "uncertainty.speeds"),
    # A thrust curve that cannot hover between rest and 1.5 max_rpm (issue #37): every hovering sample
    # would be IMPLAUSIBLE. Each value is inside its own range.
    ("cannot lift its weight", {"mass": 1e4}, "thrust.coefficients"),
    ("lifts more than its weight at rest", {"thrust.coefficients": [1e6, 1.0]}, "thrust.coefficients"),
]

# Corners whose single-precision C misses the self-test's tolerance (float cancellation between
# +-1e6 terms of the force-air law, 6e-5 relative at one flight row): generate refuses them (exit 1,
# nothing written) rather than ship C that fails its own test (issue #37).
SELF_TEST_REFUSED = {"force-air coefficients at both ends", "powers of 4"}

# Values at the corners of their ranges (with what they need to stay a stable, Nyquist-respecting design).
CORNERS = [
    ("lightest and strongest gravity", {"mass": 0.005, "gravity": 100.0, "observer.gains": [0.01, 0.01, 0.01]}),
    # With a thrust curve that lifts the 1,000 N (hover must lie below 1.5 max_rpm, issue #37).
    ("heaviest, weakest gravity, slowest observer", {"mass": 1e4, "gravity": 0.1, "observer.gains": [1e-3] * 3,
                                                     "thrust.coefficients": [0.0, 1.5, 220.0]}),
    # No constant term: a curve giving 4e6 N at rest could not hover (issue #37).
    ("max_rpm 10 with seven 1e6 N coefficients", {"thrust.max_rpm": 10.0, "thrust.coefficients": [0.0] + [1e6] * 7}),
    ("max_rpm 1e6", {"thrust.max_rpm": 1e6}),
    ("10 kHz, the stiffest gains", {"observer.sample_time": 1e-4, "limits.max_dt": 1e-4, "observer.gains": [1e7] * 3,
                                    "mass": 1e4, "thrust.coefficients": [0.0, 1.0, 1.2e4]}),
    ("1 Hz, max_dt 10 s", {"observer.sample_time": 1.0, "limits.max_dt": 10.0, "filter.cutoffs": [0.001, 0.1, 0.4],
                           "observer.gains": [0.5] * 3}),
    ("breakpoints 1 cm/s apart up to 100 m/s", {"filter.speeds": [0.0, 99.98, 99.99, 100.0],
                                                 "filter.cutoffs": [0.3, 0.6, 1.0, 24.9]}),
    ("force-air coefficients at both ends", {"force_air.horizontal.coefficients": [1e6, 1e-30, -1e6, -1e-30, 1e6, 1e6]}),
    ("powers of 4", {"force_air.horizontal.terms": ["m^4*n^4", "fh^-4*m^4", "abs(m)^4", "n^4"],
                     "force_air.horizontal.coefficients": [1e6, 1e6, 1e-30, 1.0]}),
    ("offsets of 1e6 N", {"observer.force_offset": [1e6, -1e6, 1e6]}),
    ("bias times 1e-4 s", {"observer.acceleration_bias_time": 1e-4}),
    ("bias times a day", {"observer.acceleration_bias_time": 86400.0}),
    ("tilt 1 deg", {"limits.max_tilt_deg": 1.0}),
    ("a name of 64 characters", {"name": "a" * 64}),
]


def _write(tmp_path: Path, doc: dict) -> Path:
    path = tmp_path / "af.toml"
    path.write_text(dumps(doc))
    return path


def _changed(changes: dict) -> dict:
    doc = airframe_dict(**{k: v for k, v in changes.items() if k not in ("force_air", "envelope", "uncertainty")})
    doc.update({k: v for k, v in changes.items() if k in ("force_air", "envelope", "uncertainty")})
    return doc


def _one_line(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    return err


@pytest.mark.parametrize("command", ["check", "generate"])
@pytest.mark.parametrize("case,changes,key", OUT_OF_RANGE, ids=[c[0] for c in OUT_OF_RANGE])
def test_a_value_out_of_range_is_refused_with_its_key(case, changes, key, command, tmp_path, capsys):
    path = _write(tmp_path, _changed(changes))
    argv = [command, str(path)] + (["-o", str(tmp_path / "out")] if command == "generate" else [])
    assert main(argv) == 2
    err = _one_line(capsys)
    assert f"{path}: {key}:" in err
    assert not (tmp_path / "out").exists()


def test_a_term_with_a_trailing_newline_is_refused():
    # TOML's "\n" escape: the regex "$" matched before it, so "m\n" passed and fit wrote it back.
    text = dumps(airframe_dict()).replace('"fz*abs(fz)"', '"fz\\n"')
    assert '"fz\\n"' in text
    with pytest.raises(InputError, match="force_air.vertical.terms: term 'fz\\\\n': cannot parse"):
        parse_airframe(text, "<t>")


def test_a_long_name_is_reported_in_one_short_line(tmp_path, capsys):
    path = _write(tmp_path, airframe_dict(name="a" * 10_000_000))
    assert main(["check", str(path)]) == 2
    assert len(_one_line(capsys)) < 300


@pytest.mark.parametrize("name", ["quad__esc", "quad_", "m300___x", "a_"])
def test_a_name_with_a_run_of_underscores_or_a_trailing_one_is_refused_by_key(name, tmp_path, capsys):
    """"<name>_step" is the CasADi Function's name, which may not hold "__": such names passed the loader and
    then crashed check and generate with a CasADi RuntimeError traceback."""
    path = _write(tmp_path, airframe_dict(name=name))
    for command in (["check", str(path), "--no-selftest"], ["generate", str(path), "-o", str(tmp_path / "c")]):
        assert main(command) == 2
        assert f"{path}: name:" in _one_line(capsys)
    assert not (tmp_path / "c").exists()


@pytest.mark.parametrize("output, name", [("quad--esc_.toml", "quad_esc"), ("My Quad (v2).toml", "my_quad_v2"),
                                          ("2-rotor.toml", "a_2_rotor"), (f"{'abc_' * 30}.toml", ("abc_" * 16)[:-1])])
def test_init_names_an_airframe_from_its_file_with_single_underscores(output, name):
    from dobwind.inspect.initframe import _name
    from dobwind.model.ranges import NAME_MAX_CHARS

    assert _name(None, output) == name and len(name) <= NAME_MAX_CHARS
    parse_airframe(dumps(airframe_dict(name=name)), "<t>")  # a name the loader takes


@pytest.mark.parametrize("case,changes", CORNERS, ids=[c[0] for c in CORNERS])
def test_a_corner_of_the_ranges_checks_generates_compiling_c_and_analyses(case, changes, tmp_path, capsys, shared_renders):
    path = _write(tmp_path, airframe_dict(**changes))
    with warnings.catch_warnings(record=True) as raised:  # a numpy or scipy warning would reach stderr
        warnings.simplefilter("always")
        # check runs generate's self-test gate too: it refuses exactly what generate refuses
        assert main(["check", str(path)]) == (1 if case in SELF_TEST_REFUSED else 0)
        assert main(["check", str(path), "--no-selftest"]) == 0
        out = tmp_path / "c"
        if case in SELF_TEST_REFUSED:
            assert main(["generate", str(path), "-o", str(out)]) == 1
            assert "self-test" in capsys.readouterr().err and not out.exists()
            assert main(["generate", str(path), "-o", str(out), "--no-selftest"]) == 0
        else:
            assert main(["generate", str(path), "-o", str(out)]) == 0
        # analyze runs its wind-ramp experiment step by step: at 10 kHz this case took 37 s. Left out here.
        if changes.get("observer.sample_time") != 1e-4:
            assert main(["analyze", str(path), "--json", "--freq", "0.1"]) in (0, 1)
    assert not [str(w.message) for w in raised]
    compiler = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    assert compiler, "the C checks need a compiler"
    source = next(out.glob("*_wind.c"))
    done = subprocess.run([compiler, "-std=c99", "-Wall", "-Wextra", "-Werror", "-c", str(source), "-o",
                           str(tmp_path / "step.o")], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in capsys.readouterr().err


def test_every_range_lies_inside_single_precision():
    for key, bounds in RANGES.items():
        assert bounds.high <= FLT_MAX / 1e6, key  # headroom for the products the step forms
        assert bounds.low == 0.0 or bounds.low >= FLT_MIN * 1e6, key


def test_single_precision_ok_at_the_float_limits():
    assert single_precision_ok(0.0) and single_precision_ok(FLT_MIN) and single_precision_ok(-FLT_MAX)
    assert not single_precision_ok(FLT_MIN / 2) and not single_precision_ok(FLT_MAX * 1.0000001)


@pytest.mark.parametrize("text,bounded", [
    ("m^2*fh^-1.5", True), ("m*n*fh^-1.5", True), ("m*fh^-0.5", True), ("fz*abs(fz)^-0.5", True), ("fh^0.5", True),
    ("m*abs(m)^-1", True), ("m^-2", False), ("abs(n)^-1", False), ("fh^-1.5", False), ("m^2*fh^-3", False),
    ("fz*fh^-1", False), ("m*n^-1", False),
])
def test_a_term_must_stay_bounded_at_zero_force(text, bounded):
    assert (range_problem(parse_term(text), 4.0, 8.0) is None) == bounded


@pytest.mark.parametrize("text,single_ok", [
    ("fh^0.5", True), ("fz*abs(fz)^-0.5", True), ("m*fh^-0.5", True), ("m^2*fh^-1.5", True), ("m^3*n^3", True),
    ("abs(m)^0.5*n^3", False), ("abs(m)^0.5*fh", False), ("fh^0.5*fz", False), ("abs(fz)^0.5*m", False),
])
def test_single_precision_refuses_a_term_with_an_unbounded_slope_times_another_force(text, single_ok):
    assert (single_precision_problem(parse_term(text)) is None) == single_ok


def test_generate_and_verify_refuse_an_ill_conditioned_term_in_single_precision_only(tmp_path, capsys):
    # abs(m)^0.5*n^3 failed verify's single-precision flight by 1.3x to 6x its tolerance (issue #16).
    path = _write(tmp_path, airframe_dict(**{"force_air.horizontal.terms": ["1", "abs(m)^0.5*n^3"],
                                             "force_air.horizontal.coefficients": [0.5, 0.1]}))
    for argv in (["generate", str(path), "-o", str(tmp_path / "single")], ["verify", str(path)],
                 ["verify", str(path), "--precision", "single"],
                 ["replay", str(path), str(tmp_path / "none.csv"), "--backend", "c"]):
        assert main(argv) == 2, argv
        err = _one_line(capsys)
        assert f"{path}: force_air.horizontal.terms: term 'abs(m)^0.5*n^3' cannot be generated in single" in err
    assert not (tmp_path / "single").exists()
    assert main(["generate", str(path), "-o", str(tmp_path / "double"), "--precision", "double"]) == 0
    assert (tmp_path / "double").is_dir()
