"""Tables and the #12 goals for `make accuracy`: per-vehicle rows, the WORST row, PASS/MISS per goal."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable


@dataclass(frozen=True)
class Column:
    title: str
    get: Callable[[dict[str, Any]], float | None]
    digits: int


def _path(*keys: str) -> Callable[[dict[str, Any]], float | None]:
    def get(row: dict[str, Any]) -> float | None:
        value: Any = row
        for key in keys:
            if not isinstance(value, dict):
                return None
            value = value.get(key)
        return float(value) if isinstance(value, (int, float)) and math.isfinite(value) else None
    return get


COLUMNS = (
    Column("tun spd mean", _path("tunnel", "speed_mean"), 3),
    Column("tun spd max", _path("tunnel", "speed_max"), 3),
    Column("tun dir mean", _path("tunnel", "direction_mean"), 2),
    Column("tun dir max", _path("tunnel", "direction_max"), 2),
    Column("still h", _path("still-air", "horizontal_mps"), 3),
    Column("still v", _path("still-air", "vertical_mps"), 3),
    Column("out spd", _path("outdoor", "speed_mean"), 3),
    Column("out dir", _path("outdoor", "direction_mean"), 2),
    Column("raw CV", _path("fit", "raw_cv_rmse_mps"), 3),    # per-sample vector CV (term selection)
    Column("hold CV", _path("fit", "cv_rmse_mps"), 3),      # hold-level speed CV (dobwind/calibrate/holdcv.py)
    Column("tun/CV", _path("cv_ratio"), 2),            # calibrated holds of one run
    # Worst rows: each vehicle's runs pooled (RMS of every run's holds over RMS of the predictions; the
    # goal). One run's tunnel is 6 calibrated holds at one heading, too few to judge an RMS alone.
    Column("tun/CV pool", _path("cv_ratio"), 2),
    Column("tun/CV all", _path("cv_ratio_all"), 2),    # every hold, extrapolated ones included
    Column("fit s", _path("fit", "time_s"), 0),
    Column("fit MB", _path("fit", "peak_rss_mb"), 0),
)


@dataclass(frozen=True)
class Goal:
    label: str
    column: str
    limit: float
    # The CV ratio is judged two-sided (within a factor of 2); every error one-sided (at most).
    two_sided: bool = False

    def met(self, value: float | None) -> bool:
        if value is None:
            return False
        return 1.0 / self.limit <= value <= self.limit if self.two_sided else value <= self.limit


GOALS = (
    Goal("tunnel per-hold speed error, mean <= 0.08 m/s", "tun spd mean", 0.08),
    Goal("tunnel per-hold speed error, max <= 0.15 m/s", "tun spd max", 0.15),
    Goal("tunnel per-hold direction error, mean <= 2 deg", "tun dir mean", 2.0),
    Goal("tunnel per-hold direction error, max <= 4 deg", "tun dir max", 4.0),
    Goal("still air: mean wind, horizontal <= 0.15 m/s", "still h", 0.15),
    Goal("still air: mean |vertical| wind <= 0.15 m/s", "still v", 0.15),
    Goal("outdoor per-segment speed error <= 0.20 m/s", "out spd", 0.20),
    Goal("outdoor per-segment direction error <= 3 deg", "out dir", 3.0),
    # tun/CV pool: the RMS speed error of a vehicle's tunnel holds inside the calibrated range (every
    # seed's) over the RMS of the fits' predictions for them: the band's hold-level CV for a hold as
    # long as the tunnel's (holdcv); see accuracy_run._cv_ratios.
    Goal("fit CV predicts tunnel hold RMS within a factor 2", "tun/CV pool", 2.0, two_sided=True),
)


RATIO_COLUMNS = ("tun/CV", "tun/CV pool", "tun/CV all")   # 1 is right; 0.5 as wrong as 2


def _badness(two_sided: bool, value: float) -> float:
    """How far from the goal (larger is worse), so the WORST row picks the right value per column."""
    return abs(math.log(value)) if two_sided and value > 0 else value


def per_run_ratio_line(rows: list[dict[str, Any]], factor: float = 2.0) -> str:
    """How the runs fare one by one against the CV-ratio goal (judged on the pooled figure)."""
    ratios = [(r.get("vehicle"), r.get("seed"), r.get("cv_ratio")) for r in rows]
    known = [x for x in ratios if isinstance(x[2], (int, float)) and x[2] > 0]
    if not known:
        return "  per run: no CV ratio"
    inside = sum(1 for *_, v in known if 1 / factor <= v <= factor)
    vehicle, seed, value = max(known, key=lambda x: abs(math.log(x[2])))
    return (f"  per run (its tunnel's calibrated holds, one heading): {inside} of {len(ratios)} within a factor "
            f"{factor:g}; farthest {vehicle} seed {seed}: {value:.2f}")


def pooled_ratio(rows: list[dict[str, Any]]) -> float | None:
    """sqrt(mean of the runs' squared tunnel RMS) over sqrt(mean of their squared predictions): the
    ratio over every calibrated tunnel hold of the runs (each run has as many holds)."""
    pairs = [((r.get("tunnel") or {}).get("speed_rms_calibrated"), (r.get("tunnel") or {}).get("predicted_rms_calibrated"))
             for r in rows]
    if not pairs or any(a is None or not p for a, p in pairs):
        return None
    return math.sqrt(sum(a * a for a, _ in pairs) / sum(p * p for _, p in pairs))


def _pooled_by_vehicle(rows: list[dict[str, Any]]) -> list[float | None]:
    vehicles = sorted({str(r.get("vehicle")) for r in rows})
    return [pooled_ratio([r for r in rows if str(r.get("vehicle")) == v]) for v in vehicles]


def worst(rows: list[dict[str, Any]]) -> dict[str, float | None]:
    """Column by column, the worst value over rows (None if any row lacks it: a failed run is worst);
    tun/CV pool pools each vehicle's runs, then takes the worst vehicle."""
    goals = {g.column: g for g in GOALS}
    out: dict[str, float | None] = {}
    for col in COLUMNS:
        values = _pooled_by_vehicle(rows) if col.title == "tun/CV pool" else [col.get(r) for r in rows]
        if not values or any(v is None for v in values):
            out[col.title] = None
            continue
        goal = goals.get(col.title)
        two_sided = col.title in RATIO_COLUMNS or (goal is not None and goal.two_sided)
        key = lambda v: _badness(two_sided, v)  # noqa: E731
        out[col.title] = max(values, key=key)  # type: ignore[arg-type]
    return out


def _cell(value: float | None, digits: int, width: int) -> str:
    return f"{'FAIL' if value is None else f'{value:.{digits}f}':>{width}s}"


def table(title: str, labelled: list[tuple[str, dict[str, float | None]]]) -> str:
    """Rows already reduced to {column title: value}."""
    label_width = max([len(label) for label, _ in labelled] + [8])
    lines = [title, f"  {'':{label_width}s}" + "".join(f"  {c.title:>{len(c.title)}s}" for c in COLUMNS)]
    for label, values in labelled:
        lines.append(f"  {label:{label_width}s}"
                     + "".join(f"  {_cell(values.get(c.title), c.digits, len(c.title))}" for c in COLUMNS))
    return "\n".join(lines)


def row_values(row: dict[str, Any]) -> dict[str, float | None]:
    return {c.title: c.get(row) for c in COLUMNS}


def goal_lines(worst_row: dict[str, float | None]) -> tuple[list[str], dict[str, bool]]:
    lines, verdicts = [], {}
    for goal in GOALS:
        value = worst_row.get(goal.column)
        ok = goal.met(value)
        verdicts[goal.label] = ok
        shown = "no result" if value is None else f"{value:.3g}"
        lines.append(f"  {'PASS' if ok else 'MISS'}  {goal.label} (worst: {shown})")
    return lines, verdicts
