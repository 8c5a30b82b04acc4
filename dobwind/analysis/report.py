"""`dobwind analyze`: tables, JSON and plots of the observer and the scheduled low-pass."""
from __future__ import annotations

import argparse
import dataclasses
import math
import sys
from pathlib import Path
from typing import Any, Callable

import numpy as np

from dobwind.analysis import plots
from dobwind.analysis.design import design_gain, with_gains
from dobwind.analysis.figures import figures, noise_gain
from dobwind.analysis.linear import axis_system, continuous_observer, jacobian_function, linearize
from dobwind.analysis.ramp import ramp_experiment
from dobwind.model.stability import unstable_reason
from dobwind.errors import EXIT_CHECK_FAILED, InputError
from dobwind.jsonout import print_json
from dobwind.logs import write_atomically
from dobwind.model.airframe import DISCRETIZATIONS, Airframe, load_airframe
from dobwind.model.airframe_toml import dump_airframe
from dobwind.model.step import build_step
from dobwind.outputs import OutputFiles, Target, check_targets

AXES = "xyz"
SCHEDULE_GRID_POINTS = 61


def _noise_unit(af: Airframe) -> str:
    return "N per m/s" if af.observer.acceleration == "velocity" else "N per m/s^2"


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


def analyze(af: Airframe, freqs_hz: list[float], with_ramp: bool = True) -> tuple[dict[str, Any], dict[str, Any]]:
    """(JSON-able report, python-control systems for the plots)."""
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
    if with_ramp and stable:
        ramp = ramp_experiment(af)
        systems["ramp"] = ramp
        report["ramp"] = {"scheduled_lag_s": ramp.scheduled_lag_s, "fixed_lag_s": ramp.fixed_lag_s,
                          "fixed_cutoff_hz": ramp.fixed_cutoff_hz, "lag_reduction_s": ramp.lag_reduction_s,
                          "paper_lag_reduction_s": 2.2}
    return report, systems


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
    return written


def _check_frequencies(af: Airframe, source: str, freqs_hz: list[float]) -> None:
    """A discrete system has no response above Nyquist to report: refuse instead of aliasing."""
    from dobwind.options import MAX_FREQUENCIES

    nyquist = 0.5 / af.observer.sample_time_s
    if len(freqs_hz) > MAX_FREQUENCIES:
        raise InputError(source, "--freq", f"at most {MAX_FREQUENCIES} frequencies, got {len(freqs_hz)}")
    for f in freqs_hz:
        if not f < nyquist:
            raise InputError(source, "--freq", f"{f:g} Hz is not below the Nyquist frequency {nyquist:g} Hz "
                             f"(1 / (2 * observer.sample_time))")


def analyze_command(args: argparse.Namespace) -> int:
    """Analyse the airframe; with --bandwidth, first replace its gains by the designed ones, write that
    airframe to -o (a TOML file in this mode, not a plot folder) and analyse it."""
    designing = args.bandwidth is not None
    target = None if args.output is None else Target("-o", args.output, "file" if designing else "dir")
    if target is not None:
        check_targets([target], [args.airframe])
    af = load_airframe(args.airframe)
    _check_frequencies(af, args.airframe, list(args.freq))
    design = _designed(af, args) if designing else None
    if design is not None:
        af = design[0]
    report, systems = analyze(af, list(args.freq))
    if design is not None:
        report["design"] = design[1]
        report["gains"] = design[1]["gains"]  # the key `analyze --bandwidth --json` printed before the design block
    if target is not None:
        with OutputFiles([target]) as out:
            if designing:
                text_toml = dump_airframe(af)
                write_atomically(out.stage(args.output), lambda handle: handle.write(text_toml))
            else:
                report["plots"] = [str(p) for p in write_plots(report, systems, Path(args.output), out.stage)]
    if args.json:
        print_json(report)
    else:
        if design is not None:
            print(_design_text(design[1]))
        print(text(report, list(args.freq)))
    if not report["stable"]:
        sys.stderr.write(f"dobwind analyze: {af.name}: unstable: {report['unstable_reason'] or 'a pole is outside the unit circle'}\n")
        return EXIT_CHECK_FAILED
    return 0


def _designed(af: Airframe, args: argparse.Namespace) -> tuple[Airframe, dict[str, Any]]:
    """The airframe with the gains that give --bandwidth, and what to report about the design."""
    try:
        gain = design_gain(af, args.bandwidth)
    except InputError as exc:  # name the file the user gave, not the airframe inside it
        raise InputError(args.airframe, exc.where, exc.message) from None
    new = with_gains(af, (gain, gain, gain))
    return new, {"bandwidth_hz": args.bandwidth, "gains": [gain, gain, gain], "gains_kg_per_s": [gain, gain, gain],
                 "previous_gains_kg_per_s": list(af.observer.gains), "sample_time_s": af.observer.sample_time_s,
                 "discretization": af.observer.discretization, "airframe_file": args.output}


def _design_text(design: dict[str, Any]) -> str:
    g = design["gains_kg_per_s"][0]
    where = f"; written to {design['airframe_file']}" if design["airframe_file"] else " (not written: no -o)"
    return (f"designed observer gains for a {design['bandwidth_hz']:g} Hz bandwidth at dt {design['sample_time_s']:g} s "
            f"({design['discretization']}):\ngains = [{g:.6g}, {g:.6g}, {g:.6g}]{where}\n")

