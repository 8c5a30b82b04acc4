"""The drag law's exponent (model/forceair.py, dobwind/calibrate/dragexponent.py): the quadratic terms grow as s^p.

Pinned: the forward law against a transcription of its formula, the inversion at 1.5 <= p <= 2.5, a
quadratic law's step without any power, the airframe key, the fit's columns for another exponent, and the
choice of the exponent on samples made from laws of known exponent."""
from __future__ import annotations

import copy
import dataclasses
import functools
import math

import numpy as np
import pytest

from dobwind.calibrate import dragexponent, dragfit, holdcv
from dobwind.calibrate.reportparts import FamilyScores, HoldCvBySpeed, HoldScores
from dobwind.model.airframe import load_airframe, parse_airframe
from dobwind.model.airframe_toml import dump_airframe
from dobwind.model.forceair import (DragLaw, body_drag_airflow_numpy, body_drag_basis, body_drag_force,
                                    drag_airflow_numpy, drag_force, horizontal_drag_basis, speed_power)
from tests.helpers import M300, hold_samples, random_body_flight


def _transcribed_force(law: DragLaw, a: np.ndarray, rotor: np.ndarray) -> np.ndarray:
    """The body-frame law per sample in polar form, its quadratic terms as q s^(p-1) |a_h|."""
    out = np.empty_like(a)
    p = law.exponent
    for i, ((ax, ay, az), r) in enumerate(zip(a, rotor)):
        s, sh, theta = math.sqrt(ax * ax + ay * ay + az * az), math.hypot(ax, ay), math.atan2(ay, ax)
        grow = s ** (p - 1)
        along = (law.l0 + law.lr * r + law.q0 * grow + (law.l2c + law.q2c * grow) * math.cos(2 * theta)) * sh \
            + law.q1c * s ** (p - 2) * sh * sh * math.cos(theta)
        across = (law.l2s + law.q2s * grow) * math.sin(2 * theta) * sh
        out[i] = (along * math.cos(theta) - across * math.sin(theta), along * math.sin(theta) + across * math.cos(theta),
                  law.lz * az + law.qz * s * az + law.i1 * sh + law.i2 * sh * sh)
    return out


LAW = DragLaw(0.05, 0.1, l2c=-0.006, q2c=-0.0125, l2s=0.006, q2s=0.0125, q1c=0.003, lz=0.12, qz=0.2, i1=0.01,
              lr=0.15, frame="body")


