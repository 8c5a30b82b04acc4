"""What `dobwind analyze` reports: tables, JSON and plots of the observer and the scheduled low-pass
(the command around it, its arguments and exit code, is ``dobwind.cli.analyze``)."""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any, Callable

import numpy as np

from dobwind.analysis import plots
from dobwind.analysis.figures import figures, noise_gain
from dobwind.analysis.linear import axis_system, continuous_observer, jacobian_function, linearize
from dobwind.analysis.ramp import ramp_experiment
from dobwind.analysis.windunits import NoiseSource, wind_text, wind_units
from dobwind.model.stability import unstable_reason
from dobwind.model.airframe import DISCRETIZATIONS, Airframe
from dobwind.model.step import build_step
from dobwind.model.signals import log_signals

AXES = "xyz"
SCHEDULE_GRID_POINTS = 61


def _noise_unit(af: Airframe) -> str:
    return "N per m/s" if not log_signals(af).measured_acceleration else "N per m/s^2"


def schedule_check(af: Airframe) -> dict[str, Any]:
    """Largest cascade pole magnitude over a grid of frozen schedule speeds, at dt and at max_dt."""
    model = build_step(af)
    jac = jacobian_function(model)
    top = max(af.filter.speeds_mps) * 1.5 + 1.0
    worst = 0.0
    where = (0.0, af.observer.sample_time_s)
    for dt in (af.observer.sample_time_s, af.limits.max_dt_s):
        for speed in np.linspace(0.0, top, SCHEDULE_GRID_POINTS):
            lin = linearize(model, speed, dt, function=jac)
            for axis in range(3):
                magnitude = float(np.max(np.abs(lin.axis(axis).poles())))
                if magnitude > worst:
                    worst, where = magnitude, (float(speed), dt)
    return {"max_pole_magnitude": worst, "at_speed_mps": where[0], "at_dt_s": where[1], "stable": worst < 1.0,
            "speeds_checked_mps": [0.0, top], "points": SCHEDULE_GRID_POINTS}


def analyze(af: Airframe, freqs_hz: list[float], with_ramp: bool = True, airspeeds_mps: tuple[float, ...] = (),
            force_noise_n: float | None = None, input_noise: NoiseSource | None = None) -> tuple[dict[str, Any], dict[str, Any]]:
    """(JSON-able report, python-control systems for the plots). The wind-unit block (windunits.py)
    covers every breakpoint and ``airspeeds_mps``."""
    model = build_step(af)
    report: dict[str, Any] = {
        "airframe": af.name, "sample_time_s": af.observer.sample_time_s, "discretization": af.observer.discretization,
        "gains": list(af.observer.gains), "gains_kg_per_s": list(af.observer.gains), "acceleration": af.observer.acceleration, "noise_unit": _noise_unit(af),
    }
    systems: dict[str, Any] = {"observer": [], "cascade": [], "discretizations": []}
    observer = []
    force_jac, noise_jac = jacobian_function(model, "force"), jacobian_function(model, "noise")
    hover, hover_noise = linearize(model, function=force_jac), linearize(model, function=noise_jac)
    for axis in range(3):
        sys_ = hover.axis(axis, with_filter=False)
        fig = figures(sys_, freqs_hz)
        systems["observer"].append((f"observer {AXES[axis]}", sys_))
        noise = noise_gain(hover_noise.axis(axis, with_filter=False)) if fig.stable else math.inf
        observer.append({"axis": AXES[axis], "gain": af.observer.gains[axis], **fig.as_dict(), "noise_gain": noise})
    report["observer"] = observer
    stable = all(o["stable"] for o in observer)
    cascade = []
    if stable:
        for speed, cutoff in zip(af.filter.speeds_mps, af.filter.cutoffs_hz):
            lin = linearize(model, speed, function=force_jac)
            lin_noise = linearize(model, speed, function=noise_jac)
            for axis in range(3):
                sys_ = lin.axis(axis)
                fig = figures(sys_, freqs_hz)
                if axis == 0:
                    systems["cascade"].append((f"+ low-pass {cutoff:g} Hz ({speed:g} m/s)", sys_))
                noise = noise_gain(lin_noise.axis(axis))
                cascade.append({"axis": AXES[axis], "speed_mps": speed, "cutoff_hz": cutoff, **fig.as_dict(),
                                "noise_gain": noise})
        report["schedule"] = schedule_check(af)
    report["cascade"] = cascade
    comparison = []
    rate = af.observer.gains[0] / af.mass_kg
    cont = continuous_observer(rate)
    comparison.append({"discretization": "continuous", "pole": -rate, "bandwidth_hz": rate / (2 * math.pi),
                       "gain_phase": figures(cont, freqs_hz).as_dict()["gain_phase"], "stable": True})
    for method in DISCRETIZATIONS:
        variant = dataclasses.replace(af, observer=dataclasses.replace(af.observer, discretization=method))
        sys_ = axis_system(build_step(variant), 0, with_filter=False)
        fig = figures(sys_, freqs_hz)
        systems["discretizations"].append((method, sys_))
        comparison.append({"discretization": method, "pole": float(np.real(fig.poles[0])),
                           "bandwidth_hz": None if not fig.stable else fig.bandwidth_hz, "stable": fig.stable,
                           "gain_phase": fig.as_dict()["gain_phase"]})
    report["discretizations"] = comparison
    reason = unstable_reason(af)
    report["stable"] = stable and reason is None and report.get("schedule", {}).get("stable", False)
    report["unstable_reason"] = reason
    if stable:
        report["wind_units"] = wind_units(af, model, freqs_hz, list(airspeeds_mps), force_noise_n, input_noise)
    if with_ramp and stable:
        _add_ramp(af, report, systems)
    return report, systems


