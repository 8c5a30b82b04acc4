"""Real flights for `make accuracy`: the Neural-Fly wind-tunnel runs, when ../shared/data/neural-fly exists.

The data's licence forbids copying it (or anything derived from it) into the repository, so the runs
are converted in a temporary folder by the existing converter and only printed. Each run is scored by
its mean estimated horizontal wind speed against the tunnel's nominal speed (there is no anemometer).
The user's workflow is the command line with no options: `fit` on logs, `replay --backend c`.
"""
from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path
from typing import Any

from benchmarks.accuracy_run import run_child
from dobwind.model.airframe import load_airframe
from benchmarks.tunnelruns import BASELINE, convert_all, discover, training_controller
from benchmarks.realdata import AIRFRAME, NOMINAL_MPS

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


def _fitted(workdir: Path, tag: str) -> str:
    return str(workdir / f"fitted_{tag}.toml")


def _fit_and_replay(train: list[str], score: list[str], logs: dict[str, Path], workdir: Path, tag: str) -> dict[str, Any]:
    fitted = _fitted(workdir, tag)
    child = run_child(["fit", str(AIRFRAME), *[str(logs[n]) for n in train], "-o", fitted, "--json"], workdir)
    out: dict[str, Any] = {"trained_on": train, "fit_exit_code": child.exit_code, "fit_message": child.last_stderr,
                           "fit_time_s": child.wall_s, "runs": {}}
    for name in score:  # after a failed fit every run is still listed, without a figure
        replayed = (_replay(fitted, logs[name], NOMINAL_MPS[name], workdir) if child.exit_code == 0
                    else {"nominal_mps": NOMINAL_MPS[name], "error": "the fit failed"})
        out["runs"][name] = {**replayed, "training": name in train}
    return out


def _other_controllers(split: dict[str, Any], logs: dict[str, dict[str, Path]], trainer: str,
                       workdir: Path) -> dict[str, dict[str, Any]]:
    """Every other controller's runs through the split's fitted airframe: all held out."""
    out: dict[str, dict[str, Any]] = {}
    for controller, winds in logs.items():
        if controller == trainer:
            continue
        out[controller] = {}
        for wind, path in winds.items():
            replayed = (_replay(_fitted(workdir, "split"), path, NOMINAL_MPS[wind], workdir) if split["fit_exit_code"] == 0
                        else {"nominal_mps": NOMINAL_MPS[wind], "error": "the split fit failed"})
            out[controller][wind] = {**replayed, "training": False}
    return out


def real_runs(data_dir: Path, leave_one_out: bool = True) -> dict[str, Any] | None:
    """None without the data; else the split (and leave-one-out) on the training controller's runs (the
    baseline's, else the first controller with nowind, 70wind and 100wind), and every other controller's
    runs through the split fit, through the command line."""
    found = discover(data_dir)
    if not found:
        return None
    af = load_airframe(AIRFRAME)
    with tempfile.TemporaryDirectory(prefix="dobwind-accuracy-real-") as tmp:
        work = Path(tmp)
        every, skipped = convert_all(found, af.mass_kg, af.gravity_mps2, work)
        trainer = training_controller(every, BASELINE_TRAIN)
        if trainer is None:
            sys.stderr.write(f"realdata: no controller's readable runs in {data_dir} cover {', '.join(BASELINE_TRAIN)}; "
                             "real runs skipped\n")
            return None
        logs = every[trainer]
        split = _fit_and_replay(list(BASELINE_TRAIN), list(logs), logs, work, "split")
        result = {"training_controller": trainer, "split": split,
                  "other_controllers": _other_controllers(split, every, trainer, work), "skipped": skipped}
        if leave_one_out:
            result["leave_one_out"] = {
                name: _fit_and_replay([n for n in logs if n != name], [name], logs, work, f"loo_{name}")
                for name in logs}
    return result


def _fmt(value: float | None, digits: int = 2) -> str:
    return "-" if value is None else f"{value:+.{digits}f}"


def _abs(value: float | None) -> str:
    return "-" if value is None else f"{value:.2f}"


def _or_nan(value: float | None) -> float:
    return float("nan") if value is None else value  # a 0.00 m/s estimate is a figure, not a missing one


def _run_line(name: str, r: dict[str, Any]) -> str:
    return (f"  {name:10s}{'*' if r['training'] else ' '} nominal {r['nominal_mps']:5.1f}  "
            f"estimate {_or_nan(r.get('estimate_mps')):6.2f}  error {_fmt(r.get('error_mps'))}"
            + (f"  {r['error']}" if "error" in r else ""))


