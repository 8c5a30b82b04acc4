"""ArduCopter's air-density step in CTUN.ThO (dobwind/io/densitystep.py): the ratio ArduCopter used, by its
25 m rule and the ideal-gas density, and the step undone only where the log shows it."""
from __future__ import annotations

import numpy as np
import pytest

from dobwind.io.densitystep import applied_ratio, find_step

R, RHO0, LAPSE = 287.26, 1.225, 0.0065


def _baro(alt: np.ndarray, p0: float = 94_500.0, ground_c: float = 25.0) -> dict[str, np.ndarray]:
    """A barometer climbing through ``alt`` (m) at 10 Hz, its pressure falling 11 Pa per metre."""
    return {"t": 100.0 + 0.1 * np.arange(len(alt)), "Alt": alt, "Press": p0 - 11.0 * alt,
            "GndTemp": np.full(len(alt), ground_c)}


def _density_ratio(p: float, ground_c: float, alt: float) -> float:
    return p / (R * (ground_c + 273.15 - LAPSE * alt)) / RHO0


def test_the_ratio_is_one_until_25_m_then_recomputed_every_25_m():
    baro = _baro(np.linspace(0.0, 60.0, 601))
    ratio = applied_ratio(baro["Alt"], baro["Press"], baro["GndTemp"])
    first, second = np.argmax(baro["Alt"] >= 25.0), np.argmax(baro["Alt"] >= 50.0)
    assert np.all(ratio[:first] == 1.0)
    expected = _density_ratio(94_500.0 - 11.0 * baro["Alt"][first], 25.0, baro["Alt"][first])
    assert ratio[first] == pytest.approx(expected, rel=1e-12) and 0.89 < expected < 0.91
    assert np.all(ratio[first:second] == ratio[first])  # held between recomputations
    assert ratio[second] == pytest.approx(_density_ratio(94_500.0 - 11.0 * baro["Alt"][second], 25.0,
                                                         baro["Alt"][second]), rel=1e-12)
    # a descent by 25 m from the last computation recomputes too
    down = applied_ratio(np.r_[0.0, 30.0, 10.0, 4.0], np.full(4, 90_000.0), np.full(4, 15.0))
    assert down[1] == down[2] != down[3]


def _ctun(baro: dict, step: bool, hover: float = 0.38, relearn: bool = False) -> dict[str, np.ndarray]:
    """CTUN at 10 Hz for a constant physical thrust at hover: ThO divided by the applied ratio's change
    when ``step`` (ArduCopter 4.1), ThH learned at ratio 1 (drifting into the new units if ``relearn``)."""
    ratio = applied_ratio(baro["Alt"], baro["Press"], baro["GndTemp"]) if step else np.ones(len(baro["t"]))
    tho = hover * ratio
    thh = np.full(len(tho), hover)
    if relearn:
        thh = np.where(ratio < 1.0, hover * (1.0 + (ratio - 1.0) * 0.8), hover)
    return {"t": baro["t"].copy(), "ThO": tho, "ThH": thh}


@pytest.mark.parametrize("relearn", [False, True])
def test_a_step_the_log_shows_is_undone_and_the_thrust_stays_what_the_motors_give(relearn):
    baro = _baro(np.linspace(0.0, 40.0, 401))
    ctun = _ctun(baro, step=True, relearn=relearn)
    step, said = find_step(baro, ctun)
    assert step is not None and step.measured == pytest.approx(step.predicted) and f"stepped by {step.predicted:.3f}" in said[0]
    assert step.t_s == pytest.approx(baro["t"][np.argmax(baro["Alt"] >= 25.0)])
    tho, thh = step.thrust_terms(baro["t"], ctun["ThO"], ctun["ThH"])
    np.testing.assert_allclose(tho / thh, 1.0, rtol=1e-12)  # hover throughout: thrust = m g
    logged = ctun["ThO"] / ctun["ThH"]
    assert logged[-1] < 0.91 or relearn  # what the log alone says after the step: 10 % low


def test_a_log_without_the_step_is_read_as_logged_and_says_why():
    """A version that computes the ratio at boot: the same climb, no step in ThO."""
    baro = _baro(np.linspace(0.0, 40.0, 401))
    step, said = find_step(baro, _ctun(baro, step=False))
    assert step is None and "changed by 1.000 there: the thrust is read as logged" in said[0]


def test_a_vehicle_levelling_off_at_25_m_is_not_taken_for_the_step():
    """A version without the step whose vehicle levels off as it reaches 25 m: the throttle falls 10 % over
    one second centred on the crossing, a ramp of 1 % a sample, not the compensation's jump."""
    baro = _baro(np.linspace(0.0, 40.0, 401))
    ctun = _ctun(baro, step=False)
    t1 = baro["t"][np.argmax(baro["Alt"] >= 25.0)]
    ctun["ThO"] = ctun["ThO"] * np.interp(ctun["t"], [t1 - 0.5, t1 + 0.5], [1.0, 0.9])
    step, said = find_step(baro, ctun)
    assert step is None and "the thrust is read as logged" in said[0], said


