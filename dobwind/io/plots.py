"""Replay and fit figures (matplotlib Agg).

Choices that make the replay figure readable as it stands (issue #15):
- the direction is where the wind blows FROM, unwrapped so a northerly wind is one line instead of
  dots split between 0 and 360 deg, and drawn only while the wind is strong enough to have one;
- the speed axis is scaled to dobwind and the truth: another method's spikes are clipped at the top
  edge and marked, rather than squashing the curves that matter;
- a method without a vertical estimate (all-NaN vertical column) gets no vertical line;
- every series has its own colour AND line style, so overlapping lines stay distinguishable in print.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.ticker import FuncFormatter, MultipleLocator  # noqa: E402

from dobwind.model.forceair import wind_from_deg  # noqa: E402

MIN_DIRECTION_SPEED_MPS = 0.5  # below this a wind direction is noise (and still air has none)
SPEED_HEADROOM = 1.15
# (colour, line style): truth first, dobwind second, then other methods; colour-blind-safe hues.
STYLES = (("black", "-"), ("#0072B2", "-"), ("#D55E00", "--"), ("#009E73", ":"), ("#CC79A7", "-."))


@dataclass(frozen=True)
class Series:
    label: str
    t: np.ndarray
    wind: np.ndarray  # NED rows, m/s; a NaN vertical column: the method has no vertical estimate
    colour: str
    style: str
    width: float
    is_truth: bool = False  # the reference the others are judged by (the log's or the simulator's true wind)


# An autopilot log's time axis: PX4's and ArduPilot's clocks count from boot (a SITL may count from 1970),
# so a reader must not take the numbers for UTC; the NetCDF output has UTC where the log has GPS time.
LOG_CLOCK_LABEL = "time on the log's own clock (s; not UTC)"


def published(wind: np.ndarray, vertical_law: str) -> np.ndarray:
    """dobwind's wind as a figure should draw it: an airframe whose vertical law is the zero-wind fallback
    publishes a vertical wind of 0 by construction, which drawn would read as a measured calm, so its
    vertical column becomes NaN (no vertical line), as the NetCDF leaves upward_air_velocity out."""
    from dobwind.model.airframe import VERTICAL_FALLBACK

    if vertical_law != VERTICAL_FALLBACK:
        return wind
    return np.column_stack([np.asarray(wind)[:, :2], np.full(len(wind), np.nan)])


def save(fig, path: str | Path) -> None:
    """PNG through a temporary (removed on any failure), whatever the name's extension."""
    from dobwind.io.atomic import write_file_atomically

    try:
        write_file_atomically(path, lambda tmp: fig.savefig(tmp, dpi=100, format="png"))
    finally:
        plt.close(fig)


def wind_from_unwrapped_deg(wind: np.ndarray, min_speed_mps: float = MIN_DIRECTION_SPEED_MPS,
                            windy: np.ndarray | None = None) -> np.ndarray:
    """Where the wind blows from, clockwise from north, unwrapped over time (continuous across north);
    NaN where the horizontal speed is below ``min_speed_mps`` (or where ``windy``, when given, is False:
    the truth's speed decides whether there is a direction to show). The result is shifted by whole
    turns so that its median lies in [0, 360)."""
    speed = np.hypot(wind[:, 0], wind[:, 1])
    raw = wind_from_deg(wind[:, 0], wind[:, 1])
    out = np.full(len(raw), np.nan)
    keep = np.isfinite(raw) & (speed >= min_speed_mps if windy is None else windy)
    if not keep.any():
        return out
    out[keep] = np.degrees(np.unwrap(np.radians(raw[keep])))
    return out - 360.0 * np.floor(np.nanmedian(out) / 360.0)


