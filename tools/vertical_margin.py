"""How far the chosen vertical law beats zero vertical airflow, fold by fold and block by block: the
measurement behind docs/tunnel-runs.md's "How far the law must beat zero" (issue #31).

    DOBWIND_VERTICAL_MARGIN=margins.jsonl PYTHONPATH=DIR:. python -m benchmarks.accuracy --quick
        with DIR/sitecustomize.py holding ``import tools.vertical_margin as m; m.install_from_environment()``:
        every `dobwind fit` the benchmark runs (in its own process) appends one JSON line per fit to the file;
    .venv/bin/python tools/vertical_margin.py margins.jsonl [--markdown]
        the table: per fit, its frame, the vertical CV, the RMS of the true vertical airflow (the "zero"
        score of dobwind/calibrate/fitfamily.py vertical_warning), their ratio, the folds where the law's
        held-out squared error is below zero's, and the paired comparisons over folds and over blocks
        (mean improvement of the squared error over its standard error).

The probe wraps dragfit.grouped_cv (reimplemented with the same sums, so the fit is unchanged) to keep the
per-fold and per-block sums, and fitfamily._chosen_report to write the chosen law's line; a diagnosis
tool, never imported by dobwind.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np

ENV = "DOBWIND_VERTICAL_MARGIN"
_RECENT: list[dict[str, Any]] = []   # the latest grouped_cv calls: cv_v and its per-fold and per-block sums
_KEEP = 400


def _sums(error_v: np.ndarray, zero_v: np.ndarray, group: np.ndarray) -> list[list[float]]:
    """Per block of ``group``: [samples, law's squared error sum, zero's squared error sum]."""
    return [[float(np.sum(group == g)), float(np.sum(error_v[group == g] ** 2)), float(np.sum(zero_v[group == g] ** 2))]
            for g in np.unique(group)]


def _recording_cv(original_folds: Any, prediction_error: Any) -> Any:
    def grouped_cv(samples: Any, fit_predict: Any, folds: Any = None) -> tuple[float, float]:
        folds = original_folds(samples) if folds is None else folds
        if not folds:
            return math.nan, math.nan
        squared_h, squared_v, count = 0.0, 0.0, 0
        per_fold, per_block = [], []
        for train, test in folds:
            error = prediction_error(fit_predict(train, test), test.airflow)
            squared_h += float(np.sum(error[:, 0] ** 2 + error[:, 1] ** 2))
            squared_v += float(np.sum(error[:, 2] ** 2))
            count += len(test)
            per_fold.append([float(len(test)), float(np.sum(error[:, 2] ** 2)), float(np.sum(test.airflow[:, 2] ** 2))])
            per_block += _sums(error[:, 2], test.airflow[:, 2], test.group)
        result = math.sqrt(squared_h / count), math.sqrt(squared_v / count)
        _RECENT.append({"cv_v": result[1], "folds": per_fold, "blocks": per_block})
        del _RECENT[:-_KEEP]
        return result
    return grouped_cv


def install(log_path: str) -> None:
    """Wrap the fit so that every chosen law writes its line to ``log_path``."""
    from dobwind.calibrate import dragfit, fitfamily
    dragfit.grouped_cv = _recording_cv(dragfit.fold_splits, dragfit.prediction_error)
    chosen_report = fitfamily._chosen_report

    def recorded(report: Any, chosen: str, scores: Any, samples: Any, failures: Any) -> Any:
        out = chosen_report(report, chosen, scores, samples, failures)
        cv_v = report.vertical_cv_rmse_mps
        match = next((r for r in reversed(_RECENT) if cv_v is not None and r["cv_v"] == cv_v), None)
        air_z = samples.airflow[:, 2] if len(samples) else np.zeros(0)
        line = {"argv": sys.argv[1:], "model": chosen, "cv_v": cv_v,
                "zero": float(np.sqrt(np.mean(air_z ** 2))) if len(air_z) else None,
                "warned": out[1] is not None, "folds": match and match["folds"], "blocks": match and match["blocks"]}
        with open(log_path, "a") as fh:
            fh.write(json.dumps(line) + "\n")
        return out
    fitfamily._chosen_report = recorded


def install_from_environment() -> None:
    if os.environ.get(ENV):
        install(os.environ[ENV])


def paired_t(rows: list[list[float]]) -> tuple[float, float, int]:
    """Over the units (folds or blocks): the mean of zero's minus the law's mean squared error (m2/s2),
    that mean over its standard error, and how many units the law wins."""
    d = np.array([(z - law) / n for n, law, z in rows if n > 0])
    if len(d) < 2:
        return math.nan, math.nan, int(np.sum(d > 0))
    se = float(np.std(d, ddof=1) / math.sqrt(len(d)))
    return float(np.mean(d)), float(np.mean(d) / se) if se > 0 else math.inf, int(np.sum(d > 0))


def ratio_bound(rows: list[list[float]]) -> tuple[float, float]:
    """Over the units (blocks): R, the law's held-out squared error over zero's (the square of cv_v /
    zero), and its standard error by linearising the ratio of sums (the delta method: each unit's residual
    L_u - R Z_u), the usual error of a ratio estimator from units drawn alike."""
    law, zero = np.array([r[1] for r in rows]), np.array([r[2] for r in rows])
    if len(rows) < 2 or zero.sum() <= 0:
        return math.nan, math.nan
    ratio = float(law.sum() / zero.sum())
    residual = law - ratio * zero
    n = len(rows)
    return ratio, float(math.sqrt(n / (n - 1) * np.sum(residual ** 2)) / zero.sum())


def table_rows(path: Path) -> list[str]:
    rows = ["| fit | family | cv_v | zero | ratio | folds won | t (folds) | blocks won | t (blocks) | R | SE(R) | R + 2 SE | warned |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for text in path.read_text().splitlines():
        line = json.loads(text)
        # the airframe, then the first log with its folder (the benchmarks' run folders name vehicle and seed)
        argv = line["argv"]
        name = (f"{Path(argv[1]).stem} {Path(argv[2]).parent.name}/{Path(argv[2]).name}" if len(argv) > 2
                else "(in process)")   # benchmarks/realdata.py fits in its own process
        cv, zero = line["cv_v"], line["zero"]
        ratio = f"{cv / zero:.2f}" if cv is not None and zero else "-"
        cells = [name, line["model"], f"{cv:.3f}" if cv is not None else "-", f"{zero:.3f}" if zero else "-", ratio]
        for key in ("folds", "blocks"):
            if line[key]:
                _, t, won = paired_t(line[key])
                cells += [f"{won}/{len(line[key])}", f"{t:.2f}"]
            else:
                cells += ["-", "-"]
        ratio_sq, se = ratio_bound(line["blocks"]) if line["blocks"] else (math.nan, math.nan)
        cells += [f"{ratio_sq:.3f}", f"{se:.3f}", f"{ratio_sq + 2 * se:.3f}"]
        rows.append("| " + " | ".join(cells + ["yes" if line["warned"] else "no"]) + " |")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("log", type=Path, help="the JSON lines the probe wrote")
    args = parser.parse_args()
    print("\n".join(table_rows(args.log)))


if __name__ == "__main__":
    main()
