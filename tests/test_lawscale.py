"""The law-scale warning of `check` and `generate` (model/lawscale.py), pinned by closed forms: a
polynomial law whose speed is k (m^2 + n^2) reads k F^2 at a force F, a drag law with l0 alone reads
F / l0, and the warning fires exactly when that passes 50 m/s at a tenth of the weight."""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from dobwind.cli.app import main
from dobwind.model.airframe import load_airframe
from dobwind.model.lawscale import LawScaleLimits, airflow_at_share, law_scale_problem
from tests.helpers import ROOT

M300 = (ROOT / "airframes" / "m300.toml").read_text()
G = 9.80665


def _polynomial(tmp_path: Path, mass_kg: float, k: float, name: str = "p") -> Path:
    text = re.sub(r"^mass = .*$", f"mass = {mass_kg!r}", M300, flags=re.M)
    # A calibrated force offset: the law reads the force beyond it, so the reading must not move.
    text = text.replace("force_offset = [0.0, 0.0, 0.0]", "force_offset = [0.3, -0.2, 0.1]")
    text = text.replace('terms = ["1", "m", "n", "m^2", "n^2"]\ncoefficients = [0.90, 0.06, 0.16, 0.09, 0.07]',
                        f'terms = ["m^2", "n^2"]\ncoefficients = [{k!r}, {k!r}]')
    text = re.sub(r"^coefficients = \[0.01315, 11.34, 207.0\]", f"coefficients = [0.0, 0.0, {207.0 * mass_kg / 8.0!r}]",
                  text, flags=re.M)  # rotors that still carry the weight
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


def _k_for(speed_mps: float, mass_kg: float) -> float:
    force = 0.1 * mass_kg * G
    return speed_mps / force ** 2


@pytest.mark.parametrize("mass_kg", [2.0, 8.0, 200.0])
def test_polynomial_law_reads_its_closed_form_at_a_tenth_of_the_weight(tmp_path, mass_kg):
    af = load_airframe(str(_polynomial(tmp_path, mass_kg, _k_for(30.0, mass_kg))))
    speed = airflow_at_share(af)
    assert len(speed) == LawScaleLimits().directions
    assert np.allclose(speed, 30.0, rtol=1e-6)
    assert law_scale_problem(af) is None
    over = load_airframe(str(_polynomial(tmp_path, mass_kg, _k_for(50.5, mass_kg), "q")))
    problem = law_scale_problem(over)
    assert problem is not None and "50.5 m/s" in problem and f"mass = {mass_kg:g} kg" in problem


def test_the_threshold_and_the_share_are_parameters(tmp_path):
    af = load_airframe(str(_polynomial(tmp_path, 8.0, _k_for(30.0, 8.0))))
    assert law_scale_problem(af, LawScaleLimits(max_airflow_mps=29.0)) is not None
    # Twice the force: four times the speed of a law quadratic in the force.
    assert np.allclose(airflow_at_share(af, LawScaleLimits(force_share_of_weight=0.2)), 120.0, rtol=1e-6)


def test_drag_law_reads_force_over_l0(tmp_path):
    prior = tmp_path / "d.toml"
    text = M300.split("[force_air.horizontal]")[0] + (
        '[force_air]\nmodel = "drag"\nvertical_law = "zero-wind"\n\n[force_air.drag]\n'
        "l0 = {l0!r}\nq0 = 0.0\nlz = 0.3\nqz = 0.0\n\n"
        "[filter]\nspeeds = [0.0, 3.0, 10.0]\ncutoffs = [0.2, 0.35, 0.5]\n")
    for l0, warned in ((0.2, False), (0.15, True)):  # 7.85 N / l0: 39.2 and 52.3 m/s
        prior.write_text(text.format(l0=l0))
        af = load_airframe(str(prior))
        assert np.allclose(airflow_at_share(af), 0.1 * 8.0 * G / l0, rtol=1e-6)
        assert (law_scale_problem(af) is not None) == warned


def test_check_and_generate_warn_in_one_line_and_still_succeed(tmp_path, capsys):
    path = _polynomial(tmp_path, 200.0, _k_for(7700.0, 200.0))
    assert main(["check", str(path), "--no-selftest"]) == 0
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(path) in err and "force_air" in err and "warning" in err
    assert main(["generate", str(path), "--no-selftest", "-o", str(tmp_path / "c")]) == 0
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("dobwind generate: warning:")


@pytest.mark.parametrize("name", ["m300.toml", "nf_quad.toml"])
def test_shipped_airframes_are_not_warned_about(name):
    assert law_scale_problem(load_airframe(str(ROOT / "airframes" / name))) is None


def test_a_law_that_cannot_be_read_counts_as_absurd(tmp_path, monkeypatch):
    import dobwind.model.lawscale as lawscale
    af = load_airframe(str(_polynomial(tmp_path, 8.0, _k_for(30.0, 8.0))))
    monkeypatch.setattr(lawscale, "airframe_airflow", lambda *a, **k: np.full((8, 3), math.nan))
    assert law_scale_problem(af) is not None