def _align_turns(direction: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """Shift by whole turns onto the reference (same instants): the same direction, drawn on top of it."""
    both = np.isfinite(direction) & np.isfinite(reference)
    if not both.any():
        return direction
    return direction - 360.0 * np.round(np.median(direction[both] - reference[both]) / 360.0)


def _shade_status(ax, t: np.ndarray, status: np.ndarray, legend: bool) -> None:
    """Grey behind rows with no estimate (rejected, NO_DATA, LANDED), amber behind accepted rows that
    are not trusted (SETTLING, EXTRAPOLATED, SUSPECT ...): the reader sees at once which stretch of the
    line to believe."""
    from dobwind.model.status import accepted

    ok = accepted(status)
    band = ax.get_xaxis_transform()
    for mask, colour, label in ((~ok, "0.6", "no estimate"), (ok & (status != 0), "#E69F00", "not trusted (status bits)")):
        if mask.any():
            ax.fill_between(t, 0, 1, where=mask, transform=band, color=colour, alpha=0.18, lw=0, step="mid",
                            label=label if legend else None)


def _series(t: np.ndarray, wind: np.ndarray, truth: np.ndarray | None,
            others: list[tuple[str, np.ndarray, np.ndarray]], truth_label: str = "true wind") -> list[Series]:
    named = ([(truth_label, t, truth)] if truth is not None else []) + [("dobwind", t, wind)] + list(others)
    offset = 0 if truth is not None else 1
    out = []
    for i, (label, tt, w) in enumerate(named):
        colour, style = STYLES[min(i + offset, len(STYLES) - 1)]
        out.append(Series(label, np.asarray(tt), np.asarray(w, dtype=float), colour, style,
                          1.4 if i + offset < 2 else 1.0, is_truth=i + offset == 0))
    return out


def _speed_panel(ax, series: list[Series]) -> None:
    main = [s for s in series if s.is_truth or s.label == "dobwind"]
    top = max((float(np.nanmax(np.hypot(s.wind[:, 0], s.wind[:, 1]), initial=0.0)) for s in main), default=1.0)
    top = max(top * SPEED_HEADROOM, 0.5)
    for s in series:
        speed = np.hypot(s.wind[:, 0], s.wind[:, 1])
        over = speed > top
        label = s.label + (f" (clipped at {top:.2g} m/s: ▲)" if over.any() else "")
        ax.plot(s.t, np.minimum(speed, top), color=s.colour, ls=s.style, lw=s.width, label=label)
        if over.any():  # at most ~200 markers along the top edge where the series was cut
            idx = np.flatnonzero(over)[:: max(1, int(over.sum()) // 200)]
            ax.plot(s.t[idx], np.full(len(idx), top), "^", color=s.colour, ms=4, clip_on=False)
    ax.set_ylim(0, top)
    ax.set_ylabel("horizontal wind speed (m/s)")


def _directions(series: list[Series]) -> list[tuple[Series, np.ndarray]]:
    """Each series' unwrapped wind-from angle, aligned by whole turns on the first; series with none left out.
    With a truth, its speed decides where a direction exists: in still air no estimate's direction is shown."""
    truth = next((s for s in series if s.is_truth), None)
    windy = None if truth is None else np.hypot(truth.wind[:, 0], truth.wind[:, 1]) >= MIN_DIRECTION_SPEED_MPS
    out: list[tuple[Series, np.ndarray]] = []
    for s in series:
        direction = wind_from_unwrapped_deg(s.wind, windy=windy if windy is not None and len(windy) == len(s.wind) else None)
        if not np.isfinite(direction).any():
            continue
        if out and len(out[0][1]) == len(direction):
            direction = _align_turns(direction, out[0][1])
        out.append((s, direction))
    return out


def _direction_panel(ax, directions: list[tuple[Series, np.ndarray]]) -> None:
    for s, direction in directions:
        ax.plot(s.t, direction, color=s.colour, ls=s.style, lw=s.width, label=s.label)
    ax.set_ylabel("wind from (deg)")
    low, high = ax.get_ylim()
    span = high - low  # the smallest "round" compass step that gives at most 8 ticks
    step = next((c for c in (5.0, 10.0, 15.0, 30.0, 45.0, 90.0, 180.0) if span / c <= 8), 360.0 * np.ceil(span / 2880.0))
    ax.yaxis.set_major_locator(MultipleLocator(step))
    # Unwrapped values, compass labels: 370 deg is printed as 10 (N), so a northerly wind reads as one.
    ax.yaxis.set_major_formatter(FuncFormatter(_compass_label))


def _compass_label(value: float, _pos: int | None = None) -> str:
    deg = value % 360.0
    point = {0.0: " N", 90.0: " E", 180.0: " S", 270.0: " W"}.get(round(deg, 6), "")
    return f"{deg:.0f}{point}"


def _vertical_panel(ax, series: list[Series]) -> None:
    for s in series:
        if np.isnan(s.wind[:, 2]).all():
            continue  # a method that cannot estimate the vertical wind draws nothing, not a flat zero
        ax.plot(s.t, -s.wind[:, 2], color=s.colour, ls=s.style, lw=s.width, label=s.label)
    ax.set_ylabel("vertical wind, up (m/s)")


def replay_plot(t: np.ndarray, wind: np.ndarray, truth: np.ndarray | None, title: str, path: str,
                others: list[tuple[str, np.ndarray, np.ndarray]] = (), status: np.ndarray | None = None,
                band: tuple[str, np.ndarray, np.ndarray, np.ndarray] | None = None, truth_label: str = "true wind",
                time_label: str = "time (s)") -> None:
    """Speed, direction (from) and vertical wind (up) over time; truth and other estimates if given.
    ``others``: (label, time, wind NED) for other estimators; a NaN vertical column means "no vertical".
    ``status``: per row of t, shades the rows without an estimate (grey) and the untrusted ones (amber).
    ``band``: (label, t, low, high) drawn behind the speed panel (an autopilot's own 1-sigma).
    ``truth_label``: the truth's name in the legend (an ArduPilot SITL log's: the simulator's wind).
    ``time_label``: the x axis (an autopilot log's: LOG_CLOCK_LABEL, which is no UTC)."""
    series = _series(t, wind, truth, list(others), truth_label)
    directions = _directions(series)
    if directions:
        fig, axes = plt.subplots(3, 1, sharex=True, figsize=(10, 8), height_ratios=(1.2, 1.0, 0.8))
        _direction_panel(axes[1], directions)
    else:  # calm air has no direction: no panel for it, and the title says so
        fig, axes = plt.subplots(2, 1, sharex=True, figsize=(10, 6), height_ratios=(1.2, 0.8))
        title += f"\n(no direction panel: the wind stays below {MIN_DIRECTION_SPEED_MPS:g} m/s)"
    _speed_panel(axes[0], series)
    _vertical_panel(axes[-1], series)
    if band is not None:
        axes[0].fill_between(band[1], band[2], band[3], color=STYLES[2][0], alpha=0.2, lw=0, label=band[0])
    if status is not None:
        for i, ax in enumerate(axes):
            _shade_status(ax, t, status, legend=i == 0)
    axes[-1].set_xlabel(time_label)
    axes[0].set_title(title)
    for ax in axes:
        ax.grid(True, alpha=0.3)
    axes[0].legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    save(fig, path)