@pytest.mark.parametrize("alt_top, p0, said", [
    (20.0, 94_500.0, False),    # never 25 m from the ground: no recomputation
    (40.0, 98_900.0, False),    # a ratio within 2 % of 1 (cool air near sea level): too small to tell from throttle changes
])
def test_no_step_to_judge_leaves_the_thrust_alone_silently(alt_top, p0, said):
    baro = _baro(np.linspace(0.0, alt_top, 401), p0=p0, ground_c=10.0 if p0 > 95_000 else 25.0)
    if p0 > 95_000:
        assert abs(applied_ratio(baro["Alt"], baro["Press"], baro["GndTemp"])[-1] - 1.0) < 0.02
    step, notes = find_step(baro, _ctun(baro, step=True))
    assert step is None and bool(notes) == said


def test_a_barometer_no_flight_reads_is_not_believed():
    """Pressure in hPa (a damaged or mis-scaled log): a ratio of 0.001, and a ThO that drops with it by
    chance, is still no density step."""
    baro = _baro(np.linspace(0.0, 40.0, 401))
    ctun = _ctun(baro, step=True)
    baro["Press"] = baro["Press"] / 100.0
    assert find_step(baro, ctun) == (None, [])


def test_no_barometer_or_no_throttle_around_the_step():
    baro = _baro(np.linspace(0.0, 40.0, 401))
    assert find_step(None, _ctun(baro, step=True)) == (None, [])
    ctun = _ctun(baro, step=True)
    ctun["ThO"][:] = 0.0  # on the ground (ThO 0) on both sides: nothing to measure
    assert find_step(baro, ctun) == (None, [])


def _manoeuvre(baro: dict, change: float, step: bool) -> tuple[dict, dict]:
    """CTUN at 10 Hz and a 25 Hz IMU for a vehicle whose real thrust changes by ``change`` (a fraction) within
    0.2 s as it crosses 25 m (a climb steepened or cut there), with or without the density step in ThO. The
    IMU feels the real thrust: AccZ = -g times it."""
    t1 = baro["t"][np.argmax(baro["Alt"] >= 25.0)]
    ctun = _ctun(baro, step=step)
    thrust = lambda t: np.interp(t, [t1 - 0.1, t1 + 0.1], [1.0, 1.0 + change])  # noqa: E731
    ctun["ThO"] = ctun["ThO"] * thrust(ctun["t"])
    t_imu = np.arange(baro["t"][0], baro["t"][-1], 0.04)
    return ctun, {"t": t_imu, "AccZ": -9.80665 * thrust(t_imu)}


def test_a_step_hidden_by_a_manoeuvre_is_found_through_the_imu():
    """At the crossing the real thrust rises 10 % as the compensation lowers ThO by its 0.90: ThO alone barely
    moves (0.988), and only the thrust the IMU felt shows the step."""
    baro = _baro(np.linspace(0.0, 40.0, 401))
    ctun, imu = _manoeuvre(baro, +0.10, step=True)
    alone, said_alone = find_step(baro, ctun)
    assert alone is None and "but CTUN.ThO changed by 0.98" in said_alone[0]
    step, said = find_step(baro, ctun, imu)
    assert step is not None and step.measured == pytest.approx(step.predicted, abs=1e-9)
    assert "CTUN.ThO per unit of the IMU's -AccZ stepped by" in said[0]
    tho, thh = step.thrust_terms(ctun["t"], ctun["ThO"], ctun["ThH"])
    t1 = baro["t"][np.argmax(baro["Alt"] >= 25.0)]
    real = np.interp(ctun["t"], [t1 - 0.1, t1 + 0.1], [1.0, 1.1])
    np.testing.assert_allclose(tho / thh, real, rtol=1e-9)  # the thrust read is the real thrust


def test_a_sharp_throttle_cut_without_the_step_is_not_taken_for_it():
    """A version without the step whose vehicle cuts its thrust by 10 % within 0.2 s at the crossing: ThO alone
    looks exactly like the step; the IMU felt the cut, so ThO per felt thrust did not move."""
    baro = _baro(np.linspace(0.0, 40.0, 401))
    ctun, imu = _manoeuvre(baro, -0.10, step=False)
    assert find_step(baro, ctun)[0] is not None  # misread without the IMU: why the IMU is used
    step, said = find_step(baro, ctun, imu)
    assert step is None and "per unit of the IMU's -AccZ changed by 1.000 there" in said[0]


def test_imu_samples_without_thrust_are_left_out():
    """An IMU reading free fall (AccZ near 0) around the crossing is no thrust to divide by: those samples are
    left out, and with none left the judgement is ThO's alone, as for a log without an IMU."""
    baro = _baro(np.linspace(0.0, 40.0, 401))
    ctun, imu = _manoeuvre(baro, 0.0, step=True)
    imu["AccZ"][:] = -0.1
    step, said = find_step(baro, ctun, imu)
    assert step is not None and "and CTUN.ThO stepped by" in said[0]
