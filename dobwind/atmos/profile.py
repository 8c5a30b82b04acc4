"""`dobwind profile`: the wind binned by height above the take-off point, over one or many flights.

Per bin: the mean horizontal speed and its spread (sample standard deviation), the direction of the
VECTOR mean (the mean of angles would put a northerly wind, 350 and 10 deg, at 180 deg) and the
circular spread of the sample directions, the mean vertical wind and its spread, the mean calibrated
1-sigma of the estimates, and the sample count; and how far each mean can be trusted: the time the
flights spent in the bin, the effective number of independent samples and the standard error of the mean
(atmos/binstats.py). A bin with less data than a minimum gives no mean. Only trusted rows (status 0, or
quality flags the user allows) enter. Each flight is reduced to additive per-bin sums, so flights combine exactly
whatever order the workers finish in.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from dobwind.atmos import binstats
from dobwind.core.errors import InputError
from dobwind.core.options import Bound
from dobwind.model.kinds import Precision

if TYPE_CHECKING:  # the model (CasADi) loads only when a profile runs, not with the parser (--bin)
    from dobwind.model.airframe import Airframe

BIN = Bound(0.1, 1000.0, "m")  # --bin: finer than GPS altitude is noise, coarser than 1 km is no profile
# --min-seconds: the data a bin needs for a mean. The default 10 s holds 12 or more time constants of the
# estimator's low-pass (0.8 s at its lowest cutoff, 0.2 Hz): at least about 6 independent samples even in
# perfectly steady air, so the scatter can say something about the error of the mean. 0: no minimum.
MIN_SECONDS = Bound(0.0, 3600.0, "s")
DEFAULT_MIN_SECONDS = 10.0

# Below this horizontal speed a sample's direction is noise and does not enter the direction spread.
MIN_SPEED_FOR_DIRECTION_MPS = 0.5
# The per-bin sums, in this order.
SUMS = ("count", "north", "east", "up", "up2", "n_up", "speed", "speed2", "cos", "sin", "n_dir",
        "sigma_h", "n_sigma_h", "sigma_up", "n_sigma_up", "seconds",
        *(f"speed_{name}" for name in binstats.SERIES_SUMS), *(f"up_{name}" for name in binstats.SERIES_SUMS))
_I = {name: k for k, name in enumerate(SUMS)}
# What a bin under the minimum still reports (how much data it has); every other statistic is NaN there.
ALWAYS_REPORTED = ("height_bottom_m", "height_top_m", "height_m", "count", "seconds", "n_eff", "up_n_eff",
                   "below_minimum")


@dataclass(frozen=True)
class Samples:
    """One flight's trusted rows: height above take-off (m), wind NED (m/s), the step's 1-sigmas."""
    height_m: np.ndarray
    wind_ned: np.ndarray
    sigma_h: np.ndarray
    sigma_up: np.ndarray
    notes: tuple[str, ...] = ()
    utc_s: tuple[float, float] | None = None  # Unix seconds of the first and last kept row, with GPS time
    time_s: np.ndarray | None = None  # the rows' clock (s): their time in a bin and which rows are neighbours
    # The log's sampling interval (s), from ALL its rows: the kept rows' own clock has holes where rows were
    # not trusted, so its median step overstates a kept row's time (every tenth row kept: ten times) and
    # is NaN for a flight with one kept row, which made the whole bin's time NaN. None: from time_s.
    step_s: float | None = None


def bin_sums(samples: Samples, bin_m: float) -> dict[int, np.ndarray]:
    """{bin index k (heights [k bin, (k+1) bin)): the sums of SUMS over its samples}."""
    # A NaN vertical wind (an airframe whose vertical law is the zero-wind fallback) keeps the row for the
    # horizontal statistics and leaves it out of the vertical ones.
    ok = np.isfinite(samples.height_m) & np.all(np.isfinite(samples.wind_ned[:, :2]), axis=1)
    h, w = samples.height_m[ok], samples.wind_ned[ok]
    t = None if samples.time_s is None else np.asarray(samples.time_s, float)[ok]
    step = binstats.sampling_step(t) if samples.step_s is None else samples.step_s
    sh, su = samples.sigma_h[ok], samples.sigma_up[ok]
    k = np.floor(h / bin_m).astype(np.int64)
    speed = np.hypot(w[:, 0], w[:, 1])
    strong = speed >= MIN_SPEED_FOR_DIRECTION_MPS
    safe = np.where(strong, speed, 1.0)
    # The unit vector of the direction the wind blows FROM: (north, east) = -wind / speed.
    cos_from, sin_from = np.where(strong, -w[:, 0] / safe, 0.0), np.where(strong, -w[:, 1] / safe, 0.0)
    known_h, known_up = sh >= 0, su >= 0  # -1: the airframe records no uncertainty
    has_up = np.isfinite(w[:, 2])
    up = np.where(has_up, -w[:, 2], 0.0)
    columns = np.column_stack([np.ones_like(h), w[:, 0], w[:, 1], up, up * up, has_up, speed, speed * speed,
                               cos_from, sin_from, strong, np.where(known_h, sh, 0.0), known_h,
                               np.where(known_up, su, 0.0), known_up, np.full(len(h), step),
                               *_series_columns(k, t, step, h - (k + 0.5) * bin_m, speed, np.where(has_up, up, np.nan)).T])
    keys, inverse = np.unique(k, return_inverse=True)
    sums = np.zeros((len(keys), len(SUMS)))
    np.add.at(sums, inverse, columns)
    return {int(key): sums[i] for i, key in enumerate(keys)}


def _series_columns(bins: np.ndarray, t: np.ndarray | None, step: float, centred_h: np.ndarray, speed: np.ndarray,
                    up: np.ndarray) -> np.ndarray:
    """The rows' contributions to the series sums of the speed and of the vertical wind (NaN: no vertical)."""
    pair = binstats.neighbours(bins, t, step)
    return np.column_stack([binstats.series_columns(speed, centred_h, pair),
                            binstats.series_columns(up, centred_h, pair)])


