"""The logged acceleration against the velocity's derivative (dobwind/io/accelcheck.py), and what init and
replay do with it. The check's figure is pinned by closed forms: a sinusoid added to an exact derivative
comes through the zero-phase second-order Butterworth at |H(f)|^2 = 1 / (1 + (f / fc)^4) of its RMS."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

from dobwind.cli.app import main
from dobwind.inspect.initframe import build_airframe
from dobwind.io.accelcheck import LIMIT_MPS2, check_acceleration
from dobwind.io.logs import FlightLog
from dobwind.model.airframe import load_airframe
from tests.test_inspect import _px4_log, _write

RATE_HZ, SPAN_S, BAND_HZ = 50.0, 120.0, 0.5


def _flight(disturbance, t=None, q=None, specific_force=False) -> FlightLog:
    """Velocity 2 sin(0.3 t) north and 1.5 cos(0.2 t) east with its exact derivative as the acceleration,
    plus ``disturbance(t)`` (n, 2) on the acceleration's north and east."""
    t = np.arange(0.0, SPAN_S, 1.0 / RATE_HZ) if t is None else t
    vel = np.column_stack([2 * np.sin(0.3 * t), 1.5 * np.cos(0.2 * t), np.zeros(len(t))])
    acc = np.column_stack([0.6 * np.cos(0.3 * t), -0.3 * np.sin(0.2 * t), np.zeros(len(t))])
    acc[:, :2] += disturbance(t)
    cols = {"t": t, "vel_n": vel[:, 0], "vel_e": vel[:, 1], "vel_d": vel[:, 2]}
    q = np.tile([1.0, 0.0, 0.0, 0.0], (len(t), 1)) if q is None else q
    cols |= {f"q_{c}": q[:, i] for i, c in enumerate("wxyz")}
    if specific_force:
        from dobwind.model.attitude import rotation_matrices

        sf = np.einsum("nji,nj->ni", rotation_matrices(q), acc - [0.0, 0.0, 9.80665])  # R^T (a - g e3)
        cols |= {"sf_x": sf[:, 0], "sf_y": sf[:, 1], "sf_z": sf[:, 2]}
    else:
        cols |= {"acc_n": acc[:, 0], "acc_e": acc[:, 1], "acc_d": acc[:, 2]}
    return FlightLog("synthetic.csv", cols)


def _gain(f_hz: float) -> float:
    return 1.0 / (1.0 + (f_hz / BAND_HZ) ** 4)


def _sinusoid(amplitude: float, f_hz: float):
    return lambda t: amplitude * np.column_stack([np.sin(2 * np.pi * f_hz * t), np.cos(2 * np.pi * f_hz * t)])


@pytest.mark.parametrize("amplitude, f_hz", [(0.5, 0.2), (0.1, 0.1), (1.0, 0.35)])
def test_an_in_band_error_counts_at_the_filters_gain(amplitude, f_hz):
    log = _flight(_sinusoid(amplitude, f_hz))
    check = check_acceleration(log, np.ones(log.rows, dtype=bool), "ned", BAND_HZ)
    expected = amplitude / math.sqrt(2) * _gain(f_hz)
    assert check.disagreement_mps2 == pytest.approx(expected, rel=0.02, abs=2e-3)
    # each run's first and last period of the band (2 s) are not scored
    assert check.broken == (expected > LIMIT_MPS2) and check.seconds == pytest.approx(SPAN_S - 4.0, abs=0.1)


def test_vibration_above_the_band_does_not_count():
    """5 m/s^2 at 4 Hz (vibration the logger did not alias): |H|^2 = 2.4e-4, 0.9 mm/s^2 left."""
    log = _flight(_sinusoid(5.0, 4.0))
    check = check_acceleration(log, np.ones(log.rows, dtype=bool), "ned", BAND_HZ)
    assert check.disagreement_mps2 < 0.01 and not check.broken


