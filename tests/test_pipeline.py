"""Simulate -> fit -> replay: logs, the simulator's physics, calibration, both backends, accuracy."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from dobwind.replay import baseline
from dobwind.cli.app import main
from dobwind.codegen.tolerance import TOLERANCE
from dobwind.calibrate.fit import (VERTICAL_CANDIDATES, Points, _extrapolation_rmse, _term_matrix, fit_polynomial,
                         read_calibration_logs, select_terms)
from dobwind.calibrate.fitfamily import FAMILY_TIE
from dobwind.io.logs import ESTIMATE_COLUMNS, read_log, required_columns
from dobwind.model.airframe import load_airframe
from dobwind.model.status import REJECTED_MASK, STATUS_BITS, accepted
from dobwind.replay.replay import replay, score
from dobwind.simulate.simulate import aerodynamic_force, simulate, true_vehicle
from tests.helpers import M300

STATUS_SETTLING = next(bit.value for bit in STATUS_BITS if bit.name == "SETTLING")
RATE = "25"  # fast tests: 25 Hz logs (the estimator takes the measured dt)


@pytest.fixture(scope="module")
def logs(tmp_path_factory):
    """A short calibration (8 s holds) and the three test scenarios, made once for the module."""
    folder = tmp_path_factory.mktemp("logs")
    paths = {}
    for name, seed, hold in (("sweep", 1, "8"), ("vertical", 2, None), ("tunnel", 3, None), ("still-air", 4, None),
                             ("outdoor", 5, None)):
        path = folder / f"{name}.csv"
        args = ["simulate", name, "--seed", str(seed), "--rate", RATE, "-o", str(path)]
        assert main(args + (["--hold", hold] if hold else [])) == 0
        paths[name] = str(path)
    return paths


@pytest.fixture(scope="module")
def fitted(logs, tmp_path_factory):
    out = tmp_path_factory.mktemp("fit") / "fitted.toml"
    assert main(["fit", str(M300), logs["sweep"], logs["vertical"], "--model", "polynomial", "-o", str(out)]) == 0
    return out


# --- logs ---------------------------------------------------------------------------------------

def _write(path, header, rows, comments=()):
    path.write_text("".join(f"# {c}\n" for c in comments) + ",".join(header) + "\n" +
                    "".join(",".join(map(str, r)) + "\n" for r in rows))


def test_log_reader_accepts_any_column_order_comments_and_extras(tmp_path):
    af = load_airframe(M300)
    needed = [c for c, _ in required_columns(af)]
    header = list(reversed(needed)) + ["battery_v"]
    rows = [[i * 0.01 if c == "t" else (1.0 if c == "q_w" else 0.0) for c in header] for i in range(5)]
    path = tmp_path / "log.csv"
    _write(path, header, rows, comments=["made by hand"])
    log = read_log(path, required_columns(af))
    assert log.rows == 5 and log.columns["t"][-1] == pytest.approx(0.04) and "battery_v" in log.columns


@pytest.mark.parametrize("case,expected", [
    ("missing", "column rpm_3: missing (rotor speed)"),
    ("text", "line 4, column vel_e: not a number: 'fast'"),
    ("time", "line 5, column t: time must be strictly increasing"),
    ("short", "line 3: has"),
])
def test_bad_logs_are_refused_with_one_line(tmp_path, capsys, case, expected):
    af = load_airframe(M300)
    header = [c for c, _ in required_columns(af)]
    rows = [[i * 0.01 if c == "t" else (1.0 if c == "q_w" else 0.0) for c in header] for i in range(6)]
    if case == "missing":
        header = [c for c in header if c != "rpm_3"]
        rows = [r[:-1] for r in rows]
    elif case == "text":
        rows[2][header.index("vel_e")] = "fast"
    elif case == "time":
        rows[3][0] = 0.0
    else:
        rows[1] = rows[1][:-2]
    path = tmp_path / "bad.csv"
    _write(path, header, rows)
    assert main(["replay", str(M300), str(path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(path) in err and expected in err, err


def test_fit_without_true_wind_names_the_column(tmp_path, capsys, logs):
    text = open(logs["tunnel"]).read().replace("wind_n,", "wn,")
    path = tmp_path / "no_truth.csv"
    path.write_text(text)
    assert main(["fit", str(M300), str(path), "-o", str(tmp_path / "x.toml")]) == 2
    err = capsys.readouterr().err
    assert "column wind_n: missing" in err and err.count("\n") == 1
    assert not (tmp_path / "x.toml").exists()


# --- simulator ----------------------------------------------------------------------------------

def test_simulation_is_reproducible_and_seeded():
    af = load_airframe(M300)
    a, b, c = (simulate(af, "outdoor", s) for s in (7, 7, 8))
    assert all(np.array_equal(a[k], b[k]) for k in a)
    assert not np.array_equal(a["wind_n"], c["wind_n"])
    assert np.all(np.diff(a["t"]) > 0) and np.std(np.diff(a["t"])) > 0  # jittered, still increasing


def test_true_aerodynamics_are_not_the_estimators_model():
    vehicle = true_vehicle(load_airframe(M300))
    yaw = np.zeros(4)
    air = np.array([[0.0, 0, 0], [5.0, 0, 0], [0, 5.0, 0], [0, 0, 2.0]])
    f = aerodynamic_force(vehicle, air, yaw)
    np.testing.assert_allclose(f[0], 0.0)
    assert f[1, 0] > 0 and f[2, 1] > 0 and f[3, 2] > 0  # drag along the air's relative motion
    assert f[1, 0] != pytest.approx(f[2, 1], rel=0.05)  # anisotropic: front and side differ
    diagonal = aerodynamic_force(vehicle, np.array([[3.0, 3.0, 0]]), np.zeros(1))[0]
    angle = math.degrees(math.atan2(diagonal[1], diagonal[0]))
    assert 0.5 < abs(angle - 45.0) < 2.0  # turned slightly off the airflow


def test_tunnel_and_still_air_truth(logs):
    tunnel = read_log(logs["tunnel"])
    speeds = [np.hypot(tunnel.columns["wind_n"], tunnel.columns["wind_e"])[tunnel.columns["segment"] == s][-50:].mean()
              for s in range(8)]
    np.testing.assert_allclose(speeds, np.arange(3, 11), atol=0.3)
    still = read_log(logs["still-air"])
    assert np.all(still.true_wind == 0.0) and np.ptp(still.columns["vel_n"]) > 3.0


# --- fit ----------------------------------------------------------------------------------------

def test_fit_recovers_the_thrust_scale_and_a_good_model(fitted, capsys):
    af = load_airframe(fitted)
    assert af.thrust.scale == pytest.approx(true_vehicle(af).thrust_scale, abs=0.004)
    assert max(abs(v) for v in af.observer.force_offset_n) < 0.1
    assert "fh^0.5" in af.horizontal.term_texts


def test_fit_report_json(logs, tmp_path, capsys):
    out = tmp_path / "f.toml"
    assert main(["fit", str(M300), logs["sweep"], logs["vertical"], "-o", str(out), "--json"]) == 0
    chosen = json.loads(capsys.readouterr().out)
    assert set(chosen["families"]) == {"drag", "drag-body", "polynomial"} and chosen["model"] in chosen["families"]
    best = min(f["score_mps"] for f in chosen["families"].values())
    tied = [k for k, f in chosen["families"].items() if f["score_mps"] <= best * (1 + FAMILY_TIE)]
    assert chosen["model"] in tied
    if "drag-body" in tied:  # fitfamily.TIE_PREFERRED
        assert chosen["model"] == "drag-body"
    assert chosen["self_check"]["passed"] and chosen["written"]
    first = out.read_text()
    # The paper's printed terms on this sweep: the fit's own CV looks tolerable per chunk, but the
    # training replay misses by more than a metre per second (the "terrible and silent" default).
    # The self-check refuses it: exit 1, the earlier result untouched.
    assert main(["fit", str(M300), logs["sweep"], logs["vertical"], "-o", str(out), "--json", "--model", "polynomial",
                 "--terms", "airframe"]) == 1
    report = json.loads(capsys.readouterr().out)
    assert report["horizontal_terms"] == ["1", "m", "n", "m^2", "n^2"]  # the airframe's own terms
    assert report["directions"] == 12 and report["speeds"] >= 8 and report["points"] > 100
    assert report["horizontal_cv_rmse_mps"] < 1.5
    assert not report["self_check"]["passed"] and not report["written"] and out.read_text() == first
    sweep = report["self_check"]["logs"][0]
    assert sweep["speed_rms_mps"] > report["self_check"]["replay_limit_mps"]
    assert (tmp_path / "f_fit.png").read_bytes()[:4] == b"\x89PNG"


def test_term_selection_returns_the_terms_the_data_was_made_from():
    """Vertical airflow made from fz and the inflow terms fh, fh^2 (with fz*abs(fz) and
    fz*abs(fz)^-0.5 as decoys that follow fz closely): exactly those three terms, nothing more."""
    rng = np.random.default_rng(4)
    groups = np.repeat(np.arange(60), 5)
    fz = np.repeat(rng.uniform(-4, 4, 60), 5) + rng.normal(0, 0.01, 300)
    fh = np.repeat(rng.uniform(0, 6, 60), 5)
    angle = rng.uniform(-np.pi, np.pi, 300)
    target = 0.4 * fz - 0.03 * fh ** 2 + 0.05 * fh + rng.normal(0, 0.005, 300)
    points = Points(fh * np.cos(angle), fh * np.sin(angle), fz, np.zeros(300), target, angle, groups)
    terms, score = select_terms(VERTICAL_CANDIDATES, points, target, max_terms=4)
    assert sorted(terms) == ["fh", "fh^2", "fz"]
    assert score < 0.01


def test_extrapolation_error_is_measured_on_the_top_holds_only():
    """Holds at 0..8 m/s of airflow whose speed is exactly sqrt(force): the right term extrapolates
    without error; a straight line fitted on the holds below 7.2 m/s (90 % of the top) misses the
    8 m/s hold by what a hand-made least squares gives."""
    speed = np.repeat(np.arange(0.0, 9.0), 4)
    groups = np.repeat(np.arange(9), 4)
    force = speed ** 2
    zeros = np.zeros(speed.size)
    points = Points(force, zeros, zeros, speed, zeros, zeros, groups)
    terms = _term_matrix(["fh^0.5", "fh"], points.m, points.n, points.fz)
    assert _extrapolation_rmse(terms[:, :1], speed, groups) == pytest.approx(0.0, abs=1e-9)
    below = speed < 7.2
    slope = np.sum(force[below] * speed[below]) / np.sum(force[below] ** 2)
    expected = abs(slope * 64.0 - 8.0)
    assert _extrapolation_rmse(terms[:, 1:], speed, groups) == pytest.approx(expected, rel=1e-9)


def test_one_direction_gives_a_warning_and_a_direction_free_model(logs):
    af = load_airframe(M300)
    new, report, _ = fit_polynomial(af, read_calibration_logs(af, [logs["tunnel"]]), "airframe")
    assert any("direction" in w for w in report.warnings)
    assert all(not ({"m", "n"} & t.variables) for t in new.horizontal.terms)
    assert all(math.isfinite(c) and abs(c) < 50 for c in new.horizontal.coefficients)
    fh = np.linspace(0.5, 8, 20)
    speed = sum(c * fh ** float(t.text.split("^")[1]) if "^" in t.text else c * fh
                for t, c in zip(new.horizontal.terms, new.horizontal.coefficients))
    assert np.all(np.diff(speed) > 0)  # more force, more airflow: sensible where the data is


def test_the_polynomial_family_fitted_from_a_drag_starter_is_a_polynomial_airframe(logs):
    """`dobwind init` writes a drag-family prior; when fit chooses the polynomial family, the airframe
    it returns must carry the fitted tables, not keep the prior's drag law (which the step would run)."""
    import dataclasses

    from dobwind.model.airframe import ForceAirModel, parse_airframe
    from dobwind.model.airframe_toml import dump_airframe
    from dobwind.model.forceair import DragLaw

    starter = dataclasses.replace(load_airframe(M300), drag=DragLaw(0.4, 0.02))
    new, _, _ = fit_polynomial(starter, read_calibration_logs(starter, [logs["sweep"]]), "airframe")
    assert new.drag is None and new.force_air_model == "polynomial"
    written = parse_airframe(dump_airframe(new), "fitted.toml")
    assert written.drag is None and written.horizontal.coefficients == pytest.approx(new.horizontal.coefficients)
    # As init writes it: no polynomial tables at all. A level sweep does not move the air vertically,
    # and there is no vertical table to keep: one is fitted (and said), so the airframe can be written.
    bare = dataclasses.replace(starter, horizontal=ForceAirModel((), ()), vertical=ForceAirModel((), ()))
    new, report, points = fit_polynomial(bare, read_calibration_logs(bare, [logs["sweep"]]), "auto")
    assert new.vertical.terms and new.drag is None
    assert float(np.ptp(points.air_z)) < 1.0  # the case this checks: nothing vertical to fit on (0.02 m/s)
    assert any("no polynomial vertical model to keep" in w for w in report.warnings), report.warnings
    assert parse_airframe(dump_airframe(new), "fitted.toml").vertical.term_texts == new.vertical.term_texts


