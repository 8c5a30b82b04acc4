"""A fitted drag law must increase everywhere the step may invert it (model/forceair.law_decreasing), and
the fit never chooses one that does not (dragfit.choose_drag_law).

Why: with no linear drag (l0 = 0) any linear anisotropy (l2c, l2s) makes the law's slope negative next
to zero airflow in some direction; two airflows then give one force there and the Newton inversion runs
off (a random 0.6 kg vehicle's held-out samples at 0.01-0.05 m/s came back at thousands of m/s)."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from dobwind.calibrate import dragfit, holdcv
from dobwind.model.airframe import load_airframe
from dobwind.model.forceair import DragLaw, drag_airflow_numpy, drag_force, law_decreasing
from tests.helpers import M300, observed_force


def _angle(where: str) -> float:
    return float(where.split(" deg")[0])


def _speed(where: str) -> float:
    return float(where.split(" at ")[1].split(" m/s")[0])


def test_isotropic_non_negative_laws_increase():
    for law in (DragLaw(0.3, 0.0), DragLaw(0.0, 0.05), DragLaw(0.2, 0.04, lz=0.1, qz=0.1, i1=0.01, i2=-0.003)):
        assert law_decreasing(law, 15.0) is None


def test_linear_anisotropy_beyond_the_linear_drag_decreases_near_zero():
    """Along theta the radial slope next to zero is l0 + l2c cos 2theta: negative for |l2c| > l0, first
    on the 5-degree grid at 70 deg (cos 2theta < -l0/l2c = -2/3 past 65.9 deg) for l0 = 0.1, l2c = 0.15;
    with |l2c| below l0 it stays positive (quadratic drag only adds to it)."""
    assert law_decreasing(DragLaw(0.1, 0.05, l2c=0.09), 12.0) is None
    where = law_decreasing(DragLaw(0.1, 0.05, l2c=0.15), 12.0)
    assert where is not None and _angle(where) == 70 and "next to zero airflow" in where
    where = law_decreasing(DragLaw(0.0, 0.04, l2c=0.005), 12.0)  # the fitted law of the vehicle above
    assert where is not None and "next to zero airflow" in where


def test_a_tiny_linear_harmonic_on_no_linear_drag_is_caught_below_the_grid():
    """l0 = 0, l2c = 3e-4: the law decreases only below |l2c| / (2 q0) = 0.004 m/s, under the speed
    grid, yet its inversion at 0.01 m/s is off by more than twice that speed; the linear part's own
    check sees it. No linear part at all (a pure quadratic law) is allowed."""
    law = DragLaw(0.0, 0.04, l2c=3e-4)
    assert law_decreasing(law, 12.0) is not None
    angle = np.linspace(0, 2 * math.pi, 720, endpoint=False)
    vx, vy = 0.01 * np.cos(angle), 0.01 * np.sin(angle)
    fx, fy, fz = drag_force(law, vx, vy, np.zeros_like(vx))
    back = drag_airflow_numpy(law, fx, fy, fz)
    assert np.nanmax(np.hypot(back[:, 0] - vx, back[:, 1] - vy)) > 0.02  # the premise
    assert law_decreasing(DragLaw(0.0, 0.04, q2c=0.01), 12.0) is None


def test_quadratic_anisotropy_beyond_q0_decreases_where_it_dominates():
    """l0 = 0.5, q0 - q2c = -0.03 along 90 deg: the radial force 0.5 s - 0.03 s^2 peaks at s = 8.33 m/s.
    Checked to 6 m/s it increases; to 12 m/s it does not, first past the peak."""
    law = DragLaw(0.5, 0.05, q2c=0.08)
    assert law_decreasing(law, 6.0) is None
    where = law_decreasing(law, 12.0)
    assert where is not None and 8.33 < _speed(where) < 9.5 and abs(_angle(where) - 90) < 31


def test_body_frame_rotor_term_counts():
    """Body frame: the linear drag is l0 + lr * rotor, so the same linear anisotropy is safe at hover
    (rotor term 1) and not at a low rotor term (a descent at low thrust)."""
    law = DragLaw(0.0, 0.05, l2c=0.05, lr=0.1, lz=0.1, frame="body")
    assert law_decreasing(law, 12.0, (1.0,)) is None
    where = law_decreasing(law, 12.0, (1.0, 0.3))
    assert where is not None and "rotor term 0.30" in where


def test_a_decreasing_law_is_what_breaks_the_inversion():
    """The premise, on the NumPy transcription of the step's inversion: forward then inverted, an
    increasing anisotropic law round-trips at small airflow; the decreasing one does not."""
    angle = np.linspace(0, 2 * math.pi, 360, endpoint=False)
    vx, vy = 0.03 * np.cos(angle), 0.03 * np.sin(angle)
    for law, ok in ((DragLaw(0.01, 0.04, l2c=0.008), True), (DragLaw(0.0, 0.04, l2c=0.008), False)):
        fx, fy, fz = drag_force(law, vx, vy, np.zeros_like(vx))
        back = drag_airflow_numpy(law, fx, fy, fz)
        error = np.hypot(back[:, 0] - vx, back[:, 1] - vy)
        assert (np.nanmax(error) < 1e-3) == ok
        assert (law_decreasing(law, 12.0) is None) == ok


def _samples(law: DragLaw, noise_n: float, seed: int = 5) -> dragfit.DragSamples:
    """Samples as the fit makes them (H applied to the law's force) from 20 s holds at random headings
    and airflow up to 9 m/s, some near zero."""
    af = load_airframe(M300)
    rate, seconds = 50.0, 1600.0
    rng = np.random.default_rng(seed)
    holds = int(seconds / 20)
    t = np.arange(int(rate * seconds)) / rate
    yaw = np.repeat(rng.uniform(-math.pi, math.pi, holds), int(rate * 20))
    wind = np.repeat(np.where(rng.random(holds) < 0.2, 0.02, rng.uniform(0, 9, holds)), int(rate * 20))
    air = np.column_stack([wind, np.zeros_like(wind), np.repeat(rng.uniform(-2, 2, holds), int(rate * 20))])
    c, s = np.cos(yaw), np.sin(yaw)
    air_c = np.column_stack([c * air[:, 0] + s * air[:, 1], -s * air[:, 0] + c * air[:, 1], air[:, 2]])
    fx, fy, fz = drag_force(law, air_c[:, 0], air_c[:, 1], air_c[:, 2])
    thrust = np.column_stack([np.zeros_like(t), np.zeros_like(t), np.full_like(t, 78.0)])
    force = np.column_stack([c * fx - s * fy, s * fx + c * fy, fz])
    observed = observed_force(af, rate, force, noise_n, rng)
    part = dragfit.log_samples(af, 0.5, t, observed, air, thrust, yaw, np.ones(len(t), dtype=bool))
    return dragfit.merge([part])


# Bluff-body drag with y 50 % above x and no linear drag at all (the 0.6 kg vehicle's kind).
QUADRATIC_ONLY = DragLaw(0.0, 0.05, q2c=-0.01, lz=0.2, qz=0.1)


@pytest.fixture(scope="module")
def quadratic_only() -> dragfit.DragSamples:
    return _samples(QUADRATIC_ONLY, 0.1)


def test_quadratic_anisotropy_without_linear_drag_is_found(quadratic_only):
    """Without the quadratic-anisotropy set, the fit could only choose an isotropic law here (the full
    set's linear harmonics decrease): the direction of the air would be 'along the force', 5-11 deg off."""
    choice = dragfit.choose_drag_law(quadratic_only, holdcv.prefer_on_holds)
    assert "q2c" in choice.active and "l2c" not in choice.active
    assert dragfit.decreasing_at(quadratic_only, choice.theta) is None
    got = dict(zip(quadratic_only.parameters, choice.theta))
    assert got["q2c"] == pytest.approx(QUADRATIC_ONLY.q2c, abs=0.003)


def test_a_set_whose_law_decreases_is_dropped_and_the_choice_made_again(quadratic_only, monkeypatch):
    """Only the isotropic quadratic and the full set offered: the full set fits the anisotropy better,
    but with l0 at its bound 0 its linear harmonics make the law decrease, so it is not chosen, and the
    report says why."""
    full = ("l0", "q0", "l2c", "q2c", "l2s", "q2s")
    monkeypatch.setattr(dragfit, "HORIZONTAL_SETS", (("q0",), full))
    theta = dragfit.robust_fit(quadratic_only, full + dragfit.VERTICAL_SETS[-1] + dragfit.ALWAYS)
    assert dragfit.decreasing_at(quadratic_only, theta) is not None  # the premise
    choice = dragfit.choose_drag_law(quadratic_only, holdcv.prefer_on_holds)
    assert choice.active[:1] == ("q0",) and "l2c" not in choice.active
    assert len(choice.dropped) == 1 and choice.dropped[0].startswith("+".join(full) + ": the law decreases at ")
    assert dragfit.decreasing_at(quadratic_only, choice.theta) is None


def test_the_report_names_a_dropped_set():
    from dobwind.calibrate.fit import FitReport
    from dobwind.calibrate.fitreport import text_report

    report = FitReport(model="drag", drag={"l0": 0.0, "q0": 0.05}, horizontal_rmse_mps=0.1, vertical_rmse_mps=0.1,
                       not_increasing=["l0+q0+l2c: the law decreases at 70 deg from x at 0.01 m/s"])
    assert "  not chosen: l0+q0+l2c: the law decreases at 70 deg from x at 0.01 m/s" in text_report(report)
    assert "not chosen" not in text_report(dataclasses.replace(report, not_increasing=[]))


def test_linear_anisotropy_the_data_need_is_kept():
    """Per-axis linear drag, y 22 % above x (l2c = -l2s = 0.03 on l0 = 0.3): the quadratic-only
    anisotropy fits it nearly as well on noisy samples (within the 2 % tie) but reads the air's direction
    3-5 deg off at low airflow, so it is only a last resort: the set with linear harmonics is chosen."""
    samples = _samples(DragLaw(0.3, 0.03, l2c=0.03, l2s=-0.03, lz=0.2, qz=0.1), 0.1, seed=7)
    choice = dragfit.choose_drag_law(samples, holdcv.prefer_on_holds)
    assert "l2c" in choice.active and "l2s" in choice.active
    got = dict(zip(samples.parameters, choice.theta))
    assert got["l2c"] == pytest.approx(0.03, abs=0.01) and got["l2s"] == pytest.approx(-0.03, abs=0.01)


def test_a_family_whose_every_law_decreases_is_refused_with_the_reason(quadratic_only, monkeypatch):
    """Only the full set offered and its law decreases: the drag family is not fitted, and the reason
    says where (fitfamily._drag_families, which fit then reports as a failure or falls back)."""
    from dobwind.calibrate import fitfamily

    monkeypatch.setattr(dragfit, "HORIZONTAL_SETS", (("l0", "q0", "l2c", "q2c", "l2s", "q2s"),))
    families, scores, failures = fitfamily._drag_families(load_airframe(M300), {"heading": quadratic_only},
                                                         ("heading",), len(quadratic_only))
    assert families == {} and scores == {}
    assert len(failures) == 1 and failures[0].startswith("drag family: the fitted law decreases at ")


def test_no_vertical_drag_is_refused(quadratic_only):
    """lz = qz = 0 leaves the vertical inversion 2 r / max(0, 1e-9): the family is refused."""
    from dobwind.calibrate import fitfamily

    choice = dragfit.choose_drag_law(quadratic_only, holdcv.prefer_on_holds)
    theta = choice.theta.copy()
    for key in ("lz", "qz"):
        theta[quadratic_only.parameters.index(key)] = 0.0
    flat = dataclasses.replace(choice, theta=theta)
    assert fitfamily._uninvertible(quadratic_only, choice) is None
    assert "no vertical drag" in fitfamily._uninvertible(quadratic_only, flat)