def test_the_specific_force_is_turned_by_the_attitude():
    """A tilting, turning vehicle whose accelerometer reads R^T (a - g e3) exactly: nothing disagrees; the
    same with the attitude left out of the turn (identity) reads the tilt's gravity share as error."""
    from scipy.spatial.transform import Rotation

    t = np.arange(0.0, SPAN_S, 1.0 / RATE_HZ)
    euler = np.column_stack([0.05 * t % (2 * np.pi), 0.15 * np.sin(0.5 * t), 0.1 * np.cos(0.3 * t)])
    xyzw = Rotation.from_euler("ZYX", euler).as_quat()
    q = np.column_stack([xyzw[:, 3], xyzw[:, :3]])
    log = _flight(lambda t: np.zeros((len(t), 2)), t, q, specific_force=True)
    assert check_acceleration(log, np.ones(log.rows, dtype=bool), "specific_force", BAND_HZ).disagreement_mps2 < 0.01
    level = FlightLog(log.path, log.columns | {"q_w": np.ones(log.rows), "q_x": np.zeros(log.rows),
                                                "q_y": np.zeros(log.rows), "q_z": np.zeros(log.rows)})
    assert check_acceleration(level, np.ones(log.rows, dtype=bool), "specific_force", BAND_HZ).broken


def test_only_airborne_rows_in_long_enough_runs_count():
    log = _flight(_sinusoid(1.0, 0.2))
    airborne = np.zeros(log.rows, dtype=bool)
    assert check_acceleration(log, airborne, "ned", BAND_HZ) is None
    airborne[:250] = True                      # 5 s: shorter than 3 periods of the band (6 s)
    assert check_acceleration(log, airborne, "ned", BAND_HZ) is None
    airborne[1000:4000] = True                 # 60 s, of which the middle 56 s are scored
    assert check_acceleration(log, airborne, "ned", BAND_HZ).seconds == pytest.approx(56.0, abs=0.1)


@pytest.fixture(scope="module")
def wobbly(tmp_path_factory):
    """A PX4 log whose ax, ay carry a 1 m/s^2 wobble at 0.2 Hz the (constant) velocity does not, and its
    starter."""
    folder = tmp_path_factory.mktemp("wobbly")
    log = _px4_log(folder / "w.ulg", wobble_mps2=1.0)
    text, choices, _ = build_airframe(str(log), 2.0, str(folder / "w.toml"))
    return log, _write(folder / "w.toml", text), choices


def test_init_takes_the_velocitys_derivative_when_the_logged_acceleration_disagrees(wobbly):
    log, starter, choices = wobbly
    af = load_airframe(starter)
    assert af.observer.acceleration == "velocity" and not af.observer.estimates_acceleration_bias
    # 1/sqrt(2) x |H(0.2 Hz)|^2 at the starter's 0.5 Hz band: 0.689 m/s^2 (the 10 Hz samples' ends aside)
    assert choices.acceleration_disagreement_mps2 == pytest.approx(1.0 / math.sqrt(2) * _gain(0.2), rel=0.05)
    assert "instead of the log's own" in choices.acceleration_reason
    assert f"{choices.acceleration_disagreement_mps2:.2f} m/s²" in starter.read_text()