def _flight(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return random_body_flight(np.geomspace(0.02, 20, n), seed)


@pytest.mark.parametrize("exponent", [1.5, 1.8, 2.0, 2.2, 2.5])
def test_forward_law_equals_its_transcription(exponent):
    law = dataclasses.replace(LAW, exponent=exponent)
    a, _, rotor = _flight(200, 1)
    ours = np.column_stack(body_drag_force(law, a[:, 0], a[:, 1], a[:, 2], rotor))
    np.testing.assert_allclose(ours, _transcribed_force(law, a, rotor), rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("exponent", [1.5, 1.8, 2.2, 2.5])
def test_inversion_round_trips_at_any_exponent(exponent):
    """Body frame at tilted attitudes and the heading frame, 0.02 to 20 m/s: the Newton steps (two more
    than a quadratic law's) bring the airflow back to the smoothing's 1e-4 m/s."""
    law = dataclasses.replace(LAW, exponent=exponent)
    a, rot, rotor = _flight(2000, 2)
    force_b = np.column_stack(body_drag_force(law, a[:, 0], a[:, 1], a[:, 2], rotor))
    back = body_drag_airflow_numpy(law, np.einsum("nij,nj->ni", rot, force_b), rot, rotor)
    np.testing.assert_allclose(back, np.einsum("nij,nj->ni", rot, a), atol=1e-4)
    heading = dataclasses.replace(law, frame="heading", lr=0.0)
    fx, fy, fz = drag_force(heading, a[:, 0], a[:, 1], a[:, 2])
    np.testing.assert_allclose(drag_airflow_numpy(heading, fx, fy, fz), a, atol=1e-4)


def test_the_isotropic_law_inverts_to_its_closed_form_root():
    """l0 s + q0 s^p = F solved by bisection, independently of the step's Newton steps."""
    law = DragLaw(0.2, 0.08, lz=0.1, exponent=1.7)
    force = np.array([0.01, 0.5, 3.0, 12.0, 40.0])
    got = drag_airflow_numpy(law, force, np.zeros_like(force), np.zeros_like(force))[:, 0]
    for f, s in zip(force, got):
        low, high = 0.0, 100.0
        for _ in range(200):
            mid = 0.5 * (low + high)
            low, high = (mid, high) if 0.2 * mid + 0.08 * mid ** 1.7 < f else (low, mid)
        assert s == pytest.approx(low, abs=2e-5)


def test_a_quadratic_law_raises_nothing_to_a_power():
    """p = 2 is the factor s itself, so the step's C of a quadratic law has no pow (and the checked-in C of
    the reference airframe did not change); another exponent calls pow."""
    import casadi as ca
    s = ca.SX.sym("s")
    assert speed_power(s, 2.0) is s
    assert "pow" in str(speed_power(s, 1.8))
    from dobwind.codegen.generate import generate_code
    af = dataclasses.replace(load_airframe(M300), drag=LAW)
    quadratic = "".join(generate_code(af, "single").files.values())
    other = "".join(generate_code(dataclasses.replace(af, drag=dataclasses.replace(LAW, exponent=1.8)), "single").files.values())
    assert "powf(" not in quadratic and "powf(" in other


def test_airframe_file_key():
    af = dataclasses.replace(load_airframe(M300), drag=LAW)
    text = dump_airframe(af)
    assert "exponent" not in text  # files of quadratic laws stay as they were
    other = dataclasses.replace(af, drag=dataclasses.replace(LAW, exponent=2.2))
    assert "exponent = 2.2" in dump_airframe(other)
    assert parse_airframe(dump_airframe(other), "x.toml").drag == other.drag
    for bad in ("1.4", "2.6", "nan"):
        with pytest.raises(Exception, match=r"x\.toml.*force_air\.drag\.exponent"):
            parse_airframe(dump_airframe(other).replace("exponent = 2.2", f"exponent = {bad}"), "x.toml")


@pytest.mark.parametrize("exponent", [1.5, 2.5])
def test_generated_c_of_an_exponent_law_matches_the_reference(exponent):
    """verify: strict compile, the self-test, random and limit cases (forces up to 1e6 N) and a flight,
    both precisions, on a law whose front/back term is a tenth of q0 (the demo's fit has 0.08): with
    q1c still quadratic under p = 1.5, the force against the airflow peaked near 100 m/s and the single
    precision inversion of the limit cases ran off to millions of m/s."""
    from dobwind.harness.verify import verify_airframe
    law = dataclasses.replace(LAW, q1c=0.01, exponent=exponent)
    af = dataclasses.replace(load_airframe(M300), drag=law)
    assert verify_airframe(af, "both", steps=300).passed


def _samples(law: DragLaw, noise_n: float = 0.05, seed: int = 3, frame: str = "heading") -> dragfit.DragSamples:
    return hold_samples(lambda vx, vy, vz: drag_force(law, vx, vy, vz), noise_n, seed, frame)


SET = ("l0", "q0", "lz", "qz") + dragfit.ALWAYS


def _law(exponent: float) -> DragLaw:
    return DragLaw(0.3, 0.06, lz=0.2, qz=0.1, exponent=exponent)


def test_columns_for_another_exponent_recover_its_law():
    """Samples of a p = 1.7 law: with the columns rescaled to 1.7 the fit returns its coefficients; as
    sampled (p = 2) it cannot (the linear term takes the difference)."""
    samples = _samples(_law(1.7))
    shifted = dragfit.with_exponent(samples, 1.7)
    assert shifted.exponent == 1.7 and dragfit.with_exponent(shifted, 1.7) is shifted
    got = dict(zip(samples.parameters, dragfit.robust_fit(shifted, SET)))
    assert got["l0"] == pytest.approx(0.3, abs=0.01) and got["q0"] == pytest.approx(0.06, rel=0.03)
    as_sampled = dict(zip(samples.parameters, dragfit.robust_fit(samples, SET)))
    assert abs(as_sampled["l0"] - 0.3) > 0.05
    # and the rescaled columns' law inverts with that exponent: the airflow comes back (the median: the
    # heading jumps between holds leave the filtered force behind for a few seconds)
    error = dragfit.predicted_airflow(shifted, dragfit.robust_fit(shifted, SET)) - shifted.airflow
    assert np.median(np.hypot(error[:, 0], error[:, 1])) < 0.15


def _always_usable(samples: dragfit.DragSamples, choice: dragfit.DragChoice) -> bool:
    return True


@functools.lru_cache(maxsize=None)
def _computed_choice(truth: float):
    """The samples of a law of exponent ``truth``, the set chosen on them and the exponent chosen when every
    law is usable: pure functions of ``truth`` (seeded), 3-5 s, which three tests below ask of 2.2. Computed
    once per process; each caller gets copies (copied together: picked.choice stays the copy of choice)."""
    samples = _samples(_law(truth))
    choice = dragfit.choose_drag_law(samples, holdcv.prefer_on_holds)
    return samples, choice, dragexponent.choose_exponent(samples, choice, _always_usable)


def _chosen(truth: float):
    return copy.deepcopy(_computed_choice(truth))


@pytest.mark.parametrize("truth", [1.8, 2.0, 2.2])
def test_the_exponent_chosen_is_the_laws(truth):
    samples, choice, picked = _chosen(truth)
    assert picked.exponent == pytest.approx(truth, abs=1e-9)  # on the 0.1 grid, two steps from 2
    assert picked.samples.exponent == picked.exponent and 2.0 in picked.scores
    if truth == 2.0:
        assert picked.choice is choice  # a quadratic law is kept as chosen
    else:
        assert picked.scores[picked.exponent] < (1 - dragexponent.EXPONENT_GAIN) * picked.scores[2.0]


def test_an_unusable_law_keeps_the_quadratic_one():
    samples, choice, _ = _chosen(2.2)
    picked = dragexponent.choose_exponent(samples, choice, lambda s, c: False)
    assert picked.exponent == 2.0 and picked.choice is choice


def _hold_of(errors: np.ndarray, top: np.ndarray) -> "holdcv.HoldCV":
    rms = lambda e: float(np.sqrt(np.mean(e ** 2)))
    return holdcv.HoldCV(rms(errors), (), (), rms(top), window_errors_mps=errors, top_errors_mps=top,
                         window_folds=np.arange(errors.size) % dragfit.FOLDS)


def test_a_gain_counts_when_it_is_paired_and_large():
    """Window by window: the same errors times 0.8 are a real gain; the same spread reshuffled with a
    lower RMS by chance is not, nor is a consistent gain under EXPONENT_GAIN."""
    rng = np.random.default_rng(4)
    errors, top = rng.normal(0, 0.05, 300), rng.normal(0, 0.08, 40)
    base = _hold_of(errors, top)
    assert holdcv.significant_gain(base, _hold_of(0.8 * errors, 0.8 * top))
    assert not holdcv.significant_gain(base, _hold_of(0.98 * errors, 0.98 * top))  # under 5 %
    # Independent errors 8 % smaller in RMS: their paired difference is all noise.
    scaled = lambda e, like: e * 0.92 * np.sqrt(np.mean(like ** 2) / np.mean(e ** 2))
    other = _hold_of(scaled(rng.normal(0, 1, 300), errors), scaled(rng.normal(0, 1, 40), top))
    assert dragexponent.hold_score(other) < 0.95 * dragexponent.hold_score(base)
    assert not holdcv.significant_gain(base, other)
    assert holdcv.significant_gain(base, other, sigmas=0.0)  # the test, not the gain, refused it
    assert not holdcv.significant_gain(base, None) and not holdcv.significant_gain(None, base)
    # Held-out holds much better but the top holds worse: a lower bias at low airflow, not a growth rate.
    assert not holdcv.significant_gain(base, _hold_of(0.7 * errors, 1.05 * top))
    assert holdcv.significant_gain(base, _hold_of(0.7 * errors, 0.9 * top))
    # A gain from one fold's law alone (the windows of a fold share it): 300 windows would call it
    # significant, five folds do not.
    fold = np.arange(errors.size) % dragfit.FOLDS
    one_fold = _hold_of(np.where(fold == 0, 0.5, 1.02) * errors, 0.9 * top)
    assert dragexponent.hold_score(one_fold) < 0.95 * dragexponent.hold_score(base)
    assert not holdcv.significant_gain(base, one_fold)
    per_window = dataclasses.replace(base, window_folds=np.arange(errors.size))  # every window its own
    assert holdcv.significant_gain(per_window, one_fold)


def test_hold_windows_pair_up_between_laws():
    """hold_cv's per-window errors come in one order for given samples, whatever the law: the same law
    twice gives the same arrays, another law arrays of the same shape."""
    samples = _samples(_law(2.0))
    first = holdcv.hold_cv(samples, dragfit.drag_fit_predict(SET))
    again = holdcv.hold_cv(samples, dragfit.drag_fit_predict(SET))
    other = holdcv.hold_cv(samples, dragfit.drag_fit_predict(("q0", "lz", "qz") + dragfit.ALWAYS))
    np.testing.assert_array_equal(first.window_errors_mps, again.window_errors_mps)
    assert other.window_errors_mps.shape == first.window_errors_mps.shape
    assert other.top_errors_mps.shape == first.top_errors_mps.shape
    assert first.rms_mps == pytest.approx(float(np.sqrt(np.mean(first.window_errors_mps ** 2))))


@pytest.mark.parametrize("frame", ["heading", "body"])
def test_rescaled_columns_are_the_exponents_own_in_steady_airflow(frame):
    """Settled in a hold, H passes the regressor unchanged, so with_exponent's q columns must equal the
    law's own basis at that exponent: horizontal speed in the heading frame, the whole airspeed (with
    the vertical airflow) in the body frame; the per-axis pair, its own airflow component."""
    samples = _samples(_law(2.0), frame=frame)
    shifted = dragfit.with_exponent(samples, 1.7)
    steady = samples.hold_age_s > 10.0
    air = samples.airflow[steady]
    c, s = samples.cos_yaw[steady], samples.sin_yaw[steady]
    if frame == "body":
        rot = samples.rotation[steady]
        a = np.einsum("nji,nj->ni", rot, np.column_stack([c * air[:, 0] - s * air[:, 1], s * air[:, 0] + c * air[:, 1],
                                                          air[:, 2]]))
        units = body_drag_basis(a[:, 0], a[:, 1], a[:, 2], np.ones(len(a)), 0.0, 1.7)
        expected = {k: np.einsum("nij,nj->ni", rot, np.column_stack(units[k])) for k in ("q0", "q2c", "q2s", "q1c", "q4c", "q4s", "qax", "qay", "l0")}
    else:
        units = horizontal_drag_basis(air[:, 0], air[:, 1], np.hypot(air[:, 0], air[:, 1]), 1.7)
        expected = {k: np.column_stack([c * fx - s * fy, s * fx + c * fy, np.zeros_like(fx)])
                    for k, (fx, fy) in units.items() if k in ("q0", "q2c", "q2s", "q1c", "q4c", "q4s", "qax", "qay", "l0")}
    for key, value in expected.items():  # l0: a linear term, left as it was
        got = shifted.columns[steady][:, :, samples.parameters.index(key)]
        np.testing.assert_allclose(got, value, rtol=1e-6, atol=1e-9, err_msg=key)


def _scores(score_mps: float, hold_cv_mps: float, hold_extrapolation_mps: float) -> FamilyScores:
    """A family's per-sample score and its hold-level figures (no bands: choose_family does not read them)."""
    return FamilyScores(score_mps=score_mps, hold=HoldScores(hold_cv_mps, HoldCvBySpeed((), (), (), (), None),
                                                             hold_extrapolation_mps))


def test_a_tie_between_families_goes_to_the_body_frame_law():
    """Figures of a random vehicle's fit (rand3_4): the heading-frame law won the tie on its hold means
    and read the tunnel's 10 m/s hold 0.20 m/s off; the body-frame law read it 0.04 m/s off."""
    from dobwind.calibrate.fitfamily import FAMILY_TIE, choose_family
    drag, body = _scores(0.226, 0.076, 0.053), _scores(0.228, 0.076, 0.068)
    assert choose_family(["drag", "drag-body"], {"drag": drag, "drag-body": body}) == "drag-body"
    assert choose_family(["drag-body", "drag", "polynomial"],
                         {"drag": drag, "drag-body": body, "polynomial": _scores(0.2255, 0.076, 0.053)}) == "drag-body"
    # beyond the tie the per-sample score decides, however good the other's hold means
    body_far = _scores(0.226 * (1 + FAMILY_TIE) + 1e-4, 0.076, 0.02)
    assert choose_family(["drag", "drag-body"], {"drag": drag, "drag-body": body_far}) == "drag"


def test_without_the_body_frame_law_a_tie_goes_to_the_better_hold_means():
    from dobwind.calibrate.fitfamily import choose_family
    drag, poly = _scores(0.226, 0.076, 0.053), _scores(0.2265, 0.075, 0.039)
    assert choose_family(["drag", "polynomial"], {"drag": drag, "polynomial": poly}) == "polynomial"
    # a family without hold-level figures loses a tie, and nothing scored keeps the first
    assert choose_family(["drag", "polynomial"], {"drag": poly, "polynomial": FamilyScores(score_mps=0.2262)}) == "drag"
    assert choose_family(["drag", "polynomial"], {}) == "drag"
    # tied on the hold level as well (within FAMILY_TIE): the per-sample choice stays
    close = _scores(0.2255, 0.0755, 0.0535)
    assert choose_family(["drag", "polynomial"], {"drag": drag, "polynomial": close}) == "polynomial"
    assert choose_family(["polynomial", "drag"], {"drag": _scores(0.2254, 0.076, 0.053), "polynomial": close}) == "drag"


def test_the_set_chosen_again_must_still_beat_the_quadratic_law(monkeypatch):
    """At the new exponent the set is chosen again; should that law's holds not beat the quadratic
    law's significantly (here: a set without quadratic drag, forced), the quadratic law is kept."""
    samples, choice, premise = _chosen(2.2)  # computed before choose_drag_law is replaced below
    assert premise.exponent == 2.2  # the premise
    linear_only = ("l0", "lz", "qz") + dragfit.ALWAYS
    monkeypatch.setattr(dragfit, "choose_drag_law",
                        lambda s, prefer: dataclasses.replace(choice, active=linear_only,
                                                              theta=dragfit.robust_fit(s, linear_only)))
    picked = dragexponent.choose_exponent(samples, choice, _always_usable)
    assert picked.exponent == 2.0 and picked.choice is choice
