"""The direction shape a `--truth sitl` fit ties to its quadratic term (dobwind/calibrate/directionshape.py).

ArduPilot SITL's multicopter applies its quadratic drag on each body axis, c (|a_x| a_x, |a_y| a_y). The
ratios of the law's four-fold harmonics to q0 are pinned here by a numerical Fourier series of that force
(not by the closed forms the module states), the shaped law by the per-axis force itself, and the tie by a
fit on front/back airflow only, read at the diagonals it never saw."""
from __future__ import annotations

import dataclasses
import math

from pathlib import Path

import numpy as np
import pytest

from dobwind.calibrate import dragfit
from dobwind.calibrate.directionshape import ARDUPILOT_SITL
from dobwind.model.forceair import DragLaw, drag_airflow_numpy, drag_force
from dobwind.model.kinds import DragFrame

C = 0.1          # N/(m/s)^2, the per-axis quadratic coefficient (areaCd 0.5 rho)
L0 = 0.7         # N/(m/s), linear (momentum) drag: isotropic, as ArduPilot's per-axis linear term is


def per_axis_force(ax: np.ndarray, ay: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return L0 * ax + C * np.abs(ax) * ax, L0 * ay + C * np.abs(ay) * ay


def test_ratios_are_the_fourier_coefficients_of_the_per_axis_force():
    t = np.linspace(0.0, 2 * math.pi, 720_001)[:-1]
    fx, fy = C * np.abs(np.cos(t)) * np.cos(t), C * np.abs(np.sin(t)) * np.sin(t)
    along = fx * np.cos(t) + fy * np.sin(t)      # per unit s^2
    across = -fx * np.sin(t) + fy * np.cos(t)
    mean = along.mean()
    ratios = dict(ARDUPILOT_SITL.ratios)
    assert ratios["q4c"] == pytest.approx(2 * (along * np.cos(4 * t)).mean() / mean, abs=1e-9)
    assert ratios["q4s"] == pytest.approx(2 * (across * np.sin(4 * t)).mean() / mean, abs=1e-9)


def _shaped_law(q0: float) -> DragLaw:
    ratios = dict(ARDUPILOT_SITL.ratios)
    return DragLaw(l0=L0, q0=q0, q4c=ratios["q4c"] * q0, q4s=ratios["q4s"] * q0, lz=0.5)


def test_the_shaped_law_is_the_per_axis_force_within_its_eighth_harmonics():
    t = np.radians(np.arange(0.0, 360.0, 1.0))
    mean = 8 / (3 * math.pi) * C   # the mean of the along-airflow part: the isotropic coefficient
    for s in (2.0, 8.0, 15.0):
        ax, ay = s * np.cos(t), s * np.sin(t)
        want_x, want_y = per_axis_force(ax, ay)
        got_x, got_y, _ = drag_force(_shaped_law(mean), ax, ay, np.zeros_like(ax))
        error = np.hypot(got_x - want_x, got_y - want_y) / (C * s * s)
        assert error.max() < 0.02
        # the isotropic law with the same mean is 15-17 % off at the axes and the diagonals
        iso_x, iso_y, _ = drag_force(DragLaw(l0=L0, q0=mean, lz=0.5), ax, ay, np.zeros_like(ax))
        assert (np.hypot(iso_x - want_x, iso_y - want_y) / (C * s * s)).max() > 0.14


def _front_back_samples() -> dragfit.DragSamples:
    """A flight that met the air from within 20 deg of the nose and the tail only, 1-9 m/s, with noise."""
    rng = np.random.default_rng(5)
    n = 1600
    speed = np.linspace(1.0, 9.0, n)
    direction = np.radians(rng.uniform(-20.0, 20.0, n)) + np.where(np.arange(n) % 2 == 0, 0.0, math.pi)
    air = np.column_stack([speed * np.cos(direction), speed * np.sin(direction), 0.3 * np.sin(np.arange(n) / 9)])
    columns = dragfit.basis(air)
    fx, fy = per_axis_force(air[:, 0], air[:, 1])
    force = np.column_stack([fx, fy, 0.5 * air[:, 2]]) + 0.03 * rng.standard_normal((n, 3))
    return dragfit.DragSamples(force, columns, np.ones(n), np.zeros(n), air, (np.arange(n) // 200).astype(int),
                               np.zeros(n, dtype=int))


def _diagonal_speed(theta: np.ndarray, samples: dragfit.DragSamples, s: float) -> float:
    """The law's inversion of the per-axis force of s m/s from 45 deg off the nose: the speed it reads."""
    law = dragfit.law_of(theta, samples.frame, samples.exponent)
    a = s / math.sqrt(2)
    fx, fy = per_axis_force(np.array([a]), np.array([a]))
    airflow = drag_airflow_numpy(law, fx, fy, np.zeros(1))
    return float(np.hypot(airflow[0, 0], airflow[0, 1]))


ACTIVE = ("l0", "q0") + dragfit.VERTICAL_SETS[-1] + dragfit.ALWAYS


def test_a_front_back_flight_fits_the_tied_shape_and_reads_the_diagonals():
    samples = _front_back_samples()
    shaped = dragfit.shape_if_unidentified(samples, ARDUPILOT_SITL)
    assert shaped.direction_shape is ARDUPILOT_SITL
    theta = dragfit.robust_fit(shaped, ACTIVE)
    values = dict(zip(shaped.parameters, theta))
    ratios = dict(ARDUPILOT_SITL.ratios)
    assert values["q4c"] == pytest.approx(ratios["q4c"] * values["q0"], rel=1e-12)
    assert values["q4s"] == pytest.approx(ratios["q4s"] * values["q0"], rel=1e-12)
    # the columns times the coefficients are the law's force: the tied harmonics' columns add nothing
    fx, fy, _ = drag_force(dragfit.law_of(theta), shaped.airflow[:, 0], shaped.airflow[:, 1], shaped.airflow[:, 2])
    modelled = np.einsum("nap,p->na", shaped.columns, theta)
    assert np.allclose(modelled[:, 0] - values["ox"], fx, atol=1e-9) and np.allclose(modelled[:, 1] - values["oy"], fy, atol=1e-9)
    # along the axis the law is the per-axis force: q0 (1 + 6/35) = C, as the front/back data say
    assert values["q0"] * (1 + ratios["q4c"]) == pytest.approx(C, rel=0.03)
    for s in (5.0, 12.0):   # inside and beyond the calibrated 9 m/s
        assert _diagonal_speed(theta, shaped, s) == pytest.approx(s, abs=0.05 * s)
    # the isotropic law from the same samples reads the diagonal air slow (its force there is too large)
    iso = dragfit.robust_fit(samples, ACTIVE)
    assert _diagonal_speed(iso, samples, 12.0) < 12.0 - 1.0


def test_a_flight_that_identifies_the_harmonics_is_not_shaped():
    samples = _front_back_samples()
    rng = np.random.default_rng(1)
    turned = rng.uniform(0.0, 2 * math.pi, len(samples))
    air = samples.airflow.copy()
    speed = np.hypot(air[:, 0], air[:, 1])
    air[:, 0], air[:, 1] = speed * np.cos(turned), speed * np.sin(turned)
    every_way = dragfit.DragSamples(samples.observed, dragfit.basis(air), samples.cos_yaw, samples.sin_yaw, air,
                                    samples.group, samples.log_index)
    assert dragfit.shape_if_unidentified(every_way, ARDUPILOT_SITL) is every_way
    assert dragfit.shape_if_unidentified(samples, None) is samples


def test_the_tie_survives_a_selection_and_another_exponent():
    shaped = dragfit.shape_if_unidentified(_front_back_samples(), ARDUPILOT_SITL)
    part = shaped.select(np.arange(len(shaped)) % 3 != 0)
    other = dragfit.with_exponent(shaped, 1.8)
    for s in (part, other):
        assert s.direction_shape is ARDUPILOT_SITL
        values = dict(zip(s.parameters, dragfit.robust_fit(s, ACTIVE)))
        assert values["q4c"] == pytest.approx(dict(ARDUPILOT_SITL.ratios)["q4c"] * values["q0"], rel=1e-12)


def test_the_run_mean_anchored_fit_keeps_the_tie():
    samples = _front_back_samples()
    logs = dataclasses.replace(samples, log_index=(np.arange(len(samples)) * 4 // len(samples)).astype(int), anchor=True)
    shaped = dragfit.shape_if_unidentified(logs, ARDUPILOT_SITL)
    theta, _ = dragfit.anchored_theta(shaped, ACTIVE, dragfit.robust_fit(shaped, ACTIVE))
    values = dict(zip(shaped.parameters, theta))
    assert values["q0"] > 0
    assert values["q4s"] == pytest.approx(dict(ARDUPILOT_SITL.ratios)["q4s"] * values["q0"], rel=1e-12)


def test_only_the_sitl_truth_carries_the_shape():
    from dobwind.calibrate.fieldtruth import parse_wind
    from dobwind.calibrate.sitlwind import SitlTruth

    assert SitlTruth.direction_shape is ARDUPILOT_SITL
    assert getattr(parse_wind("5@90"), "direction_shape", None) is None


@pytest.fixture(scope="module")
def one_heading_bin(tmp_path_factory):
    """The SITL stand-in flown along one track (air from the nose only), written as an ArduCopter log."""
    pytest.importorskip("pymavlink")
    from benchmarks.sitlconvert import main as convert_main
    from dobwind.cli.app import main

    root = Path(__file__).resolve().parents[1] / "benchmarks" / "vehicles" / "arducopter"
    out = tmp_path_factory.mktemp("oneheading")
    csv, log, start = out / "oh.csv", out / "oh.bin", out / "start.toml"
    assert main(["simulate", "one-heading", "--airframe", f"{root}.airframe.toml", "--vehicle", f"{root}.vehicle.toml",
                 "--wind", "5@37", "--seed", "11", "-o", str(csv)]) == 0
    assert convert_main([str(csv), "--wind", "5@37", "-o", str(log)]) == 0
    assert main(["init", str(log), "--mass", "3.0", "-o", str(start)]) == 0
    return out, log, start


@pytest.mark.parametrize("truth, shaped", [(["--truth", "sitl"], True), (["--wind", "5@37"], False)])
def test_fit_ties_the_shape_for_a_sitl_truth_only(one_heading_bin, truth, shaped, capsys):
    from dobwind.cli.app import main
    from dobwind.model.airframe import load_airframe

    out, log, start = one_heading_bin
    fitted = out / f"fit_{shaped}.toml"
    assert main(["fit", str(start), str(log), *truth, "-o", str(fitted)]) == 0
    err = capsys.readouterr().err
    law = load_airframe(str(fitted)).drag
    if shaped:
        assert law.q4c == pytest.approx(6 / 35 * law.q0, rel=1e-9) and law.q4s == pytest.approx(-8 / 35 * law.q0, rel=1e-9)
        assert law.q0 > 0 and "per-body-axis" in err
    else:
        assert law.q4c == 0.0 and law.q4s == 0.0 and "an isotropic law instead" in err


def _three_track_samples() -> dragfit.DragSamples:
    """Three logs, each flown with the air from one side of the nose only: straight on, 38 deg left and 38
    deg right (+-6 deg), 1-12 m/s. Two 45-deg sectors of the axis: the harmonics are not identified."""
    rng = np.random.default_rng(3)
    n = 600
    air = []
    for centre in (0.0, 38.0, -38.0):
        speed = np.linspace(1.0, 12.0, n)
        direction = np.radians(centre + rng.uniform(-6.0, 6.0, n))
        air.append(np.column_stack([speed * np.cos(direction), speed * np.sin(direction), 0.3 * np.sin(np.arange(n) / 9)]))
    airflow = np.vstack(air)
    fx, fy = per_axis_force(airflow[:, 0], airflow[:, 1])
    force = np.column_stack([fx, fy, 0.5 * airflow[:, 2]]) + 0.03 * rng.standard_normal((len(airflow), 3))
    return dragfit.DragSamples(force, dragfit.basis(airflow), np.ones(len(airflow)), np.zeros(len(airflow)), airflow,
                               (np.arange(len(airflow)) // 200).astype(int), np.repeat(np.arange(3), n))


def test_whether_to_fit_on_the_run_means_is_decided_with_the_tied_law():
    """The isotropic law cannot meet the three tracks' means (the per-axis force at 38 deg is 0.8 of the
    along-axis one), the tied law meets them: the fit, which fits the tied law, fits it per sample.
    Deciding with the isotropic law anchored it on the run means (fitfamily tied after anchor_on_runs)."""
    from dobwind.calibrate import fitfamily
    from dobwind.model.airframe import load_airframe

    samples = _three_track_samples()
    assert not dragfit.direction_coverage(samples.airflow).allows(dragfit.FOURFOLD_KEYS)
    assert dragfit.anchor_on_runs(samples).anchor   # the isotropic law misses some log's mean by > 0.25 m/s
    af = load_airframe(str(Path(__file__).resolve().parents[1] / "benchmarks" / "vehicles" / "arducopter.airframe.toml"))
    by_frame = {DragFrame.HEADING: samples}
    families, _, failures = fitfamily._drag_families(af, by_frame, (DragFrame.HEADING,), len(samples), ARDUPILOT_SITL)
    assert not failures
    report, law = families["drag"][1], families["drag"][0].drag
    assert not report.anchored and not by_frame[DragFrame.HEADING].anchor
    assert law.q4c == pytest.approx(6 / 35 * law.q0, rel=1e-9) and law.q0 > 0
    assert max(run.error_mps for run in report.runs) < 0.1


M_KG, G_MPS2 = 3.0, 9.81


def _tilt(axis: np.ndarray, angle: float) -> np.ndarray:
    """The rotation by ``angle`` about the unit ``axis`` (Rodrigues)."""
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def _tilted_samples(speed: np.ndarray, direction: np.ndarray, seed: int, frame: DragFrame) -> dragfit.DragSamples:
    """Level airflow (yaw 0), the vehicle tilted so that its thrust balances the drag, the drag per BODY
    axis on all three axes, as ArduPilot SITL applies it: 3 kg, up to 24 deg at 9 m/s, 30 deg at 12. The
    samples of ``frame``'s law."""
    rng = np.random.default_rng(seed)
    n = len(speed)
    air = np.column_stack([speed * np.cos(direction), speed * np.sin(direction), 0.3 * np.sin(np.arange(n) / 9)])
    rotation, force = np.zeros((n, 3, 3)), np.zeros((n, 3))
    for i in range(n):
        r = np.eye(3)
        for _ in range(3):   # the tilt depends on the drag, the drag on the tilt: a few fixed-point rounds
            body = r.T @ air[i]
            f = r @ (L0 * body + C * np.abs(body) * body)
            across = np.array([-f[1], f[0], 0.0]) / max(math.hypot(f[0], f[1]), 1e-12)
            r = _tilt(across, math.atan2(math.hypot(f[0], f[1]), M_KG * G_MPS2))
        rotation[i], force[i] = r, f
    thrust = np.einsum("nij,j->ni", rotation, np.array([0.0, 0.0, -M_KG * G_MPS2]))
    assert np.all(np.einsum("ni,ni->n", thrust[:, :2], force[:, :2]) <= 1e-9)   # leaning against the drag
    observed = force + 0.03 * rng.standard_normal((n, 3))
    group, logs = (np.arange(n) // 200).astype(int), np.zeros(n, dtype=int)
    if frame == DragFrame.HEADING:   # yaw 0: NED is the heading frame
        return dragfit.DragSamples(observed, dragfit.basis(air), np.ones(n), np.zeros(n), air, group, logs)
    columns = dragfit.body_columns(air, rotation, np.ones(n), np.ones(n), np.zeros(n), thrust)
    return dragfit.DragSamples(observed, columns, np.ones(n), np.zeros(n), air, group, logs, frame, rotation, np.ones(n))


@pytest.mark.parametrize("frame", [DragFrame.HEADING, DragFrame.BODY])
def test_either_frame_carries_the_tie_at_a_sitl_flights_tilt(frame):
    """Both families tie the same way (the body frame's basis, model/forceair.body_drag_basis, has its own
    four-fold columns), and the heading frame's law, which sees the per-body-axis force through the tilt
    (its true ratios fall to 0.162 and -0.230 at 20 deg), carries it as well: fitted on tilted front/back
    flight, each reads tilted diagonal air of 5 and 12 m/s within 2 %, where its isotropic law reads it
    8-11 % slow."""
    rng = np.random.default_rng(5)
    n = 1600
    direction = np.radians(rng.uniform(-20.0, 20.0, n)) + np.where(np.arange(n) % 2 == 0, 0.0, math.pi)
    train = _tilted_samples(np.linspace(1.0, 9.0, n), direction, 5, frame)
    shaped = dragfit.shape_if_unidentified(train, ARDUPILOT_SITL)
    assert shaped.direction_shape is ARDUPILOT_SITL
    active = ("l0", "q0", "lz", "qz") + dragfit.ALWAYS
    theta, iso = dragfit.robust_fit(shaped, active), dragfit.robust_fit(train, active)
    for s in (5.0, 12.0):
        test = _tilted_samples(np.full(40, s), np.full(40, math.pi / 4), 1, frame)
        tied_air = dragfit.predicted_airflow(dragfit.tie_to_q0(test, ARDUPILOT_SITL), theta)
        iso_air = dragfit.predicted_airflow(test, iso)
        assert np.hypot(tied_air[:, 0], tied_air[:, 1]).mean() == pytest.approx(s, rel=0.02)
        assert np.degrees(np.arctan2(tied_air[:, 1], tied_air[:, 0])).mean() == pytest.approx(45.0, abs=0.5)
        assert np.hypot(iso_air[:, 0], iso_air[:, 1]).mean() < 0.93 * s


def test_the_warning_names_the_shape_only_when_the_law_has_a_quadratic_term():
    """A tied law with q0 says it took the shape; one whose chosen set has no quadratic term (or whose q0 was
    dropped for its sign) is isotropic and says so; untied samples say isotropic."""
    from dobwind.calibrate import fitfamily, holdcv

    samples = _front_back_samples()
    shaped = dragfit.shape_if_unidentified(samples, ARDUPILOT_SITL)
    choice = dragfit.choose_drag_law(shaped, holdcv.prefer_on_holds)
    assert choice.directions is not None and "q0" in choice.active
    [warning] = fitfamily._directions_warning(choice, shaped)
    assert "takes the shape of ArduPilot SITL's per-body-axis" in warning and "q4s = -0.2286 q0" in warning
    linear = ("l0",) + dragfit.VERTICAL_SETS[-1] + dragfit.ALWAYS
    without = dataclasses.replace(choice, active=linear, theta=dragfit.robust_fit(shaped, linear))
    dropped = dataclasses.replace(choice, theta=np.where(np.array(shaped.parameters) == "q0", 0.0, choice.theta))
    for isotropic, of in ((without, shaped), (dropped, shaped), (choice, samples)):
        [warning] = fitfamily._directions_warning(isotropic, of)
        assert "an isotropic law instead" in warning and "shape" not in warning
