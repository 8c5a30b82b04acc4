"""The blend's noise predicted from the sensors' noise (dobwind/calibrate/blendnoise.py) and the fit's use of it
(accelroute.tries_blend / keeps_blend).

The closed form is checked against the step itself: white acceleration and velocity noise in a level
hover through the observer and the low-pass, with and without the velocity-aided bias estimate, and the
ratio of the horizontal force variances compared with fc / (fh + fc) (1 + sv^2 / (sa^2 T^2)). With the
blend disabled (the airframe's route replayed twice) the measured ratio is 1 and the test fails."""
from __future__ import annotations

import math

import numpy as np
import pytest

from dobwind.calibrate.accelroute import (BLEND_TIME_S, LONGEST_BLEND_TIME_S, QUIETER_SHARE, blend_time, blended, keeps_blend,
                                         observer_hz, predicted_ratio, tries_blend)
from dobwind.calibrate.blendnoise import (SensorNoise, acceleration_noise_ratio, blend_rms_ratio, log_sensor_noise,
                                         quietest_blend_time)
from dobwind.calibrate.hovernoise import HoverNoise
from dobwind.calibrate.selfcheck import SelfCheck
from dobwind.io.logs import FlightLog
from dobwind.model import reference
from dobwind.model.step import build_step
from tests.helpers import make_airframe

DT = 0.02
CUTOFF_HZ = 0.1
ROWS = 150_000   # 50 min at 50 Hz: some 1,900 correlation times of the 0.1 Hz low-pass per run


def _hover_force(af, acc_noise: float, vel_noise: float, seed: int) -> np.ndarray:
    """The step's low-passed horizontal force (N) in a level hover whose NED acceleration and ground
    velocity carry white noise only."""
    model = build_step(af)
    rng = np.random.default_rng(seed)
    values = {"dt": np.full(ROWS, DT), "vel_ned": vel_noise * rng.normal(size=(ROWS, 3)),
              "acc_ned": acc_noise * rng.normal(size=(ROWS, 3)), "q": np.tile([1.0, 0.0, 0.0, 0.0], (ROWS, 1)),
              "yaw_ref": np.zeros(ROWS), "thrust": np.full(ROWS, af.mass_kg * af.gravity_mps2)}
    traj = reference.run_columns(model, model.inputs.pack(values, rows=ROWS), slice(0, 1),
                                 model.outputs.slice("force_ned"))
    return traj.outputs[5_000:, :2]   # past the start-up of the observer, the low-pass and the bias


def _airframe(gain: float):
    return make_airframe(**{"thrust": {"source": "collective", "scale": 1.0}, "observer.sample_time": DT,
                            "observer.gains": [gain, gain, gain], "observer.force_offset": [0.0, 0.0, 0.0],
                            "filter.speeds": [0.0], "filter.cutoffs": [CUTOFF_HZ]})


# Observers at 50 / 2.5 = 20 rad/s (3.2 Hz) and 48 rad/s (7.6 Hz): the slower cuts more of the 1/f^2
# tail the low-pass passes above the blend's corner (without the observer's factor the form said 0.58
# where the 3.2 Hz step measured 0.51).
@pytest.mark.parametrize("gain", [50.0, 120.0])
@pytest.mark.parametrize("acc_noise", [0.15, 0.05])
def test_the_steps_blend_leaves_the_closed_form_share_of_the_noise(acc_noise, gain):
    vel_noise = 0.03
    af = _airframe(gain)
    assert af.observer.acceleration == "ned" and af.observer.acceleration_bias_time_s == 0.0
    alone = np.var(_hover_force(af, acc_noise, vel_noise, 1))
    mixed = np.var(_hover_force(blended(af), acc_noise, vel_noise, 1))
    fo = observer_hz(af)
    expected = acceleration_noise_ratio(SensorNoise(acc_noise, vel_noise), CUTOFF_HZ, BLEND_TIME_S, fo)
    # By hand: fh = 1 / (2 pi 0.5) = 0.318 Hz, fo = gain / 2.5 / (2 pi);
    # 0.1 / 0.418 * fo / (fo + 0.318) * (1 + (0.03 / (acc_noise 0.5))^2).
    fh, fo_hand = 1 / math.pi, gain / 2.5 / (2 * math.pi)
    by_hand = 0.1 / (0.1 + fh) * fo_hand / (fo_hand + fh) * (1 + (vel_noise / (acc_noise * 0.5)) ** 2)
    assert fo == pytest.approx(fo_hand) and expected == pytest.approx(by_hand, rel=1e-12)
    assert mixed / alone == pytest.approx(expected, rel=0.06)


def test_the_ratio_is_one_without_a_bias_estimate_and_infinite_for_a_noiseless_accelerometer():
    noise = SensorNoise(0.1, 0.03)
    assert acceleration_noise_ratio(noise, 0.05, 0.0) == 1.0
    assert acceleration_noise_ratio(SensorNoise(0.0, 0.03), 0.05, BLEND_TIME_S) == math.inf
    # No velocity noise: the high-pass alone, fc / (fh + fc); a slow bias estimate (T large) changes little.
    fh = 1 / (2 * math.pi * BLEND_TIME_S)
    assert acceleration_noise_ratio(SensorNoise(0.1, 0.0), 0.05, BLEND_TIME_S) == pytest.approx(0.05 / (fh + 0.05))
    assert acceleration_noise_ratio(noise, 0.05, 1e4) == pytest.approx(1.0, abs=1e-3)
    # Relative to an airframe already estimating its bias slowly (20 s), the blend's RMS ratio.
    assert blend_rms_ratio(noise, 0.05, 20.0, BLEND_TIME_S) == pytest.approx(math.sqrt(
        acceleration_noise_ratio(noise, 0.05, BLEND_TIME_S) / acceleration_noise_ratio(noise, 0.05, 20.0)))


