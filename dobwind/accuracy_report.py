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
    Column("hold CV", _path("fit", "cv_rmse_mps"), 3),      # hold-level speed CV (dobwind/holdcv.py)
    Column("tun/CV", _path("cv_ratio"), 2),            # calibrated holds (the goal)
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
    # tun/CV: the per-hold RMS speed error of the tunnel holds inside the calibrated range over the fit's
    # hold-level CV for them (each hold's speed band); see accuracy_run._cv_ratios.
    Goal("fit CV predicts tunnel hold RMS within a factor 2", "tun/CV", 2.0, two_sided=True),
)


def _badness(goal: Goal, value: float) -> float:
    """How far from the goal (larger is worse), so the WORST row picks the right value per column."""
    return abs(math.log(value)) if goal.two_sided and value > 0 else value


def worst(rows: list[dict[str, Any]]) -> dict[str, float | None]:
    """Column by column, the worst value over rows (None if any row lacks it: a failed run is worst)."""
    goals = {g.column: g for g in GOALS}
    out: dict[str, float | None] = {}
    for col in COLUMNS:
        values = [col.get(r) for r in rows]
        if not values or any(v is None for v in values):
            out[col.title] = None
            continue
        goal = goals.get(col.title)
        key = (lambda v: _badness(goal, v)) if goal else (lambda v: v)
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
