"""`dobwind analyze` as a command: the arguments in, the report and plots out, the exit code back.

The analysis itself (``dobwind.analysis.report``) knows nothing of argparse or exit codes; this module
checks the arguments, designs the gains for ``--bandwidth``, writes the outputs and says whether the
airframe passed.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

from dobwind.cli.common import AIRFRAME_HELP, JSON_HELP, Command
from dobwind.core import options as opt
from dobwind.core.errors import EXIT_CHECK_FAILED, InputError
from dobwind.core.options import MAX_AIRSPEEDS, MAX_FREQUENCIES, WindTargetSpec
from dobwind.io.outputs import OutputFiles, Target, check_targets

if TYPE_CHECKING:
    from dobwind.analysis.windunits import NoiseSource
    from dobwind.model.airframe import Airframe


def add(command: Command) -> None:
    p = command("analyze", "observer and filter poles, bandwidth, Bode plots; --bandwidth designs gains")
    p.add_argument("airframe", help=AIRFRAME_HELP)
    p.add_argument("-o", "--output", help="folder for the PNG plots (none are drawn without it); with --bandwidth: "
                   "the new airframe TOML with the designed gains (default: none, nothing written)")
    p.add_argument("--json", action="store_true", help=JSON_HELP)
    p.add_argument("--freq", type=opt.FREQUENCY, nargs="+", default=[0.1, 0.5, 1.0],
                   help=f"frequencies to report gain and phase at, Hz ({opt.FREQUENCY.text()}, below the Nyquist "
                        f"frequency 1/(2 sample_time); at most {opt.MAX_FREQUENCIES})")
    p.add_argument("--bandwidth", type=opt.DESIGN_TARGET, help="design the observer gains (kg/s, equal on x y z) that give "
                   f"this -3 dB bandwidth, Hz ({opt.DESIGN_TARGET.text()}; Hz below the Nyquist frequency), or "
                   "this wind noise along the airflow or ramp lag at an airspeed, then analyse the airframe with "
                   "those gains (default: none, analyse the gains in the file)")
    p.add_argument("--airspeed", type=opt.AIRSPEED, nargs="+", default=[],
                   help=f"airspeeds to report the wind-unit figures at besides the schedule's breakpoints, m/s "
                        f"({opt.AIRSPEED.text()}; at most {opt.MAX_AIRSPEEDS})")
    p.add_argument("--force-noise", type=opt.FORCE_NOISE, metavar="N",
                   help="1-sigma scatter of the observer's horizontal force estimate before the low-pass, per "
                        f"axis, at the file's gains, N ({opt.FORCE_NOISE.text()}); default: from the wind noise "
                        "the fit recorded in the airframe ([uncertainty] noise_h), else the wind noise is not given")
    p.set_defaults(func=run)


def _check_frequencies(af: Airframe, source: str, freqs_hz: list[float]) -> None:
    """A discrete system has no response above Nyquist to report: refuse instead of aliasing."""
    nyquist = 0.5 / af.observer.sample_time_s
    if len(freqs_hz) > MAX_FREQUENCIES:
        raise InputError(source, "--freq", f"at most {MAX_FREQUENCIES} frequencies, got {len(freqs_hz)}")
    for f in freqs_hz:
        if not f < nyquist:
            raise InputError(source, "--freq", f"{f:g} Hz is not below the Nyquist frequency {nyquist:g} Hz "
                             f"(1 / (2 * observer.sample_time))")


def run(args: argparse.Namespace) -> int:
    """Analyse the airframe; with --bandwidth, first replace its gains by the designed ones, write that
    airframe to -o (a TOML file in this mode, not a plot folder) and analyse it."""
    from dobwind.analysis.report import analyze, text, write_plots
    from dobwind.analysis.windunits import noise_source
    from dobwind.io.jsonout import print_json
    from dobwind.io.logs import write_atomically
    from dobwind.model.airframe import load_airframe
    from dobwind.model.step import build_step

    designing = args.bandwidth is not None
    target = None if args.output is None else Target("-o", args.output, "file" if designing else "dir")
    if target is not None:
        check_targets([target], [args.airframe])
    af = load_airframe(args.airframe)
    _check_frequencies(af, args.airframe, list(args.freq))
    airspeeds = list(getattr(args, "airspeed", []) or [])
    if len(airspeeds) > MAX_AIRSPEEDS:
        raise InputError(args.airframe, "--airspeed", f"at most {MAX_AIRSPEEDS} airspeeds, got {len(airspeeds)}")
    force_noise = getattr(args, "force_noise", None)
    # The noise is referred to the observer's input at the FILE's gains (--force-noise and the fit's
    # recorded noise were measured there), before a design changes them.
    noise = noise_source(af, build_step(af), force_noise) if designing else None
    design = _designed(af, args, noise) if designing else None
    if design is not None:
        af = design[0]
    try:
        report, systems = analyze(af, list(args.freq), airspeeds_mps=tuple(airspeeds), force_noise_n=force_noise,
                                  input_noise=noise)
    except InputError as exc:  # name the file the user gave, not the airframe inside it
        raise InputError(args.airframe, exc.where, exc.message) from None
    if design is not None:
        report["design"] = design[1]
        report["gains"] = design[1]["gains"]  # the key `analyze --bandwidth --json` printed before the design block
        if not report["stable"]:
            design[1]["airframe_file"] = None  # refused below: say so in the design text and the JSON
    # A designed airframe that is unstable would be refused by check and generate: the failed design is
    # reported, and its file is not written (a command writes nothing unless it succeeds).
    if target is not None and not (designing and not report["stable"]):
        with OutputFiles([target]) as out:
            if designing:
                text_toml = designed_text(args.airframe, af, design[1]["bandwidth_hz"])
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
        unwritten = f" ({args.output} not written)" if designing and args.output is not None else ""
        sys.stderr.write(f"dobwind analyze: {af.name}: unstable: {report['unstable_reason'] or 'a pole is outside the unit circle'}"
                         f"{unwritten}\n")
        return EXIT_CHECK_FAILED
    return 0


def _designed(af: Airframe, args: argparse.Namespace, noise: NoiseSource | None) -> tuple[Airframe, dict[str, Any]]:
    """The airframe with the gains that give --bandwidth, and what to report about the design."""
    from dobwind.analysis.design import WindTarget, design_gain, design_gain_for_wind, observer_bandwidth_hz, with_gains

    target = args.bandwidth
    try:
        if isinstance(target, WindTargetSpec):
            wind = WindTarget(target.kind, target.value, target.airspeed_mps)
            gain = design_gain_for_wind(af, wind, None if noise is None else noise.input_sigma)
        else:
            gain = design_gain(af, target)
    except InputError as exc:  # name the file the user gave, not the airframe inside it
        raise InputError(args.airframe, exc.where, exc.message) from None
    new = with_gains(af, (gain, gain, gain))
    if isinstance(target, WindTargetSpec):
        bandwidth = observer_bandwidth_hz(new, gain)
        extra = {"target": {"kind": target.kind, "value": target.value, "airspeed_mps": target.airspeed_mps,
                            "unit": "m/s" if target.kind == "noise" else "s"}}
    else:
        bandwidth, extra = target, {}
    return new, {"bandwidth_hz": bandwidth, **extra, "gains": [gain, gain, gain], "gains_kg_per_s": [gain, gain, gain],
                 "previous_gains_kg_per_s": list(af.observer.gains), "sample_time_s": af.observer.sample_time_s,
                 "discretization": af.observer.discretization, "airframe_file": args.output}


def designed_text(source: str, af: Airframe, bandwidth_hz: float) -> str:
    """The airframe file's own text with the designed gains put in (its comments kept); the full dump
    when the gains are written in a form the text edit does not handle, or the edit would not parse
    back to ``af``'s gains."""
    from dobwind.io.tomledit import replace_array
    from dobwind.model.airframe import parse_airframe, resolve_airframe_path
    from dobwind.model.airframe_toml import dump_airframe

    path = resolve_airframe_path(source)
    literal = "[" + ", ".join(repr(float(g)) for g in af.observer.gains) + "]"
    comment = f"kg/s: {bandwidth_hz:.4g} Hz bandwidth (designed by `dobwind analyze {path.name} --bandwidth`)"
    edited = replace_array(path.read_text(encoding="utf-8"), "observer", "gains", literal, comment)
    if edited is not None:
        try:
            if parse_airframe(edited, str(path)).observer.gains == af.observer.gains:
                return edited
        except InputError:
            pass
    return dump_airframe(af)


def _design_text(design: dict[str, Any]) -> str:
    g = design["gains_kg_per_s"][0]
    where = f"; written to {design['airframe_file']}" if design["airframe_file"] else " (not written)"
    if "target" in design:
        t = design["target"]
        return (f"designed observer gains for a wind {t['kind']} of {t['value']:g} {t['unit']} at "
                f"{t['airspeed_mps']:g} m/s airspeed (observer bandwidth {design['bandwidth_hz']:.4g} Hz) at dt "
                f"{design['sample_time_s']:g} s ({design['discretization']}):\ngains = [{g:.6g}, {g:.6g}, {g:.6g}]{where}\n")
    return (f"designed observer gains for a {design['bandwidth_hz']:g} Hz bandwidth at dt {design['sample_time_s']:g} s "
            f"({design['discretization']}):\ngains = [{g:.6g}, {g:.6g}, {g:.6g}]{where}\n")