def test_replay_names_a_disagreeing_acceleration_input_and_marks_the_rows(wobbly, tmp_path, capsys):
    log, starter, choices = wobbly
    given = tmp_path / "ned.toml"
    given.write_text(starter.read_text().replace('acceleration = "velocity"', 'acceleration = "ned"'))
    assert main(["replay", str(given), str(log), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    found = [f for f in out["plausibility"] if f["check"] == "acceleration"]
    assert len(found) == 1 and found[0]["value"] > LIMIT_MPS2 and found[0]["rows"] > 0
    # at init's band (the filter's highest cutoff is the starter's bandwidth): init's figure, to 0.5 %
    assert found[0]["value"] == pytest.approx(choices.acceleration_disagreement_mps2, rel=0.005)
    assert all("SUSPECT" in name for name, n in out["status_counts"].items() if "LANDED" not in name and "NO_DATA" not in name)
    assert main(["replay", str(starter), str(log), "--json"]) == 0
    assert not [f for f in json.loads(capsys.readouterr().out)["plausibility"] if f["check"] == "acceleration"]


def test_a_log_replay_cannot_read_keeps_the_logged_acceleration(tmp_path, monkeypatch):
    """init's check reads the log as replay would; when that read fails, init still writes the starter it
    wrote before the check existed (replay then says what is wrong), not exit 2 from the check."""
    import dobwind.io.autopilot as autopilot
    from dobwind.core.errors import InputError

    def refuse(path, *args, **kwargs):
        raise InputError(path, "topic", "unreadable for this test")

    monkeypatch.setattr(autopilot, "read_autopilot", refuse)
    log = _px4_log(tmp_path / "w.ulg", wobble_mps2=1.0)
    text, choices, _ = build_airframe(str(log), 2.0, str(tmp_path / "w.toml"))
    assert choices.acceleration == "ned" and choices.acceleration_disagreement_mps2 is None
    assert 'acceleration = "ned"' in text


@pytest.mark.parametrize("wobble, verdict", [(1.0, "above"), (0.0, "within")])
def test_inspect_shows_the_check_on_the_logs_own_samples(tmp_path, wobble, verdict):
    from dobwind.inspect.anylog import inspect_log

    summary = inspect_log(str(_px4_log(tmp_path / "w.ulg", wobble_mps2=wobble)))
    note = next(n for n in summary.notes if n.startswith("acceleration: vehicle_local_position"))
    assert f"({verdict} the 0.20 m/s² limit" in note, note


def test_a_repeated_timestamp_splits_the_run_instead_of_dividing_by_zero():
    import warnings

    log = _flight(_sinusoid(0.5, 0.2))
    t = log.time_s.copy()
    t[3000] = t[2999]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check = check_acceleration(FlightLog(log.path, log.columns | {"t": t}), np.ones(log.rows, dtype=bool), "ned",
                                   BAND_HZ)
    assert math.isfinite(check.disagreement_mps2)
    assert check.disagreement_mps2 == pytest.approx(0.5 / math.sqrt(2) * _gain(0.2), rel=0.03)


def test_fit_warns_when_a_calibration_logs_acceleration_is_not_the_vehicles(wobbly, tmp_path, capsys):
    """fit on the wobbly log with an airframe that reads the logged acceleration: one warning naming the log and
    the figure, whatever the fit's verdict; with the starter (velocity) none."""
    log, starter, _ = wobbly
    given = tmp_path / "ned.toml"
    given.write_text(starter.read_text().replace('acceleration = "velocity"', 'acceleration = "ned"'))
    main(["fit", str(given), str(log), "--wind", "3@90", "-o", str(tmp_path / "f.toml")])
    err = capsys.readouterr().err
    warned = [line for line in err.splitlines() if "the calibration reads that error as an external force" in line]
    assert len(warned) == 1 and str(log) in warned[0] and "above the 0.20 m/s² limit" in warned[0], err
    main(["fit", str(starter), str(log), "--wind", "3@90", "-o", str(tmp_path / "g.toml")])
    assert "the calibration reads that error" not in capsys.readouterr().err


def test_fit_on_a_flight_at_one_constant_velocity_is_refused_in_one_line(wobbly, tmp_path, capsys):
    """The wobbly log's vehicle flies at 1 m/s north throughout: no candidate law's cross-validation is
    defined (NaN). Ranked as NaN, no candidate was "within 2 % of the best" and the fit ended in an
    IndexError traceback; ranked last, the fit ends in its ordinary refusal (exit 1, one line)."""
    log, starter, _ = wobbly
    assert main(["fit", str(starter), str(log), "--wind", "3@90", "-o", str(tmp_path / "f.toml")]) == 1
    err = capsys.readouterr().err
    assert "Traceback" not in err and not (tmp_path / "f.toml").exists()


def _exact(t: np.ndarray) -> FlightLog:
    """The velocity 4 sin(0.3 t) north, 3 cos(0.2 t) east and its exact derivative, sampled at ``t``."""
    return FlightLog("exact.csv", {"t": t, "vel_n": 4 * np.sin(0.3 * t), "vel_e": 3 * np.cos(0.2 * t),
                                   "acc_n": 1.2 * np.cos(0.3 * t), "acc_e": -0.6 * np.sin(0.2 * t)})


@pytest.mark.parametrize("rate_hz, jitter", [(10.0, 0.1), (10.0, 0.2), (50.0, 0.2)])
def test_jittered_timestamps_of_an_exact_log_read_no_disagreement(rate_hz, jitter):
    """A logger's timestamps jitter by a tenth of an interval and more: exact samples at such times agree
    (a derivative over the uneven times read 10 % of the 0.67 m/s^2 RMS acceleration per 10 % jitter)."""
    period = 1.0 / rate_hz
    t = np.arange(0.0, SPAN_S, period)
    t = t + np.clip(np.random.default_rng(7).normal(0.0, jitter * period, len(t)), -0.3 * period, 0.3 * period)
    check = check_acceleration(_exact(t), np.ones(len(t), dtype=bool), "ned", BAND_HZ)
    assert check.disagreement_mps2 < 0.005, check


def test_a_silence_of_seconds_ends_the_run():
    """A 10 Hz log that lost 3 s of samples mid-flight: the two stretches are checked apart. Joined, the
    silence was flight made up by interpolation (0.015 m/s^2 on these exact samples; 0.21 m/s^2 before the
    runs were resampled, the velocity's change over the silence read as one sample's)."""
    t = np.arange(0.0, SPAN_S, 0.1)
    t = t[(t < 50.0) | (t > 53.05)]
    check = check_acceleration(_exact(t), np.ones(len(t), dtype=bool), "ned", BAND_HZ)
    assert check.disagreement_mps2 < 0.005, check
    # each stretch loses its first and last period of the band (2 s), and the silence is no flight
    assert check.seconds == pytest.approx(SPAN_S - 3.0 - 2 * 4.0, abs=0.3)


def test_a_flight_too_short_to_check_says_its_acceleration_is_unchecked(tmp_path, monkeypatch):
    """Runs shorter than the check needs (here: every run, by asking for 10^4 periods of the band): the
    logged acceleration is kept, and the starter and its summary say it was not checked."""
    import dobwind.io.accelcheck as accelcheck

    monkeypatch.setattr(accelcheck, "MIN_RUN_PERIODS", 1e4)
    text, choices, _ = build_airframe(str(_px4_log(tmp_path / "w.ulg", wobble_mps2=1.0)), 2.0, str(tmp_path / "w.toml"))
    assert choices.acceleration == "ned" and choices.acceleration_disagreement_mps2 is None
    said = "not checked against the velocity's derivative"
    assert said in choices.acceleration_reason and f"# acceleration: ned (the log's own NED acceleration; {said}" in text


def test_inspect_checks_only_the_airborne_spans():
    """vehicle_local_position at 10 Hz whose acceleration wobbles (1 m/s^2 at 0.2 Hz) on the ground only:
    the note reads the 60 s airborne span, where it agrees, not the 60 s on the ground before it."""
    from dobwind.inspect.inspect_ulog import _acceleration_note

    t = np.arange(0.0, SPAN_S, 0.1)
    log = _exact(t)
    wobble = np.where(t < 60.0, 1.0, 0.0) * np.sin(0.4 * math.pi * t)
    lp = {"t": t, "vx": log.columns["vel_n"], "vy": log.columns["vel_e"], "ax": log.columns["acc_n"] + wobble,
          "ay": log.columns["acc_e"] + wobble}
    note = _acceleration_note({"vehicle_local_position": lp}, ((60.0, SPAN_S),))
    assert "differ by 0.00 m/s² RMS below 0.5 Hz over 56 s airborne (within" in note, note