def _add_ramp(af: Airframe, report: dict[str, Any], systems: dict[str, Any]) -> None:
    ramp = ramp_experiment(af)
    systems["ramp"] = ramp
    report["ramp"] = {"scheduled_lag_s": ramp.scheduled_lag_s, "fixed_lag_s": ramp.fixed_lag_s,
                      "fixed_cutoff_hz": ramp.fixed_cutoff_hz, "lag_reduction_s": ramp.lag_reduction_s,
                      "paper_lag_reduction_s": 2.2}


def _fmt_bw(value: float | None) -> str:
    return ">Nyquist" if value is None or (isinstance(value, float) and math.isinf(value)) else f"{value:.3f}"


def _gp(entry: dict) -> str:
    return " ".join(f"{g['gain_db']:6.2f}/{g['phase_deg']:6.1f}" for g in entry["gain_phase"])


def text(report: dict[str, Any], freqs_hz: list[float]) -> str:
    freq_head = " ".join(f"{f:>5g} Hz dB/deg" for f in freqs_hz)
    lines = [f"dobwind analyze {report['airframe']}: {report['discretization']} discretization, "
             f"dt {report['sample_time_s']:g} s, gains {report['gains']} kg/s, acceleration input "
             f"'{report['acceleration']}'", "",
             "Observer alone (force estimate before the low-pass), per axis:",
             f"  axis   gain  pole        stable  -3dB Hz  {freq_head}  settle(2%) s  delay s  noise ({report['noise_unit']})"]
    for o in report["observer"]:
        pole = o["poles"][0] if not isinstance(o["poles"][0], list) else complex(*o["poles"][0])
        lines.append(f"  {o['axis']:4s} {o['gain']:6g}  {pole:<10.6g}  {'yes' if o['stable'] else 'NO':6s}  "
                     f"{_fmt_bw(o['bandwidth_hz']):7s}  {_gp(o)}  {o['settling_time_s']:12.3g}  {o['group_delay_s']:7.3f}  "
                     f"{o['noise_gain']:.4g}")
    if report["cascade"]:
        lines += ["", "Observer + scheduled low-pass, schedule frozen at each breakpoint:",
                  f"  axis  speed m/s  cutoff Hz  -3dB Hz  {freq_head}  settle(2%) s  delay s  noise"]
        for c in report["cascade"]:
            lines.append(f"  {c['axis']:4s}  {c['speed_mps']:9g}  {c['cutoff_hz']:9g}  {_fmt_bw(c['bandwidth_hz']):7s}  "
                         f"{_gp(c)}  {c['settling_time_s']:12.3g}  {c['group_delay_s']:7.3f}  {c['noise_gain']:.4g}")
        s = report["schedule"]
        lines.append(f"  schedule between breakpoints: largest pole magnitude {s['max_pole_magnitude']:.6f} "
                     f"({'stable' if s['stable'] else 'UNSTABLE'}) over {s['points']} speeds in "
                     f"[{s['speeds_checked_mps'][0]:g}, {s['speeds_checked_mps'][1]:g}] m/s at dt and max_dt")
    lines += ["", "Discretizations with the same gain (axis x, observer alone):",
              f"  method      pole        -3dB Hz  {freq_head}"]
    for d in report["discretizations"]:
        lines.append(f"  {d['discretization']:10s}  {d['pole']:<10.6g}  {_fmt_bw(d['bandwidth_hz']):7s}  {_gp(d)}"
                     + ("" if d["stable"] else "  UNSTABLE"))
    if "ramp" in report:
        r = report["ramp"]
        lines += ["", f"Ramp to 10 m/s at 0.5 m/s^2: mean lag {r['scheduled_lag_s']:.2f} s scheduled, "
                      f"{r['fixed_lag_s']:.2f} s with a fixed {r['fixed_cutoff_hz']:g} Hz low-pass: "
                      f"{r['lag_reduction_s']:.2f} s less lag (paper: 2.2 s)"]
    if "wind_units" in report:
        lines += wind_text(report["wind_units"])
    lines.append("")
    lines.append("stable" if report["stable"] else f"UNSTABLE: {report['unstable_reason'] or 'see the poles above'}")
    return "\n".join(lines)


def write_plots(report: dict[str, Any], systems: dict[str, Any], out_dir: Path,
                stage: Callable[[Path], Path] | None = None) -> list[Path]:
    """The PNGs into out_dir; with ``stage`` (OutputFiles.stage) each goes to the temporary it names and
    the caller renames them in together."""
    if stage is None:
        out_dir.mkdir(parents=True, exist_ok=True)
        stage = lambda path: path  # noqa: E731
    written = []
    name = report["airframe"]
    if report["cascade"]:
        plots.bode(systems["observer"][:1] + systems["cascade"], f"{name}: observer and scheduled low-pass (axis x)",
                   stage(out_dir / "bode.png"))
        written.append(out_dir / "bode.png")
    plots.bode(systems["discretizations"], f"{name}: observer alone, four discretizations, same gains (axis x)", stage(out_dir / "discretizations.png"))
    written.append(out_dir / "discretizations.png")
    if "ramp" in systems:
        plots.ramp(systems["ramp"], stage(out_dir / "ramp.png"), name)
        written.append(out_dir / "ramp.png")
    if report.get("wind_units", {}).get("airspeeds"):  # drawn over the airspeeds asked (--airspeed)
        plots.wind_units(report["wind_units"], stage(out_dir / "wind_units.png"), name)
        written.append(out_dir / "wind_units.png")
    return written