def _mean_abs(errors: list[float | None]) -> float | None:
    """The mean |error|; None when a run has no figure (a failed replay counts against the goal)."""
    if not errors or any(e is None for e in errors):
        return None
    return sum(abs(e) for e in errors) / len(errors)  # type: ignore[arg-type]


def held_out_errors(result: dict[str, Any]) -> list[float | None]:
    """Every held-out run's error: the training controller's runs the split did not fit on, and every run
    of every other controller (same vehicle, same tunnel, fitted on none of them)."""
    errors = [r.get("error_mps") for r in result["split"]["runs"].values() if not r["training"]]
    return errors + [r.get("error_mps") for winds in result.get("other_controllers", {}).values() for r in winds.values()]


def _controller_lines(result: dict[str, Any]) -> tuple[list[str], dict[str, bool]]:
    """The other controllers' runs grouped by controller, the all-controller summary and its verdict."""
    others = result.get("other_controllers") or {}
    if not others:
        return [], {}
    lines = ["  other controllers' runs through the same split fit (all held out):"]
    for controller, winds in others.items():
        lines.append(f"  {controller}: {len(winds)} run{'s' * (len(winds) != 1)}, mean |error| {_abs(_mean_abs([r.get('error_mps') for r in winds.values()]))}")
        lines += ["  " + _run_line(name, r) for name, r in winds.items()]
    errors = held_out_errors(result)
    mean = _mean_abs(errors)
    missing = sum(e is None for e in errors)
    lines.append(f"  all held-out runs of {1 + len(others)} controllers: mean |error| {_abs(mean)} m/s over {len(errors)} runs"
                 + (f" ({missing} without a figure)" if missing else ""))
    label = f"real: every controller's runs within {HELD_OUT_GOAL_MPS} m/s on average ({len(errors)} runs)"
    return lines, {label: mean is not None and mean <= HELD_OUT_GOAL_MPS}


def _header(result: dict[str, Any]) -> str:
    trainer = result.get("training_controller", BASELINE)
    source = "" if trainer == BASELINE else f" (training runs: the {trainer} controller's; the baseline's are absent)"
    return (f"Real runs (Neural-Fly, converted in a temporary folder; nothing copied): `dobwind fit nf_quad.toml "
            f"{' '.join(BASELINE_TRAIN)}` (no options), `replay --backend c`; error = mean |wind| - nominal{source}")


def real_lines(result: dict[str, Any]) -> tuple[list[str], dict[str, bool]]:
    """Text and verdicts: each training run within 0.3 m/s; held-out runs within 0.5 m/s on average; and,
    when other controllers flew, all their runs with the held-out ones within 0.5 m/s on average."""
    split = result["split"]
    lines = [_header(result)]
    verdicts: dict[str, bool] = {}
    if split["fit_exit_code"] != 0:
        lines.append(f"  split fit FAILED (exit {split['fit_exit_code']}): {split['fit_message']}")
        verdicts["real: training runs within 0.3 m/s"] = verdicts["real: held-out runs within 0.5 m/s on average"] = False
    else:
        lines += [_run_line(name, r) for name, r in split["runs"].items()]
        train = [r.get("error_mps") for r in split["runs"].values() if r["training"]]
        held = [r.get("error_mps") for r in split["runs"].values() if not r["training"]]
        verdicts["real: training runs within 0.3 m/s"] = all(e is not None and abs(e) <= TRAINING_GOAL_MPS for e in train)
        held_mean = _mean_abs(held)
        verdicts["real: held-out runs within 0.5 m/s on average"] = held_mean is not None and held_mean <= HELD_OUT_GOAL_MPS
    controller_text, controller_verdict = _controller_lines(result)
    lines += controller_text
    lines += [f"  skipped {entry['controller']} {entry['wind']}: {entry['reason']}" for entry in result.get("skipped", [])]
    loo = result.get("leave_one_out")
    if loo:
        errors = []
        for name, r in loo.items():
            run = r["runs"].get(name, {})
            errors.append(run.get("error_mps"))
            status = f"error {_fmt(run.get('error_mps'))}" if r["fit_exit_code"] == 0 else f"fit FAILED: {r['fit_message']}"
            lines.append(f"  leave-one-out {name:10s} {status}")
        loo_mean = _mean_abs(errors)
        verdicts["real: leave-one-out within 0.5 m/s on average"] = loo_mean is not None and loo_mean <= HELD_OUT_GOAL_MPS
    verdicts.update(controller_verdict)
    for label, ok in verdicts.items():
        lines.append(f"  {'PASS' if ok else 'MISS'}  {label}")
    return lines, verdicts
