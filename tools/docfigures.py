"""docs/figures.md and its images, made from the current code by one command (`make figures`, i.e.
`python -m tools.docfigures`): issue #33 found the page showing figures of the polynomial era.

Two airframes: the shipped reference m300 (the paper's polynomial law) and the same vehicle with a
body-frame drag law, the family `fit` writes on most vehicles, whose coefficients are the isotropic part
of the simulator's m300 (dobwind/simulate/simulate.py true_vehicle: its rotor and body drag, horizontal and
vertical), so the replays below fly that law against the simulator's anisotropic truth. For each: the
Bode plot, the discretizations, the ramp and the wind-unit view (`dobwind analyze`'s figures), and for the
drag airframe replays of short simulated tunnel and still-air flights (Python backend).

The page carries the numbers each figure shows and a checksum of every figure's data (rounded to
``DIGITS`` significant digits, not the PNG bytes, which depend on the matplotlib build), so
tests/test_docfigures.py regenerates the markdown and fails when the page is stale.
"""
from __future__ import annotations

import dataclasses
import hashlib
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from dobwind.analysis.report import analyze, write_plots
from dobwind.model.airframe import Airframe, load_airframe
from dobwind.model import forceair
from dobwind.model.forceair import DragLaw
from dobwind.core.resources import shipped_airframe

DIGITS = 5
FREQS_HZ = [0.1, 0.5, 1.0]
AIRSPEEDS_MPS = tuple(float(s) for s in range(0, 13, 2))
SHOWN_MPS = (0.0, 2.0, 6.0, 10.0)  # the airspeeds whose numbers the page prints
# The force noise of the wind-unit figures: the scatter of the observer's force estimate before the
# low-pass, per axis (N), stated on the page (the shipped airframes record none).
FORCE_NOISE_N = 0.3
# Short simulated flights of the drag airframe: (scenario, hold s, seed). The shipped m300's polynomial
# is the paper's calibration of the real vehicle, not of the simulator's: it is not replayed here.
REPLAYS = (("tunnel", 6.0, 1), ("still-air", 4.0, 2))


def drag_body_m300(m300: Airframe) -> Airframe:
    """m300 with the body-frame drag law of the simulator's m300 vehicle (its isotropic part)."""
    from dobwind.simulate.simulate import true_vehicle

    truth = true_vehicle(m300)
    law = DragLaw(l0=truth.drag_lin, q0=truth.drag_quad, lz=truth.drag_lin_z, qz=truth.drag_quad_z, frame="body")
    return dataclasses.replace(m300, name="m300_drag", drag=law)


def _digest(values: list[np.ndarray]) -> str:
    """SHA-256 of the figure data, each number rounded to DIGITS significant digits."""
    h = hashlib.sha256()
    for v in values:
        flat = np.asarray(v, dtype=float).ravel()
        h.update(" ".join(f"{x:.{DIGITS - 1}e}" for x in flat).encode())
    return h.hexdigest()[:16]


def _replay(af: Airframe, folder: Path, scenario: str, hold_s: float, seed: int) -> dict[str, Any]:
    from dobwind.replay.replay import replay, score
    from dobwind.simulate.simulate import write_log

    log_path = folder / f"{scenario}.csv"
    write_log(log_path, af, scenario, seed=seed, hold_s=hold_s)
    model, log, traj = replay(af, str(log_path))
    wind = traj.outputs[:, model.outputs.slice("wind_ned")]
    scores = score(log, traj, model)
    return {"time": log.time_s, "wind": wind, "truth": log.true_wind, "scores": scores}


def _airframe_figures(af: Airframe, images: Path | None, folder: Path) -> dict[str, Any]:
    """The numbers the page shows for ``af``, and with ``images`` its figures drawn there."""
    report, systems = analyze(af, FREQS_HZ, airspeeds_mps=AIRSPEEDS_MPS, force_noise_n=FORCE_NOISE_N)
    block = report["wind_units"]
    if images is not None:
        for path in write_plots(report, systems, folder / af.name):  # wind_units.png too (airspeeds asked)
            (images / f"{af.name}_{path.name}").write_bytes(path.read_bytes())
    ramp = systems["ramp"]
    data = [ramp.scheduled_mps, ramp.fixed_mps,
            [[p["slope_along_mps_per_n"], p["wind_noise_along_mps"], p["ramp_lag_s"]] for p in block["airspeeds"]],
            [[c["bandwidth_hz"] or 0.0, c["group_delay_s"]] for c in report["cascade"]]]
    replays = {}
    for scenario, hold, seed in (REPLAYS if forceair.family(af) != "polynomial" else ()):
        run = _replay(af, folder, scenario, hold, seed)
        if images is not None:
            from dobwind.io.plots import replay_plot

            replay_plot(run["time"], run["wind"], run["truth"], f"{af.name}, '{scenario}' scenario (Python reference)",
                        str(images / f"{af.name}_replay_{scenario}.png"))
        data.append(run["wind"])
        replays[scenario] = run["scores"]
    return {"report": report, "replays": replays, "digest": _digest(data)}


