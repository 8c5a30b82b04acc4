"""The body-frame drag law: forward law against an independent transcription, its inversion at any
attitude, the step's stage, the airframe file, the calibration from filtered data, and the C."""
from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from dobwind.calibrate import dragfit
from dobwind.model.airframe import load_airframe, parse_airframe
from dobwind.model.airframe_toml import dump_airframe
from dobwind.model.forceair import DragLaw, body_drag_airflow_numpy, body_drag_force
from tests.helpers import M300, observed_force

BODY_LAWS = {
    "rotor drag only, scaled by rotor speed": DragLaw(0.0, 0.0, lr=0.25, lz=0.4, frame="body"),
    "per-axis body drag, y 25 % above x": DragLaw(0.05, 0.1, l2c=-0.006, q2c=-0.0125, l2s=0.006, q2s=0.0125,
                                                  lz=0.12, qz=0.2, frame="body"),
    "every term": DragLaw(0.2, 0.08, 0.03, 0.01, 0.004, -0.02, -0.005, 0.3, 0.1, 0.02, 0.01, lr=0.15, frame="body"),
}


def _independent_force(law: DragLaw, a: np.ndarray, rotor: np.ndarray) -> np.ndarray:
    """The law written out per sample from its docstring, in polar form (not through the basis)."""
    out = np.empty_like(a)
    for i, ((ax, ay, az), r) in enumerate(zip(a, rotor)):
        s, sh, theta = math.sqrt(ax * ax + ay * ay + az * az), math.hypot(ax, ay), math.atan2(ay, ax)
        along = (law.l0 + law.lr * r + law.q0 * s + (law.l2c + law.q2c * s) * math.cos(2 * theta)) * sh \
            + law.q1c * sh * sh * math.cos(theta)
        across = (law.l2s + law.q2s * s) * math.sin(2 * theta) * sh
        u, e = (math.cos(theta), math.sin(theta)), (-math.sin(theta), math.cos(theta))
        out[i] = (along * u[0] + across * e[0], along * u[1] + across * e[1],
                  law.lz * az + law.qz * s * az + law.i1 * sh + law.i2 * sh * sh)
    return out