def _log(acc_noise: float, vel_noise: float, rows: int = 20_000) -> FlightLog:
    """A manoeuvring flight (a 0.1 Hz, 2 m/s velocity swing) with white sensor noise."""
    rng = np.random.default_rng(3)
    t = np.arange(rows) * DT
    vel = 2.0 * np.sin(2 * np.pi * 0.1 * t)
    acc = 2.0 * 2 * np.pi * 0.1 * np.cos(2 * np.pi * 0.1 * t)
    columns = {"t": t}
    for k, axis in enumerate("ne"):
        columns[f"vel_{axis}"] = vel * (k + 1) + vel_noise * rng.normal(size=rows)
        columns[f"acc_{axis}"] = acc * (k + 1) + acc_noise * rng.normal(size=rows)
    return FlightLog("flight.csv", columns)


@pytest.mark.parametrize("acc_noise,vel_noise", [(0.15, 0.03), (0.05, 0.01), (0.3, 0.1)])
def test_the_noise_levels_are_read_off_a_manoeuvring_log(acc_noise, vel_noise):
    noise = log_sensor_noise(_log(acc_noise, vel_noise), "ned")
    assert noise is not None
    assert noise.acceleration_mps2 == pytest.approx(acc_noise, rel=0.05)
    assert noise.velocity_mps == pytest.approx(vel_noise, rel=0.05)
    assert log_sensor_noise(_log(acc_noise, vel_noise), "specific_force") is None   # no such columns


def _check(still: float | None, passed: bool = True) -> SelfCheck:
    return SelfCheck(passed, [] if passed else ["a reason"], 0.05, 8.0, 0.5, 0.5, 10.0, [], 0.05, 0.04, still)


def test_a_noiseless_accelerometer_is_kept_as_it_is():
    """The limiting case: with no accelerometer noise the blend only adds the velocity's, so the fit
    does not try it, however noisy the replay's figure (which is then the thrust's noise, not the
    acceleration's)."""
    af = make_airframe(**{"observer.acceleration": "specific_force", "filter.cutoffs": [0.05, 0.6, 1.0]})
    quiet = predicted_ratio(af, SensorNoise(0.0, 0.03))
    assert quiet == math.inf
    assert not tries_blend(af, _check(0.3), HoverNoise(), True, quiet)
    noisy = predicted_ratio(af, SensorNoise(0.15, 0.03))
    assert noisy < QUIETER_SHARE and tries_blend(af, _check(0.3), HoverNoise(), True, noisy)


def test_a_lowered_low_pass_tries_the_blend_the_sensors_back():
    af = make_airframe(**{"observer.acceleration": "ned", "filter.cutoffs": [0.15, 0.6, 1.0]})
    ratio = predicted_ratio(af, SensorNoise(0.05, 0.03))
    assert ratio < QUIETER_SHARE
    within = _check(0.069)   # the replay's figure meets the 0.07 target
    assert tries_blend(af, within, HoverNoise(), True, ratio)           # the low-pass had to be lowered
    assert not tries_blend(af, within, HoverNoise(), False, ratio)      # it did not: nothing to gain
    assert not tries_blend(af, within, HoverNoise(), True, None)        # no prediction: the replay alone
    assert not tries_blend(af, within, HoverNoise(target_mps=0.0), True, ratio)   # --hover-noise 0
    assert not tries_blend(blended(af), within, HoverNoise(), True, ratio)        # already blended
    velocity = make_airframe(**{"observer.acceleration": "velocity"})
    assert predicted_ratio(velocity, SensorNoise(0.05, 0.03)) is None


def test_a_predicted_blend_is_kept_unless_measured_clearly_noisier():
    assert keeps_blend(_check(0.070), _check(0.076), predicted=True)
    assert not keeps_blend(_check(0.070), _check(0.078), predicted=True)
    assert not keeps_blend(_check(0.070), _check(0.060, passed=False), predicted=True)
    assert not keeps_blend(_check(0.070), _check(0.066))   # unpredicted: clearly quieter only


@pytest.mark.parametrize("acc_noise,vel_noise,cutoff_hz", [(0.05, 0.03, 0.15), (0.15, 0.03, 0.05), (0.1, 0.1, 0.1)])
def test_the_quietest_blend_time_is_the_minimum_of_the_ratio(acc_noise, vel_noise, cutoff_hz):
    noise = SensorNoise(acc_noise, vel_noise)
    grid = np.geomspace(0.01, 100.0, 20_001)   # an independent search over the time constant
    for fo in (math.inf, 1.0, 3.0):
        best = quietest_blend_time(noise, cutoff_hz, fo)
        ratios = [acceleration_noise_ratio(noise, cutoff_hz, t, fo) for t in grid]
        assert best == pytest.approx(grid[int(np.argmin(ratios))], rel=1e-3)
    assert quietest_blend_time(SensorNoise(0.0, 0.03), 0.05) == math.inf
    # The fit's choice stays within its bounds, and a noiseless accelerometer predicts no gain at them.
    af = make_airframe(**{"observer.acceleration": "ned", "filter.cutoffs": [cutoff_hz, 0.6, 1.0]})
    assert BLEND_TIME_S <= blend_time(af, noise) <= LONGEST_BLEND_TIME_S
    assert blend_time(af, SensorNoise(0.0, 0.03)) == LONGEST_BLEND_TIME_S and blend_time(af, None) == BLEND_TIME_S