def _pick(block: dict[str, Any], speed: float) -> dict[str, Any]:
    return next(p for p in block["airspeeds"] if p["airspeed_mps"] == speed)


def _airframe_section(af: Airframe, numbers: dict[str, Any]) -> list[str]:
    r = numbers["report"]
    ramp, block = r["ramp"], r["wind_units"]
    family = {"polynomial": "polynomial (the paper's)", "drag-heading": "drag, heading frame",
              "drag-body": "drag, body frame"}[forceair.family(af)]
    noise = ", ".join(f"{_pick(block, s)['wind_noise_along_mps']:.3f} m/s at {s:g}" for s in SHOWN_MPS)
    lag = ", ".join(f"{_pick(block, s)['ramp_lag_s']:.2f} s at {s:g}" for s in SHOWN_MPS)
    n = af.name
    return [
        f"## {n}: force-air law {family}", "",
        "| figure | what it shows |", "|---|---|",
        f"| ![Bode](images/{n}_bode.png) | `dobwind analyze {n} -o DIR`: the observer and the low-pass frozen at "
        f"each schedule breakpoint |",
        f"| ![discretizations](images/{n}_discretizations.png) | the same command: the observer alone, four "
        f"discretizations at the same gains |",
        f"| ![ramp](images/{n}_ramp.png) | the same command: a wind ramp to 10 m/s at 0.5 m/s^2 through the "
        f"step, mean lag {ramp['scheduled_lag_s']:.2f} s scheduled, {ramp['fixed_lag_s']:.2f} s with a fixed "
        f"{ramp['fixed_cutoff_hz']:g} Hz low-pass |",
        f"| ![wind units](images/{n}_wind_units.png) | `dobwind analyze {n} --airspeed 0 2 ... 12 --force-noise "
        f"{FORCE_NOISE_N:g}`: the law's slope, the wind noise along the airflow ({noise} m/s airspeed) and the "
        f"ramp lag ({lag} m/s) |",
        *_replay_rows(n, numbers["replays"]),
        "", f"Figure data checksum ({DIGITS} significant digits): `{numbers['digest']}`", ""]


def _replay_rows(name: str, replays: dict[str, Any]) -> list[str]:
    rows = []
    if "tunnel" in replays:
        tunnel = replays["tunnel"]["per_sample"]
        rows.append(f"| ![tunnel](images/{name}_replay_tunnel.png) | `dobwind simulate tunnel --hold 6 --seed 1` "
                    f"replayed against the simulator's anisotropic vehicle: speed error mean "
                    f"{tunnel['speed_mean']:.3f} m/s, max {tunnel['speed_max']:.3f} m/s per sample |")
    if "still-air" in replays:
        still = replays["still-air"]["mean_estimated_wind"]
        rows.append(f"| ![still air](images/{name}_replay_still-air.png) | `dobwind simulate still-air --hold 4 "
                    f"--seed 2` replayed: mean estimated wind {still['horizontal_mps']:.3f} m/s horizontal in still "
                    f"air |")
    return rows


HEADER = """# Reference figures

Made from the current code by `make figures` (`python -m tools.docfigures`), which rewrites
this page and its images; tests/test_docfigures.py fails when the page is stale. Two airframes: the
shipped m300 with the paper's polynomial law, and the same vehicle with the body-frame drag law `fit`
writes on most vehicles (its coefficients: the isotropic part of the simulator's m300, see
tools/docfigures.py). The wind-unit figures take a force noise of {noise:g} N (the observer's
force estimate before the low-pass, per axis); `dobwind analyze` takes it from the airframe when `fit`
recorded one, or from `--force-noise`.
"""


def render(numbers: dict[str, dict[str, Any]], airframes: list[Airframe]) -> str:
    lines = [HEADER.format(noise=FORCE_NOISE_N)]
    for af in airframes:
        lines += _airframe_section(af, numbers[af.name])
    lines.append("`dobwind report AIRFRAME LOG -o report.html` puts a replay figure and the analysis figures on one "
                 "page with the error and status tables.")
    return "\n".join(lines) + "\n"


def airframes() -> list[Airframe]:
    m300 = load_airframe(shipped_airframe("m300"))
    return [m300, drag_body_m300(m300)]


def build(images: Path | None) -> str:
    """The page's markdown; with ``images``, every figure drawn there too (the test only compares text)."""
    if images is not None:
        images.mkdir(parents=True, exist_ok=True)
    chosen = airframes()
    with tempfile.TemporaryDirectory() as tmp:
        numbers = {af.name: _airframe_figures(af, images, Path(tmp)) for af in chosen}
    return render(numbers, chosen)


def main(argv: list[str] | None = None) -> int:
    docs = Path(argv[0] if argv else "docs")
    page = build(docs / "images")
    from dobwind.io.atomic import write_text_atomically

    write_text_atomically(docs / "figures.md", lambda handle: handle.write(page))
    print(f"wrote {docs / 'figures.md'} and its images in {docs / 'images'}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