def combine(parts: list[dict[int, np.ndarray]]) -> dict[int, np.ndarray]:
    total: dict[int, np.ndarray] = {}
    for part in parts:
        for key, sums in part.items():
            total[key] = total[key] + sums if key in total else sums.copy()
    return total


def _std(s2: np.ndarray, s1: np.ndarray, n: np.ndarray) -> np.ndarray:
    """Sample standard deviation from sums (NaN below two samples)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        var = (s2 - s1 * s1 / n) / (n - 1)
    return np.where(n > 1, np.sqrt(np.maximum(var, 0.0)), np.nan)


def table(total: dict[int, np.ndarray], bin_m: float, min_seconds: float = 0.0) -> dict[str, np.ndarray]:
    """Per-bin statistics, every bin from the lowest to the highest with samples (empty ones: count 0).
    A bin with less than min_seconds of data (or an unknown time, when a minimum is asked) reports only
    ALWAYS_REPORTED, with below_minimum True; its means, spreads and errors are NaN."""
    from dobwind.model.forceair import wind_from_deg

    if not total:
        return {}
    keys = np.arange(min(total), max(total) + 1)
    s = np.array([total.get(int(k), np.zeros(len(SUMS))) for k in keys])
    n = s[:, _I["count"]]
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_n, mean_e, mean_up = s[:, _I["north"]] / n, s[:, _I["east"]] / n, s[:, _I["up"]] / s[:, _I["n_up"]]
        n_dir = s[:, _I["n_dir"]]
        resultant = np.hypot(s[:, _I["cos"]], s[:, _I["sin"]]) / n_dir
        spread = np.degrees(np.sqrt(-2.0 * np.log(np.clip(resultant, 1e-12, 1.0))))
        sigma_h = s[:, _I["sigma_h"]] / s[:, _I["n_sigma_h"]]
        sigma_up = s[:, _I["sigma_up"]] / s[:, _I["n_sigma_up"]]
    stats = {
        "height_bottom_m": keys * bin_m, "height_top_m": (keys + 1) * bin_m, "height_m": (keys + 0.5) * bin_m,
        "count": n.astype(np.int64),
        "speed_mean_mps": np.where(n > 0, s[:, _I["speed"]] / np.maximum(n, 1), np.nan),
        "speed_std_mps": _std(s[:, _I["speed2"]], s[:, _I["speed"]], n),
        "vector_speed_mps": np.hypot(mean_n, mean_e),
        "direction_from_deg": np.where(n > 0, wind_from_deg(mean_n, mean_e), np.nan),
        "direction_spread_deg": np.where(n_dir > 1, spread, np.nan),
        "northward_mean_mps": mean_n, "eastward_mean_mps": mean_e,
        "up_mean_mps": mean_up, "up_std_mps": _std(s[:, _I["up2"]], s[:, _I["up"]], s[:, _I["n_up"]]),
        "sigma_h_mps": sigma_h, "sigma_up_mps": sigma_up,
    }
    stats.update(_trust(s))
    return _apply_minimum(stats, min_seconds)


def _series(s: np.ndarray, name: str) -> np.ndarray:
    return s[:, [_I[f"{name}_{column}"] for column in binstats.SERIES_SUMS]]


def _trust(s: np.ndarray) -> dict[str, np.ndarray]:
    """The bin's time (s), effective sample counts and the standard errors of its means."""
    out = {"seconds": s[:, _I["seconds"]]}
    for name, prefix in (("speed", ""), ("up", "up_")):
        series = _series(s, name)
        std, r = binstats.residual_scatter(series)
        n_eff = binstats.effective_count(series[:, 0], r)
        out[f"{prefix}n_eff"] = n_eff
        out[f"{name}_se_mps"] = binstats.standard_error(std, n_eff)
    return out