def test_check_json_gives_the_reading(tmp_path, capsys):
    path = _polynomial(tmp_path, 8.0, _k_for(30.0, 8.0))
    assert main(["check", str(path), "--no-selftest", "--json"]) == 0
    import json
    assert json.loads(capsys.readouterr().out)["law_airflow_at_tenth_weight_mps"] == pytest.approx(30.0, abs=1e-3)


def _drag(tmp_path: Path, law: str, name: str = "d") -> Path:
    """m300 (8 kg: half the weight is 39.2 N) with a heading-frame drag law."""
    path = tmp_path / f"{name}.toml"
    path.write_text(M300.split("[force_air.horizontal]")[0] + (
        '[force_air]\nmodel = "drag"\nvertical_law = "zero-wind"\n\n[force_air.drag]\n'
        f"{law}\nlz = 0.3\nqz = 0.0\n\n[filter]\nspeeds = [0.0, 3.0, 10.0]\ncutoffs = [0.2, 0.35, 0.5]\n"))
    return path


@pytest.mark.parametrize("qay, folds", [(-0.02, True), (-0.004, False)])
def test_a_drag_law_that_folds_inside_the_envelope_is_warned_about(tmp_path, qay, folds):
    """With l0 = 1 and the per-axis qay alone, the y force vy + qay |vy| vy peaks at |vy| = 1 / (2 |qay|) with
    1 / (4 |qay|) N, and x and y are independent: the law folds where |vy| = s |sin theta| passes it. At
    qay = -0.02: 25 m/s and 12.5 N, short of half the weight (39.2 N), so the law is checked to 50 m/s and
    folds at 25; at -0.004 the peak is at 125 m/s, half the weight is read at 48.7 m/s, and the law
    increases over all it is checked on."""
    from dobwind.model.lawscale import law_fold_problem

    af = load_airframe(str(_drag(tmp_path, f"l0 = 1.0\nq0 = 0.0\nqay = {qay!r}")))
    problem = law_fold_problem(af)
    assert (problem is not None) == folds
    if folds:
        found = re.search(r"at ([0-9.]+) deg from x at ([0-9.]+) m/s", problem.replace("stops increasing ", ""))
        assert found is not None, problem
        across = float(found.group(2)) * abs(math.sin(math.radians(float(found.group(1)))))
        assert 25.0 <= across <= 25.0 * 1.1, problem  # |vy| at the first checked airflow at or past the peak
        assert problem.startswith("force_air.drag:") and "inside the 50 m/s it is checked to" in problem


def test_the_fold_is_checked_only_up_to_the_envelope(tmp_path):
    """l0 = 2, qay = -0.025 folds along y at 40 m/s, 40 N, and reads half the weight (39.2 N) there at
    (2 - sqrt(4 - 0.1 * 39.2)) / 0.05 = 34.3 m/s: not warned. At 0.6 of the weight (47.1 N > 40 N) the law
    never reaches the force along y, is checked to 50 m/s, and folds at 40."""
    from dobwind.model.lawscale import law_fold_problem

    af = load_airframe(str(_drag(tmp_path, "l0 = 2.0\nq0 = 0.0\nqay = -0.025")))
    weight = 0.5 * 8.0 * G
    reach = airflow_at_share(af, LawScaleLimits(force_share_of_weight=0.5))
    assert reach[2] == pytest.approx((2.0 - math.sqrt(4.0 - 0.1 * weight)) / 0.05, rel=1e-4)  # 90 deg from x
    assert law_fold_problem(af) is None
    assert law_fold_problem(af, LawScaleLimits(envelope_share_of_weight=0.6)) is not None


def test_check_warns_of_a_folding_law_and_still_succeeds(tmp_path, capsys):
    path = _drag(tmp_path, "l0 = 1.0\nq0 = 0.0\nqay = -0.02")
    assert main(["check", str(path), "--no-selftest"]) == 0
    lines = [e for e in capsys.readouterr().err.splitlines() if "stops increasing" in e]
    assert len(lines) == 1 and str(path) in lines[0] and lines[0].startswith("dobwind check: warning:")


@pytest.mark.parametrize("name", ["m300.toml", "nf_quad.toml"])
def test_shipped_airframes_do_not_fold(name):
    from dobwind.model.lawscale import law_fold_problem
    assert law_fold_problem(load_airframe(str(ROOT / "airframes" / name))) is None


@pytest.mark.parametrize("airflow_h_max, folds", [(20.0, False), (30.0, True)])
def test_a_calibrated_envelope_bounds_the_fold_check(tmp_path, airflow_h_max, folds):
    """The law above folds at |vy| = 25 m/s; with an [envelope] it is checked to its airflow_h_max only
    (the step flags every wind beyond EXTRAPOLATED): 20 m/s misses the fold, 30 m/s holds it."""
    from dobwind.model.lawscale import law_fold_problem

    path = _drag(tmp_path, "l0 = 1.0\nq0 = 0.0\nqay = -0.02")
    path.write_text(path.read_text() + f"\n[envelope]\nforce_h_max = 20.0\nforce_z = [-40.0, 40.0]\n"
                                       f"airflow_h_max = {airflow_h_max!r}\n")
    problem = law_fold_problem(load_airframe(str(path)))
    assert (problem is not None) == folds
    if folds:
        assert f"inside the {airflow_h_max:g} m/s" in problem