def _random_flight(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    speed, angle = rng.uniform(0.05, 15, n), rng.uniform(-math.pi, math.pi, n)
    a = np.column_stack([speed * np.cos(angle), speed * np.sin(angle), rng.uniform(-4, 4, n)])
    # Tilts up to about 45 degrees, any heading.
    rot = Rotation.from_euler("ZYX", np.column_stack([rng.uniform(-math.pi, math.pi, n), rng.uniform(-0.7, 0.7, n),
                                                      rng.uniform(-0.7, 0.7, n)])).as_matrix()
    return a, rot, np.sqrt(rng.uniform(0.7, 1.6, n))


def test_forward_law_equals_an_independent_transcription():
    law = BODY_LAWS["every term"]
    a, _, rotor = _random_flight(300, 1)
    ours = np.column_stack(body_drag_force(law, a[:, 0], a[:, 1], a[:, 2], rotor))
    np.testing.assert_allclose(ours, _independent_force(law, a, rotor), rtol=1e-10, atol=1e-12)


def test_per_axis_drag_is_the_special_case_of_the_harmonics():
    """F_x = (kx + cx |a|) a_x, F_y = (ky + cy |a|) a_y: l2s = -l2c and q2s = -q2c, as in the heading frame."""
    law = BODY_LAWS["per-axis body drag, y 25 % above x"]
    a, _, rotor = _random_flight(50, 2)
    fx, fy, _ = body_drag_force(law, a[:, 0], a[:, 1], a[:, 2], rotor)
    s = np.linalg.norm(a, axis=1)
    np.testing.assert_allclose(fx, (0.05 - 0.006 + (0.1 - 0.0125) * s) * a[:, 0], rtol=1e-12)
    np.testing.assert_allclose(fy, (0.05 + 0.006 + (0.1 + 0.0125) * s) * a[:, 1], rtol=1e-12)


@pytest.mark.parametrize("name", list(BODY_LAWS))
def test_inversion_round_trips_at_any_attitude(name):
    law = BODY_LAWS[name]
    a, rot, rotor = _random_flight(3000, 3)
    force_ned = np.einsum("nij,nj->ni", rot, np.column_stack(body_drag_force(law, a[:, 0], a[:, 1], a[:, 2], rotor)))
    back = body_drag_airflow_numpy(law, force_ned, rot, rotor)
    np.testing.assert_allclose(back, np.einsum("nij,nj->ni", rot, a), atol=1e-4)


def test_level_body_law_without_tilt_terms_is_the_heading_law():
    """Level flight, no vertical airflow and no rotor term: the body-frame law is the heading-frame one."""
    from dobwind.model.forceair import drag_force

    body = DragLaw(0.2, 0.08, l2c=0.03, q2c=0.01, l2s=-0.02, q2s=-0.005, q1c=0.004, frame="body")
    heading = dataclasses.replace(body, frame="heading")
    a, _, rotor = _random_flight(200, 4)
    ours = body_drag_force(body, a[:, 0], a[:, 1], 0 * a[:, 2], rotor)
    theirs = drag_force(heading, a[:, 0], a[:, 1], 0 * a[:, 2])
    np.testing.assert_allclose(ours[0], theirs[0], rtol=1e-10)
    np.testing.assert_allclose(ours[1], theirs[1], rtol=1e-10)


def _body_airframe(law: DragLaw):
    return parse_airframe(dump_airframe(dataclasses.replace(load_airframe(M300), drag=law)), "x.toml")


def test_airframe_file_round_trip_and_keys():
    law = BODY_LAWS["every term"]
    af = _body_airframe(law)
    assert af.drag == law and 'frame = "body"' in dump_airframe(af)
    assert parse_airframe(dump_airframe(af), "x.toml").drag == law
    heading_text = dump_airframe(dataclasses.replace(af, drag=dataclasses.replace(law, frame="heading", lr=0.0)))
    assert "frame" not in heading_text and "lr" not in heading_text  # heading files stay as they were
    with pytest.raises(Exception, match="force_air.drag.lr"):
        parse_airframe(heading_text.replace("l0 =", "lr = 0.1\nl0 ="), "x.toml")
    with pytest.raises(Exception, match="force_air.drag.frame"):
        parse_airframe(dump_airframe(af).replace('frame = "body"', 'frame = "wind"'), "x.toml")


def test_step_stage_inverts_the_law_at_the_measured_attitude():
    """A steady force from a known airflow at a tilted attitude and rotor speed: the stage returns it."""
    from dobwind.model.step import build_step

    law = BODY_LAWS["every term"]
    af = _body_airframe(law)
    stage = next(s for s in build_step(af).stages if s.name == "force_air")
    rot = Rotation.from_euler("ZYX", [0.7, 0.3, -0.2]).as_matrix()
    u_f = 1.3 * af.mass_kg * af.gravity_mps2
    a = np.array([4.0, -3.0, 1.0])
    rotor = np.array([math.sqrt(1.3)])
    force = rot @ np.array(body_drag_force(law, a[:1], a[1:2], a[2:], rotor)).ravel()
    args = {"f_filt_new": force, "in_yaw_ref": 0.7, "rot_body_to_ned": rot.T.ravel(), "u_f": u_f,
            "state_air_prev": np.zeros(3), "state_initialized": 0.0}
    names = [n.replace(".", "_") for n in stage.inputs]

    def run(previous: np.ndarray, warm: float) -> tuple[np.ndarray, np.ndarray]:
        out = stage.function(*[dict(args, state_air_prev=previous, state_initialized=warm)[n] for n in names])
        return (np.asarray(out[stage.outputs.index("air_rel_ned")]).ravel(),
                np.asarray(out[stage.outputs.index("air_body")]).ravel())

    # The step tracks the solution (forceair.body_drag_airflow_tracking): from the isotropic start on the
    # first sample, then from the previous sample's body-frame airflow; three samples of a steady force
    # reach it.
    air, body = run(np.zeros(3), 0.0)
    for _ in range(2):
        air, body = run(body, 1.0)
    np.testing.assert_allclose(air, rot @ a, atol=1e-5)
    np.testing.assert_allclose(body, a, atol=1e-5)
    # The solution itself is a fixed point; a previous airflow far from it is not used (the cold start is).
    np.testing.assert_allclose(run(a, 1.0)[0], rot @ a, atol=1e-9)
    np.testing.assert_allclose(run(-10 * a, 1.0)[0], run(np.zeros(3), 0.0)[0], rtol=1e-12)


def test_filtered_regression_recovers_a_known_body_law():
    """Force made by H from a known body-frame law at tilted attitudes, with noise: the fit returns it."""
    af = load_airframe(M300)
    law = BODY_LAWS["every term"]
    rate, seconds, hold = 50.0, 1200.0, 20
    rng = np.random.default_rng(6)
    n, holds = int(rate * seconds), int(seconds / hold)
    t = np.arange(n) / rate
    per = lambda x: np.repeat(x, int(rate * hold))
    yaw = per(rng.uniform(-math.pi, math.pi, holds))
    rot = Rotation.from_euler("ZYX", np.column_stack([yaw, per(rng.uniform(-0.4, 0.4, holds)),
                                                      per(rng.uniform(-0.4, 0.4, holds))])).as_matrix()
    air = np.column_stack([per(rng.uniform(0, 9, holds)), per(rng.uniform(-3, 3, holds)), per(rng.uniform(-2, 2, holds))])
    weight = af.mass_kg * af.gravity_mps2
    u_f = weight * per(rng.uniform(0.8, 1.5, holds))
    thrust = u_f[:, None] * rot[:, :, 2]
    rotor = np.sqrt(u_f / weight)
    a = np.einsum("nji,nj->ni", rot, air)
    kappa = 0.02
    force = np.einsum("nij,nj->ni", rot, np.column_stack(body_drag_force(law, a[:, 0], a[:, 1], a[:, 2], rotor)))
    force = force + kappa * thrust
    observed = observed_force(af, rate, force, 0.02, rng)
    q = Rotation.from_matrix(rot).as_quat()[:, [3, 0, 1, 2]]
    part = dragfit.log_samples(af, 0.5, t, observed, air, thrust, yaw, np.ones(n, dtype=bool), "body", q)
    samples = dragfit.merge([part], "body")
    theta = dragfit.robust_fit(samples, ("l0", "lr", "q0", "l2c", "q2c", "l2s", "q2s", "q1c") + dragfit.VERTICAL_SETS[-1] + dragfit.ALWAYS)
    got = dict(zip(dragfit.BODY_PARAMETERS, theta))
    for key in law.keys():
        value = getattr(law, key)
        assert got[key] == pytest.approx(value, abs=0.004 + 0.03 * abs(value)), key
    assert got["kappa"] == pytest.approx(kappa, abs=0.002)
    # and the inverted law predicts the (filtered) airflow it was fitted on, once the filtered force has
    # caught up with a hold's attitude (which this synthetic flight changes in a jump)
    error = dragfit.predicted_airflow(samples, theta) - samples.airflow
    steady = (part["time"] % hold) >= 8.0
    assert np.sqrt(np.mean(error[steady, 0] ** 2 + error[steady, 1] ** 2)) < 0.05


def test_generated_c_of_a_body_drag_airframe_matches_the_reference():
    """verify: strict compile, the self-test, random cases, the limit cases and a flight, both precisions."""
    from dobwind.harness.verify import verify_airframe

    report = verify_airframe(_body_airframe(BODY_LAWS["every term"]), "both", steps=500)
    assert report.passed, report


def test_a_diverged_prediction_scores_as_the_clip_not_as_overflow():
    """CV errors of a candidate law whose inversion blew up: finite, the clip, and no numpy warning."""
    import warnings

    truth = np.zeros((4, 3))
    predicted = np.array([[1e300, 0, 0], [np.inf, -np.inf, 0], [np.nan, 0, 0], [0.5, -0.25, 0.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        error = dragfit.prediction_error(predicted, truth)
        assert np.isfinite(np.sum(error ** 2))
    clip = dragfit.ERROR_CLIP_MPS
    np.testing.assert_array_equal(error[:, 0], [clip, clip, clip, 0.5])
    np.testing.assert_array_equal(error[3], [0.5, -0.25, 0.0])


@pytest.mark.parametrize("frame", ["heading", "body"])
def test_columns_built_in_blocks_equal_one_pass(frame):
    """log_samples filters its full-rate columns block by block, the filter state carried: any block size
    gives the single block's samples bit for bit (blocks cut inside holds and between decimated rows)."""
    af = load_airframe(M300)
    rng = np.random.default_rng(8)
    n = 5000
    t = np.arange(n) / 50.0
    air = np.column_stack([np.repeat(rng.uniform(0, 9, 25), 200), np.repeat(rng.uniform(-3, 3, 25), 200),
                           rng.normal(0, 0.3, n)])
    yaw = np.repeat(rng.uniform(-math.pi, math.pi, 25), 200)
    rot = Rotation.from_euler("ZYX", np.column_stack([yaw, rng.normal(0, 0.2, n), rng.normal(0, 0.2, n)]))
    q = rot.as_quat()[:, [3, 0, 1, 2]]
    thrust = 80.0 * rot.as_matrix()[:, :, 2]
    force = rng.normal(0, 1.0, (n, 3))
    usable = rng.uniform(size=n) > 0.1
    segment = np.repeat(np.arange(25), 200)
    whole = dragfit.log_samples(af, 0.5, t, force, air, thrust, yaw, usable, frame, q, segment, block_rows=10 ** 9)
    for rows in (1, 333, 1000):
        parts = dragfit.log_samples(af, 0.5, t, force, air, thrust, yaw, usable, frame, q, segment, block_rows=rows)
        assert set(parts) == set(whole)
        for key, value in whole.items():
            np.testing.assert_array_equal(parts[key], value, err_msg=f"{key}, blocks of {rows}")


def test_a_body_drag_law_near_the_result_limit_passes_its_float_self_test(tmp_path, capsys):
    """`dobwind fit --truth sitl` on the ArduCopter SITL log fitted a body-frame law with a vertical term
    (l0 0.76, q0 0.085, lz 2.04) whose generated float C failed its own self-test, so `check` and
    `generate` refused the calibrated airframe: the result-limit row at 1e30 squares the vertical airflow,
    which overflows a float (the C says NUMERIC) but not the double reference (accepted). Such rows are no
    golden rows in single precision; every row kept has all its intermediate values within a float."""
    import casadi as ca

    from dobwind.cli.app import main
    from dobwind.model.boundaries import FLOAT_MAX, boundary_cases
    from dobwind.model.kinds import Precision
    from dobwind.model.status import REJECTED_MASK
    from dobwind.model.step import build_step

    af = _body_airframe(DragLaw(0.76, 0.085, lz=2.04, frame="body"))
    path = tmp_path / "body.toml"
    path.write_text(dump_airframe(af))
    assert main(["check", str(path)]) == 0, capsys.readouterr().err
    model = build_step(af)
    cases = boundary_cases(model, Precision.SINGLE)
    every = ca.Function("every", model.step.sx_in(), [model.step.instructions_sx()])
    _, _, status = model.step.map(len(cases.labels))(cases.states.T, cases.inputs.T)
    for k, accepted in enumerate((np.asarray(status).ravel().astype(int) & REJECTED_MASK) == 0):
        if accepted:
            assert np.nanmax(np.abs(np.asarray(every(cases.states[k], cases.inputs[k])))) <= FLOAT_MAX, cases.labels[k]
    assert "result sum <= RESULT_MAGNITUDE_LIMIT" in cases.labels   # the rejected side of the limit stays