def _apply_minimum(stats: dict[str, np.ndarray], min_seconds: float) -> dict[str, np.ndarray]:
    """NaN every statistic of a bin under the minimum (a NaN time fails any minimum above 0)."""
    with np.errstate(invalid="ignore"):
        below = (stats["count"] == 0) | ((min_seconds > 0) & ~(stats["seconds"] >= min_seconds))
    stats["below_minimum"] = below
    return {key: value if key in ALWAYS_REPORTED else np.where(below, np.nan, value)
            for key, value in stats.items()}


def allowed_mask(names: list[str]) -> int:
    """The quality bits a user lets into the profile (--allow NAME). Rejection bits are never allowed:
    their rows carry no new estimate."""
    from dobwind.io.cfnames import status_flags
    from dobwind.model.status import NOT_ACCEPTED_MASK

    masks, meanings = status_flags()
    by_name = dict(zip(meanings, masks))
    mask = 0
    for name in names:
        value = by_name.get(name.strip().lower())
        if value is None or value & NOT_ACCEPTED_MASK:
            quality = [m for m, v in zip(meanings, masks) if not v & NOT_ACCEPTED_MASK]
            raise InputError("--allow", None, f"{name!r} is not a quality flag (one of {', '.join(quality)})")
        mask |= value
    return mask