# --- replay -------------------------------------------------------------------------------------

def test_replay_backends_agree_and_output_has_every_row(fitted, logs, tmp_path):
    af = load_airframe(fitted)
    model, log, py = replay(af, logs["outdoor"], "python")
    _, _, c = replay(af, logs["outdoor"], "c", "single")
    tol = TOLERANCE["single"]
    wind = model.outputs.slice("wind_ned")
    assert np.all(np.abs(c.outputs[:, wind] - py.outputs[:, wind]) <= tol.atol * 5 + tol.rtol * np.abs(py.outputs[:, wind]))
    np.testing.assert_array_equal(c.status, py.status)
    out = tmp_path / "est.csv"
    assert main(["replay", str(fitted), logs["outdoor"], "-o", str(out), "--backend", "c"]) == 0
    lines = out.read_text().splitlines()
    assert lines[0] == ",".join(ESTIMATE_COLUMNS) and len(lines) == log.rows + 1


def test_bad_rows_get_a_status_and_the_estimate_recovers(logs, tmp_path):
    """Replayed with the airframe the logs were simulated with (the statuses and the settling do not
    depend on a fit: a fitted one would cost test-fast a fit for this test alone)."""
    text = open(logs["tunnel"]).read().splitlines()
    header_at = next(i for i, line in enumerate(text) if not line.startswith("#"))
    cols = text[header_at].split(",")
    row = text[header_at + 2000].split(",")
    row[cols.index("vel_n")] = "nan"
    row[cols.index("q_w")] = ""
    text[header_at + 2000] = ",".join(row)
    path = tmp_path / "holes.csv"
    path.write_text("\n".join(text) + "\n")
    model, log, traj = replay(load_airframe(M300), str(path))
    assert traj.status[1999] & REJECTED_MASK and np.all(accepted(traj.status[2000:]))
    # The rows after the hole are flagged SETTLING for one settling time of accepted time, then never.
    settling = (traj.status & STATUS_SETTLING) != 0
    after = log.time_s - log.time_s[2000] + (log.time_s[2000] - log.time_s[1999])  # accepted time at each row
    expected = (after > 0) & (after < model.settling_time_s - 1e-9)
    np.testing.assert_array_equal(settling[2000:], expected[2000:])
    assert settling[2000] and not settling[1998]
    wind = traj.outputs[:, model.outputs.slice("wind_speed_h")].ravel()
    assert np.all(np.isfinite(wind)) and wind[1999] == wind[1998]


