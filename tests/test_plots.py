"""Replay-figure choices that a reader relies on (issue #15), checked on the drawn data."""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from dobwind.io import plots  # noqa: E402


def _wind_from(deg: np.ndarray, speed: float = 5.0) -> np.ndarray:
    """NED wind blowing FROM ``deg`` (clockwise from north): the air moves towards deg + 180."""
    rad = np.radians(deg)
    return np.column_stack([-speed * np.cos(rad), -speed * np.sin(rad), np.zeros(len(deg))])


def test_direction_is_continuous_across_north():
    deg = np.linspace(340.0, 380.0, 81) % 360.0  # from NNW through N to NNE
    unwrapped = plots.wind_from_unwrapped_deg(_wind_from(deg))
    assert np.all(np.diff(unwrapped) > 0) and np.max(np.abs(np.diff(unwrapped))) < 1.0
    assert np.allclose(unwrapped % 360.0, deg, atol=1e-9)


def test_no_direction_in_calm_air():
    calm = _wind_from(np.full(50, 90.0), speed=0.2)
    assert np.isnan(plots.wind_from_unwrapped_deg(calm)).all()


def test_speed_axis_follows_dobwind_and_truth_and_marks_clipped_methods():
    t = np.linspace(0.0, 10.0, 200)
    truth, ours = _wind_from(np.full(200, 45.0), 1.0), _wind_from(np.full(200, 45.0), 1.1)
    spiky = _wind_from(np.full(200, 45.0), 1.0)
    spiky[100] *= 10.0
    fig, ax = plt.subplots()
    plots._speed_panel(ax, plots._series(t, ours, truth, [("tilt", t, spiky)]))
    assert ax.get_ylim()[1] < 1.5  # scaled to 1.1 m/s, not to the 10 m/s spike
    tilt = [line for line in ax.get_lines() if line.get_label().startswith("tilt")]
    assert tilt and "clipped" in tilt[0].get_label()
    assert any(line.get_marker() == "^" for line in ax.get_lines())
    plt.close(fig)


def test_a_method_without_vertical_has_no_vertical_line_and_styles_differ():
    t = np.linspace(0.0, 10.0, 50)
    wind = _wind_from(np.full(50, 10.0))
    no_vertical = wind.copy()
    no_vertical[:, 2] = np.nan
    series = plots._series(t, wind, wind, [("tilt", t, no_vertical)])
    fig, ax = plt.subplots()
    plots._vertical_panel(ax, series)
    assert sorted(line.get_label() for line in ax.get_lines()) == ["dobwind", "true wind"]
    assert len({(s.colour, s.style) for s in series}) == len(series)
    plt.close(fig)


def test_still_air_has_no_direction_panel_even_when_estimates_are_noisy():
    t = np.linspace(0.0, 10.0, 100)
    truth = np.zeros((100, 3))
    noisy = _wind_from(np.random.default_rng(1).uniform(0, 360, 100), speed=0.8)
    assert plots._directions(plots._series(t, noisy, truth, [("tilt", t, noisy * 3)])) == []
    windy = _wind_from(np.full(100, 270.0), speed=4.0)
    drawn = plots._directions(plots._series(t, noisy, windy, [("tilt", t, noisy * 3)]))
    assert [s.label for s, _ in drawn] == ["true wind", "dobwind", "tilt"]
