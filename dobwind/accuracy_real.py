"""Real flights for `make accuracy`: the Neural-Fly wind-tunnel runs, when ../shared/data/neural-fly exists.

The data's licence forbids copying it (or anything derived from it) into the repository, so the runs
are converted in a temporary folder by the existing converter and only printed. Each run is scored by
its mean estimated horizontal wind speed against the tunnel's nominal speed (there is no anemometer).
The user's workflow is the command line with no options: `fit` on logs, `replay --backend c`.
"""
from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Any

from dobwind.accuracy_run import run_child
from dobwind.realdata import AIRFRAME, NOMINAL_MPS, convert, runs
from dobwind.model.airframe import load_airframe

BASELINE_TRAIN = ("nowind", "70wind", "100wind")
TRAINING_GOAL_MPS = 0.3   # each training run replays within this of its nominal speed (#12)
HELD_OUT_GOAL_MPS = 0.5   # held-out runs within this on average (#12)


def _replay(fitted: str, log: Path, nominal: float, workdir: Path) -> dict[str, Any]:
    child = run_child(["replay", fitted, str(log), "--backend", "c", "--json"], workdir)
    if child.exit_code != 0:
        return {"nominal_mps": nominal, "error": f"replay exit {child.exit_code}: {child.last_stderr}"}
    estimate = json.loads(child.stdout).get("mean_estimated_wind", {}).get("horizontal_mps")
    return {"nominal_mps": nominal, "estimate_mps": estimate,
            "error_mps": None if estimate is None else estimate - nominal}


def _fit_and_replay(train: list[str], score: list[str], logs: dict[str, Path], workdir: Path, tag: str) -> dict[str, Any]:
    fitted = str(workdir / f"fitted_{tag}.toml")
    child = run_child(["fit", str(AIRFRAME), *[str(logs[n]) for n in train], "-o", fitted, "--json"], workdir)
    out: dict[str, Any] = {"trained_on": train, "fit_exit_code": child.exit_code, "fit_message": child.last_stderr,
                           "fit_time_s": child.wall_s, "runs": {}}
    if child.exit_code != 0:
        return out
    for name in score:
        out["runs"][name] = {**_replay(fitted, logs[name], NOMINAL_MPS[name], workdir), "training": name in train}
    return out


def real_runs(data_dir: Path, leave_one_out: bool = True) -> dict[str, Any] | None:
    """None without the data; else the baseline split (and leave-one-out) through the command line."""
    found = runs(data_dir)
    if not all(name in found for name in BASELINE_TRAIN):
        return None
    af = load_airframe(AIRFRAME)
    with tempfile.TemporaryDirectory(prefix="dobwind-accuracy-real-") as tmp:
        work = Path(tmp)
        logs = {name: convert(path, NOMINAL_MPS[name], af.mass_kg, af.gravity_mps2, work / f"{name}.csv")
                for name, path in found.items()}
        result = {"split": _fit_and_replay(list(BASELINE_TRAIN), list(logs), logs, work, "split")}
        if leave_one_out:
            result["leave_one_out"] = {
                name: _fit_and_replay([n for n in logs if n != name], [name], logs, work, f"loo_{name}")
                for name in logs}
    return result


def _fmt(value: float | None, digits: int = 2) -> str:
    return "-" if value is None else f"{value:+.{digits}f}"


def real_lines(result: dict[str, Any]) -> tuple[list[str], dict[str, bool]]:
    """Text and verdicts: each training run within 0.3 m/s; held-out runs within 0.5 m/s on average."""
    split = result["split"]
    lines = [f"Real runs (Neural-Fly, converted in a temporary folder; nothing copied): `dobwind fit nf_quad.toml "
             f"{' '.join(BASELINE_TRAIN)}` (no options), `replay --backend c`; error = mean |wind| - nominal"]
    verdicts: dict[str, bool] = {}
    if split["fit_exit_code"] != 0:
        lines.append(f"  split fit FAILED (exit {split['fit_exit_code']}): {split['fit_message']}")
        verdicts["real: training runs within 0.3 m/s"] = verdicts["real: held-out runs within 0.5 m/s on average"] = False
    else:
        for name, r in split["runs"].items():
            lines.append(f"  {name:10s}{'*' if r['training'] else ' '} nominal {r['nominal_mps']:5.1f}  "
                         f"estimate {r.get('estimate_mps') or float('nan'):6.2f}  error {_fmt(r.get('error_mps'))}"
                         + (f"  {r['error']}" if "error" in r else ""))
        train = [r.get("error_mps") for r in split["runs"].values() if r["training"]]
        held = [r.get("error_mps") for r in split["runs"].values() if not r["training"]]
        verdicts["real: training runs within 0.3 m/s"] = all(e is not None and abs(e) <= TRAINING_GOAL_MPS for e in train)
        verdicts["real: held-out runs within 0.5 m/s on average"] = bool(held) and all(e is not None for e in held) and (
            sum(abs(e) for e in held) / len(held) <= HELD_OUT_GOAL_MPS)  # type: ignore[arg-type]
    loo = result.get("leave_one_out")
    if loo:
        errors = []
        for name, r in loo.items():
            run = r["runs"].get(name, {})
            errors.append(run.get("error_mps"))
            status = f"error {_fmt(run.get('error_mps'))}" if r["fit_exit_code"] == 0 else f"fit FAILED: {r['fit_message']}"
            lines.append(f"  leave-one-out {name:10s} {status}")
        ok = all(e is not None for e in errors) and sum(abs(e) for e in errors) / len(errors) <= HELD_OUT_GOAL_MPS  # type: ignore[arg-type]
        verdicts["real: leave-one-out within 0.5 m/s on average"] = ok
    for label, ok in verdicts.items():
        lines.append(f"  {'PASS' if ok else 'MISS'}  {label}")
    return lines, verdicts