def test_accuracy_on_the_projects_simulator(fitted, logs):
    """A regression guard, looser than the README's measured figures (those use 20 s holds, 50 Hz)."""
    af = load_airframe(fitted)
    tunnel = score(*_scored(af, logs["tunnel"]))
    assert tunnel["per_segment"]["speed_mean"] < 0.2 and tunnel["per_segment"]["direction_mean"] < 3.0
    still = score(*_scored(af, logs["still-air"]))
    # 0.19 m/s here; without the acceleration bias estimate the same logs read 0.25.
    assert still["mean_estimated_wind"]["horizontal_mps"] < 0.22 and still["mean_estimated_wind"]["vertical_mps"] < 0.2


def _scored(af, path):
    model, log, traj = replay(af, path)
    return log, traj, model


def test_tilt_baseline_tracks_steady_wind_but_not_manoeuvres(logs):
    af = load_airframe(M300)
    needed = required_columns(af) + [("wind_n", "truth")]
    model = baseline.calibrate([read_log(logs["sweep"], needed)])
    tunnel = read_log(logs["tunnel"], needed)
    wind = baseline.estimate(model, tunnel)
    true_speed = np.hypot(tunnel.columns["wind_n"], tunnel.columns["wind_e"])
    late = tunnel.time_s > 20
    assert np.mean(np.abs(np.hypot(wind[late, 0], wind[late, 1]) - true_speed[late])) < 1.0
    still = read_log(logs["still-air"], needed)
    assert np.mean(np.hypot(*baseline.estimate(model, still)[:, :2].T)) > 0.1