def flight_samples(af: Airframe, path: str, backend: str = "python", precision: Precision = Precision.SINGLE,
                   rate_hz: float | None = None, allow: int = 0) -> Samples:
    """One log through the estimator, its rows put at their height above take-off, trusted rows kept."""
    from dobwind.io.autopilot import is_autopilot_log
    from dobwind.io.position import local_height_on_rows, on_rows, read_geo
    from dobwind.model.airframe import VERTICAL_FALLBACK
    from dobwind.replay.replay import replay, replay_ulog

    notes: list[str] = []
    if is_autopilot_log(path):
        model, flight, traj = replay_ulog(af, path, backend, precision, rate_hz)
        t, landed, columns = flight.t0_s + flight.log.time_s, flight.landed, None
    else:
        model, log, traj = replay(af, path, backend, precision)
        t, landed, columns = log.time_s, None, log.columns
    geo = read_geo(path, columns)
    if geo.track is not None:
        pos = on_rows(geo.track, t, landed)
        height, notes = pos.height_m, [f"height: {pos.height_source}"]
    elif geo.local is not None:
        height, how = local_height_on_rows(geo.local, t, landed)
        notes.append(f"height: {how}")
    elif columns is not None:
        height = _integrated_height(t, columns["vel_d"])
        notes.append("height: integrated from vel_d (no lat, lon, alt columns): the first row is the take-off point")
    else:
        raise InputError(path, None, "no global or local position in the log: a profile needs the height of each row")
    keep = (np.asarray(traj.status).astype(np.int64) & ~allow) == 0
    if not (keep & np.isfinite(height)).any():
        notes.append(why_no_row(np.asarray(traj.status).astype(np.int64), keep, allow))
    out = traj.outputs
    kept_t = t[keep & np.isfinite(height)]
    utc = (float(kept_t[0] + geo.utc_offset_s), float(kept_t[-1] + geo.utc_offset_s)) \
        if geo.utc_offset_s is not None and kept_t.size else None
    wind = out[keep][:, model.outputs.slice("wind_ned")]
    if af.vertical_law == VERTICAL_FALLBACK:
        wind = wind.copy()
        wind[:, 2] = np.nan  # the step publishes 0 there: not a measured calm, no vertical wind at all
        notes.append(f'vertical wind: none (force_air.vertical_law = "{VERTICAL_FALLBACK}": not identified)')
    return Samples(height[keep], wind,
                   out[keep][:, model.outputs.slice("wind_sigma_h")][:, 0],
                   out[keep][:, model.outputs.slice("wind_sigma_up")][:, 0], tuple(notes), utc, np.asarray(t)[keep],
                   binstats.sampling_step(np.asarray(t)))


def why_no_row(status: np.ndarray, keep: np.ndarray, allow: int = 0) -> str:
    """Why a flight gave the profile no row, in words that say what to fly or allow next time: a log that
    never flew is no rejected estimate, and no --allow can admit it."""
    from dobwind.model.status import STATUS_LANDED, accepted, describe

    if not len(status) or np.all(status & STATUS_LANDED):
        return "no row: never airborne (every row LANDED): the log of a flight is needed"
    ok = accepted(status)
    if not ok.any():
        return "no row: no airborne row was accepted by the estimator (see `dobwind replay` for the rejections)"
    if keep.any():
        return "no row: the kept rows have no height (no position near them)"
    values, counts = np.unique(status[ok], return_counts=True)
    flags = ", ".join(f"{describe(int(v))} {int(c)}" for v, c in sorted(zip(values, counts), key=lambda x: -x[1]))
    kept = "trusted" + (" or flagged only as --allow admits" if allow else "")
    return (f"no row: none of its {int(ok.sum())} accepted airborne rows is {kept} ({flags}); a longer flight "
            "settles, a calibrated airframe is not UNCALIBRATED, --allow FLAG admits a quality flag")


def _integrated_height(t: np.ndarray, vel_d: np.ndarray) -> np.ndarray:
    """Height above the first row by the trapezoid rule on -vel_d (NaN velocities count as 0)."""
    up = -np.nan_to_num(np.asarray(vel_d, float))
    return np.r_[0.0, np.cumsum(0.5 * (up[1:] + up[:-1]) * np.diff(t))]


def flight_sums(airframe_path: str, path: str, bin_m: float, backend: str, precision: Precision,
                rate_hz: float | None, allow: int) -> tuple[dict[int, np.ndarray], int, tuple[str, ...],
                                                            tuple[float, float] | None]:
    """A worker's job (top level, so a process pool can call it): (per-bin sums, trusted rows, notes, UTC
    span of the trusted rows or None)."""
    from dobwind.model.airframe import load_airframe

    samples = flight_samples(load_airframe(airframe_path), path, backend, precision, rate_hz, allow)
    return bin_sums(samples, bin_m), len(samples.height_m), samples.notes, samples.utc_s


def coverage(spans: list[tuple[float, float] | None]) -> tuple[str, str] | None:
    """ISO 8601 UTC start and end over the flights that have GPS time (None: none has)."""
    import datetime as dt

    known = [s for s in spans if s is not None]
    if not known:
        return None
    iso = [dt.datetime.fromtimestamp(x, dt.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
           for x in (min(s[0] for s in known), max(s[1] for s in known))]
    return iso[0], iso[1]
